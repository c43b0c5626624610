//! `ema firmware-trace`: regenerates the firmware's built-in trace (`traces/standard.ematrace`) from
//! the reference model.
//!
//! ```text
//! ema firmware-trace [--out FILE] [--force]                       # default: ./standard.ematrace
//! ema firmware-trace --profile pbit [--out FILE] [--force]        # default: ./pbit.ematrace
//! ema firmware-trace --from RECORDING.csv [--out FILE] [--force]  # default: ./RECORDING.ematrace
//! ```
//!
//! Without `--out` the file goes to the current directory, named after the input
//! ([`default_out`]), never into the source tree: the committed trace is replaced only on request,
//! `firmware-trace --out ../traces/standard.ematrace --force` from `host-tests/`. An existing file
//! is replaced only with `--force`, checked before the run, and the file is written whole or not
//! at all ([`crate::output`]).
//!
//! The recording is fixed, so the file is reproducible byte for byte (the test
//! `tests/firmware_trace.rs` regenerates it in memory and compares it with the committed copy):
//! the standard profile ([`Profile::STANDARD`], 0.85 s), nominal parameters, no unmodelled effect,
//! sensor noise on with seed [`FIRMWARE_TRACE_SEED`], and the fault vector
//! [`FIRMWARE_TRACE_FAULTS`] (a small friction fault, so the on-board demo has something to
//! diagnose). The file holds the three phase currents exactly as the reference model's 12-bit ADC
//! coded them (`Sample::adc_counts`, not re-quantized amperes), 10 kHz, packed with
//! [`ema_monitor::trace::pack`] as `EMA3`, with its CRC-32: 8500 frames, 38 270 bytes.
//!
//! `--profile pbit` records the pre-flight built-in test ([`Profile::PBIT`], 0.88 s) instead,
//! with the same actuator, faults and seed: `traces/pbit.ematrace`, 8800 frames, 39 620 bytes,
//! which the firmware replays when built with `EMA_PROFILE=pbit`.
//!
//! The same recording as CSV: `ema simulate --faults 0.25,0,0,0,0,0,0.5,0.5 --seed 1 --out FILE.csv`
//! (its current columns are `counts_to_amps` of these codes).
//!
//! `--from RECORDING.csv` packs a recording instead (any `ema simulate` CSV, e.g. one with a hidden
//! `--effect`), so the firmware can replay it: `EMA_TRACE=X.ematrace cargo run --release`. The
//! recording must be what the firmware replays: 10 kHz, the standard profile's command, and exactly
//! [`FIRMWARE_TRACE_FRAMES`] rows. Each current goes through
//! [`amps_to_counts`], which gives back the recorded ADC code
//! exactly for a quantized recording (the default), so packing the CSV of the built-in run
//! reproduces `traces/standard.ematrace` byte for byte.
//!
//! A recording that opens before the manoeuvre (a bench's pre-trigger, `ema simulate
//! --pre-trigger-ms`) keeps up to [`MAX_PRE_TRIGGER_FRAMES`] (100 ms) of it: the frames on the
//! 10 kHz grid just before the aligned start ([`RecordingArgs::load_with_pre_trigger`]), packed
//! in a trace whose trigger frame is their count, so that the firmware raises its trigger at the
//! manoeuvre's first frame and its self-calibration can read the sensors' zero points from the
//! frames before. Without such frames the trigger frame is 0.

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use ema_monitor::trace::{amps_to_counts, pack, packed_len, PackedTrace, TraceHeader, SAMPLE_RATE_HZ};
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, Effects, SimConfig};

use crate::error::CliError;
use crate::output::{check_file, write_files, OutputArgs, Overwrite};
use crate::params::ParamsArgs;
use crate::progress::{self, ProgressArgs};
use crate::recording::{Recording, RecordingArgs};
use crate::runtime::recording::check_recording;

pub use crate::runtime::firmware::MAX_PRE_TRIGGER_FRAMES;

