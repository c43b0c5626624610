//! `ema firmware-trace`: regenerates the firmware's built-in trace (`traces/standard.ematrace`) from
//! the reference model.
//!
//! ```text
//! ema firmware-trace [--out FILE]     # default: <repo>/traces/standard.ematrace
//! ema firmware-trace --from RECORDING.csv --out FILE.ematrace
//! ```
//!
//! The recording is fixed, so the file is reproducible byte for byte (the test
//! `tests/firmware_trace.rs` regenerates it in memory and compares it with the committed copy):
//! the standard profile ([`Profile::STANDARD`], 0.85 s), nominal parameters, no unmodelled effect,
//! sensor noise on with seed [`FIRMWARE_TRACE_SEED`], and the fault vector
//! [`FIRMWARE_TRACE_FAULTS`] (a small friction fault, so the on-board demo has something to
//! diagnose). The file holds the three phase currents exactly as the reference model's 12-bit ADC
//! coded them (`Sample::adc_counts`, not re-quantized amperes), 10 kHz, packed with
//! [`ema_monitor::trace::pack`]: 8500 frames, 38 262 bytes.
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

use std::path::{Path, PathBuf};

use clap::Args;
use ema_monitor::trace::{amps_to_counts, pack, packed_len, PackedTrace, SAMPLE_RATE_HZ};
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, Effects, SimConfig};

use crate::error::CliError;
use crate::identify::check_recording;
use crate::recording_io::{read_recording, Recording};

/// Fault vector of the built-in trace: friction `k1 = 0.25`, everything else healthy
/// (`ecc_phase` and `gain` at their neutral 0.5).
pub const FIRMWARE_TRACE_FAULTS: FaultVector = FaultVector([0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);

/// Seed of the reference model's sensor noise for the built-in trace (`ema simulate`'s default seed).
pub const FIRMWARE_TRACE_SEED: u64 = 1;

/// Arguments of `ema firmware-trace`.
#[derive(Args, Debug, Clone)]
pub struct FirmwareTraceArgs {
    /// Output file [default: traces/standard.ematrace at the repository root; required with --from].
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Pack this recording CSV (10 kHz, standard profile, 8500 rows) instead of the built-in run.
    #[arg(long, value_name = "RECORDING")]
    pub from: Option<PathBuf>,
}

/// Frames of a firmware trace: the standard profile at 10 kHz (8500, as the built-in trace).
pub const FIRMWARE_TRACE_FRAMES: usize = 8500;

/// The firmware's built-in trace: `<repo>/traces/standard.ematrace`, found from this crate's
/// manifest directory (`<repo>/host-tests/cli`), so it does not depend on the working directory.
pub fn default_out() -> PathBuf {
    let cli = Path::new(env!("CARGO_MANIFEST_DIR"));
    let repo = cli.parent().and_then(Path::parent).unwrap_or(cli);
    repo.join("traces").join("standard.ematrace")
}

/// The reference-model configuration of the built-in trace.
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

/// Simulates [`firmware_trace_config`] and packs the recorded ADC codes of the three phases:
/// the exact content of `traces/standard.ematrace`.
pub fn firmware_trace_bytes() -> Result<Vec<u8>, CliError> {
    let recording = simulate(&firmware_trace_config()).map_err(|e| CliError::Simulation(e.to_string()))?;
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

/// Packs a recording read from `path` (named in messages) into a firmware trace: checks the
/// sample rate and the standard profile's command, requires [`FIRMWARE_TRACE_FRAMES`] rows.
pub fn recording_trace_bytes(recording: &Recording, path: &Path) -> Result<Vec<u8>, CliError> {
    check_recording(recording, path, &Profile::STANDARD, &EmaParams::NOMINAL)?;
    if recording.len() != FIRMWARE_TRACE_FRAMES {
        return Err(CliError::Input {
            path: path.to_path_buf(),
            message: format!(
                "{} rows, but a firmware trace holds exactly {FIRMWARE_TRACE_FRAMES} frames (the standard profile, \
                 {} s at {SAMPLE_RATE_HZ} Hz)",
                recording.len(),
                Profile::STANDARD.duration_s()
            ),
        });
    }
    let frames: Vec<[u16; 3]> = (0..recording.len())
        .map(|k| [recording.ia_a[k], recording.ib_a[k], recording.ic_a[k]].map(|i| amps_to_counts(i as f32)))
        .collect();
    let mut bytes = vec![0u8; packed_len(frames.len())];
    let n = pack(&frames, SAMPLE_RATE_HZ, &mut bytes).map_err(|e| CliError::Input {
        path: path.to_path_buf(),
        message: format!("the recording cannot be packed: {e}"),
    })?;
    bytes.truncate(n);
    Ok(bytes)
}

/// Runs `ema firmware-trace`; returns the one-line summary printed on success.
pub fn run(args: &FirmwareTraceArgs) -> Result<String, CliError> {
    if let Some(from) = &args.from {
        return run_from(from, args.out.as_deref());
    }
    let out = args.out.clone().unwrap_or_else(default_out);
    let bytes = firmware_trace_bytes()?;
    let trace = PackedTrace::parse(&bytes)
        .map_err(|e| CliError::Simulation(format!("the packed trace does not read back: {e}")))?;
    std::fs::write(&out, &bytes).map_err(|source| CliError::Io { path: out.clone(), source })?;
    let k: Vec<String> = FIRMWARE_TRACE_FAULTS.0.iter().map(|v| v.to_string()).collect();
    Ok(format!(
        "wrote {} frames at {} Hz ({} bytes) to {}: profile standard, faults {}, noise on, seed {}",
        trace.frames(),
        trace.sample_rate_hz(),
        bytes.len(),
        out.display(),
        k.join(","),
        FIRMWARE_TRACE_SEED
    ))
}

/// `ema firmware-trace --from RECORDING --out FILE`.
fn run_from(from: &Path, out: Option<&Path>) -> Result<String, CliError> {
    let out = out.ok_or_else(|| {
        CliError::flag("--out", "--from needs --out FILE (the built-in traces/standard.ematrace is not overwritten)")
    })?;
    let recording = read_recording(from)?;
    let bytes = recording_trace_bytes(&recording, from)?;
    let trace = PackedTrace::parse(&bytes)
        .map_err(|e| CliError::Simulation(format!("the packed trace does not read back: {e}")))?;
    std::fs::write(out, &bytes).map_err(|source| CliError::Io { path: out.to_path_buf(), source })?;
    Ok(format!(
        "wrote {} frames at {} Hz ({} bytes) to {} from {}; run it on board: EMA_TRACE={} cargo run --release",
        trace.frames(),
        trace.sample_rate_hz(),
        bytes.len(),
        out.display(),
        from.display(),
        out.display()
    ))
}