/// Fault vector of the built-in trace: friction `k1 = 0.25`, everything else healthy
/// (`ecc_phase` and `gain` at their neutral 0.5).
pub const FIRMWARE_TRACE_FAULTS: FaultVector = FaultVector([0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);

/// Seed of the reference model's sensor noise for the built-in trace (`ema simulate`'s default seed).
pub const FIRMWARE_TRACE_SEED: u64 = 1;

/// Arguments of `ema firmware-trace`.
#[derive(Args, Debug, Clone)]
#[command(mut_arg("out", |a| a.value_name("FILE").help("Output file [default: in the current directory, \
    standard.ematrace, or with --from the recording's name with the extension .ematrace]. To regenerate \
    the committed trace, from host-tests/: --out ../traces/standard.ematrace --force")))]
pub struct FirmwareTraceArgs {
    /// `--out FILE` and `--force`.
    #[command(flatten)]
    pub output: OutputArgs,
    /// Pack this recording CSV (10 kHz, standard profile, 8500 rows of the manoeuvre) instead of the
    /// built-in run; up to 100 ms of rows before the manoeuvre are kept as pre-trigger frames (the
    /// trace's trigger frame is the manoeuvre's first).
    #[arg(long, value_name = "RECORDING")]
    pub from: Option<PathBuf>,
    /// The actuator's parameters: the built-in run simulates it (pair the trace with the same
    /// file in EMA_PARAMS); --from checks the recording against its control period.
    #[command(flatten)]
    pub params: ParamsArgs,
    /// How to read the --from recording.
    #[command(flatten)]
    pub recording: RecordingArgs,
    /// The manoeuvre of the built-in run (the firmware's `EMA_PROFILE`).
    #[arg(long, value_enum, default_value_t = BuiltInProfile::Standard, conflicts_with = "from")]
    pub profile: BuiltInProfile,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
}

/// A manoeuvre the firmware can fly (`EMA_PROFILE` at build time).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BuiltInProfile {
    /// [`Profile::STANDARD`] (0.85 s): `traces/standard.ematrace`.
    Standard,
    /// [`Profile::PBIT`] (0.88 s), the pre-flight built-in test: `traces/pbit.ematrace`.
    Pbit,
}

impl BuiltInProfile {
    /// The profile.
    pub fn profile(self) -> Profile {
        match self {
            BuiltInProfile::Standard => Profile::STANDARD,
            BuiltInProfile::Pbit => Profile::PBIT,
        }
    }

    /// Its name: `standard` or `pbit`.
    pub fn name(self) -> &'static str {
        match self {
            BuiltInProfile::Standard => "standard",
            BuiltInProfile::Pbit => "pbit",
        }
    }
}

/// Frames of a firmware trace: the standard profile at 10 kHz (8500, as the built-in trace).
pub const FIRMWARE_TRACE_FRAMES: usize = 8500;

/// Where `ema firmware-trace` writes without `--out`: a file in the current directory, named
/// `standard.ematrace` for the built-in run, or after the recording packed with `--from`
/// (`runs/rec.csv` gives `rec.ematrace`). A user's working directory, not the source tree: the
/// committed `traces/standard.ematrace` changes only when named with `--out`.
pub fn default_out(from: Option<&Path>) -> PathBuf {
    let stem = from.and_then(Path::file_stem).map_or_else(|| "standard".into(), |s| s.to_os_string());
    let mut name = stem;
    name.push(".ematrace");
    PathBuf::from(name)
}

/// The reference-model configuration of the built-in trace (the nominal actuator).
pub fn firmware_trace_config() -> SimConfig {
    SimConfig {
        params: EmaParams::NOMINAL,
        faults: FIRMWARE_TRACE_FAULTS,
        effects: Effects::NONE,
        profile: Profile::STANDARD,
        noise: true,
        seed: FIRMWARE_TRACE_SEED,
        quantization: true,
        ..SimConfig::default()
    }
}

/// Simulates [`firmware_trace_config`] with the actuator `params` and packs the recorded ADC
/// codes of the three phases: with [`EmaParams::NOMINAL`], the exact content of
/// `traces/standard.ematrace`.
pub fn firmware_trace_bytes(params: &EmaParams) -> Result<Vec<u8>, CliError> {
    firmware_trace_bytes_for(params, BuiltInProfile::Standard)
}

/// [`firmware_trace_bytes`] of the manoeuvre `profile`: with [`EmaParams::NOMINAL`] and
/// [`BuiltInProfile::Pbit`], the exact content of `traces/pbit.ematrace`.
pub fn firmware_trace_bytes_for(params: &EmaParams, profile: BuiltInProfile) -> Result<Vec<u8>, CliError> {
    let config = SimConfig { params: *params, profile: profile.profile(), ..firmware_trace_config() };
    let recording = simulate(&config).map_err(|e| CliError::Simulation(e.to_string()))?;
    let period = 1.0 / f64::from(SAMPLE_RATE_HZ);
    if (recording.sample_period_s - period).abs() > 1e-9 * period {
        return Err(CliError::Simulation(format!(
            "the recording's sample period is {} s, the firmware trace needs {period} s ({SAMPLE_RATE_HZ} Hz)",
            recording.sample_period_s
        )));
    }
    let frames: Vec<[u16; 3]> = recording.samples.iter().map(|s| s.adc_counts).collect();
    let mut bytes = vec![0u8; packed_len(frames.len())];
    let n = pack(&frames, SAMPLE_RATE_HZ, &mut bytes)
        .map_err(|e| CliError::Simulation(format!("the recording cannot be packed: {e}")))?;
    bytes.truncate(n);
    Ok(bytes)
}

/// Packs a recording read from `path` (named in messages) into a firmware trace, after the rows
/// of `pre_trigger` (at most [`MAX_PRE_TRIGGER_FRAMES`]; none gives trigger frame 0): checks the
/// sample rate and the standard profile's command, requires [`FIRMWARE_TRACE_FRAMES`] rows of the
/// manoeuvre.
pub fn recording_trace_bytes(
    recording: &Recording,
    pre_trigger: &Recording,
    path: &Path,
    params: &EmaParams,
) -> Result<Vec<u8>, CliError> {
    check_recording(recording, path, &Profile::STANDARD, params)?;
    if recording.len() != FIRMWARE_TRACE_FRAMES {
        return Err(CliError::input(
            path,
            format!(
                "{} rows, but a firmware trace holds exactly {FIRMWARE_TRACE_FRAMES} frames (the standard profile, \
                 {} s at {SAMPLE_RATE_HZ} Hz)",
                recording.len(),
                Profile::STANDARD.duration_s()
            ),
        ));
    }
    if pre_trigger.len() > MAX_PRE_TRIGGER_FRAMES {
        return Err(CliError::input(
            path,
            format!(
                "{} rows before the manoeuvre, but a firmware trace keeps at most {MAX_PRE_TRIGGER_FRAMES}",
                pre_trigger.len()
            ),
        ));
    }
    let codes = |r: &Recording, k: usize| [r.ia_a[k], r.ib_a[k], r.ic_a[k]].map(|i| amps_to_counts(i as f32));
    let frames: Vec<[u16; 3]> = (0..pre_trigger.len())
        .map(|k| codes(pre_trigger, k))
        .chain((0..recording.len()).map(|k| codes(recording, k)))
        .collect();
    // at most MAX_PRE_TRIGGER_FRAMES: fits a u32
    let header = TraceHeader::new(SAMPLE_RATE_HZ, pre_trigger.len() as u32);
    let mut bytes = vec![0u8; header.packed_len(frames.len())];
    let n = pack(&frames, header, &mut bytes)
        .map_err(|e| CliError::input(path, format!("the recording cannot be packed: {e}")))?;
    bytes.truncate(n);
    Ok(bytes)
}

/// Runs `ema firmware-trace`; returns the one-line summary printed on success.
pub fn run(args: &FirmwareTraceArgs) -> Result<String, CliError> {
    let out = args.output.out.clone().unwrap_or_else(|| match (args.from.as_deref(), args.profile) {
        (None, BuiltInProfile::Pbit) => PathBuf::from("pbit.ematrace"),
        (from, _) => default_out(from),
    });
    let overwrite = args.output.overwrite();
    check_file(&out, overwrite)?;
    let params = args.params.load()?;
    if let Some(from) = &args.from {
        return run_from(from, &args.recording, &out, overwrite, &params);
    }
    let spinner = progress::spinner(format!("simulating {}", out.display()), args.progress.visible());
    let bytes = firmware_trace_bytes_for(&params, args.profile);
    spinner.finish_and_clear();
    let bytes = bytes?;
    let trace = PackedTrace::parse(&bytes)
        .map_err(|e| CliError::Simulation(format!("the packed trace does not read back: {e}")))?;
    write_files(&[(&out, &bytes)], overwrite)?;
    let k: Vec<String> = FIRMWARE_TRACE_FAULTS.0.iter().map(|v| v.to_string()).collect();
    Ok(format!(
        "wrote {} frames at {} Hz ({} bytes) to {}: profile {}, faults {}, noise on, seed {}",
        trace.frames(),
        trace.sample_rate_hz(),
        bytes.len(),
        out.display(),
        args.profile.name(),
        k.join(","),
        FIRMWARE_TRACE_SEED
    ))
}

/// `ema firmware-trace --from RECORDING [--out FILE]`.
fn run_from(
    from: &Path,
    how: &RecordingArgs,
    out: &Path,
    overwrite: Overwrite,
    params: &EmaParams,
) -> Result<String, CliError> {
    let loaded = how.load_with_pre_trigger(from, Some(&Profile::STANDARD), params, MAX_PRE_TRIGGER_FRAMES)?;
    let bytes = recording_trace_bytes(&loaded.recording, &loaded.pre_trigger, from, params)?;
    let trace = PackedTrace::parse(&bytes)
        .map_err(|e| CliError::Simulation(format!("the packed trace does not read back: {e}")))?;
    write_files(&[(out, &bytes)], overwrite)?;
    let trigger = match trace.trigger_frame() {
        0 => String::new(),
        t => format!(", trigger at frame {t} after {} ms at rest", f64::from(t) * 1e3 / f64::from(SAMPLE_RATE_HZ)),
    };
    Ok(format!(
        "wrote {} frames at {} Hz ({} bytes{trigger}) to {} from {}; run it on board: EMA_TRACE={} cargo run --release",
        trace.frames(),
        trace.sample_rate_hz(),
        bytes.len(),
        out.display(),
        from.display(),
        out.display()
    ))
}
