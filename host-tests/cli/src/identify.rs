//! `ema identify`: the `no_std` core built for the host — the same code as the firmware —
//! identifies the faults behind a recording and prints the health report.
//!
//! Two inputs:
//! - a recording CSV (`ema simulate`'s format, 10 kHz): phase currents in amperes pass the same
//!   range, stuck-channel and sum checks as on board ([`FrameCheck::amps`], the core's code with
//!   the nominal calibration); a refused frame is held at the last good one and counted, and too
//!   many make the report `SENSOR_FAULT`, as [`monitor::acquire`] does. The monitor model is
//!   driven by the command profile (`--command profile`, the default: `--profile`, default
//!   `standard`), and then the command column must match it, or by the recording's own command
//!   column (`--command recorded`: any manoeuvre, sampled at 10 kHz into the core's
//!   [`SampledCommand`], at most [`HOST_COMMAND_SAMPLES`] rows, every value inside the end stops);
//! - `--firmware-trace FILE`: the firmware's packed 12-bit trace, read through the same replay ADC,
//!   `OneShot` reader and fixed-point calibration as on the MCU, with the on-board window, swarm
//!   and settings — its report is bit-identical to the firmware's. `--bits` prints the fault
//!   vector's bits and the firmware's summary line ([`summary_line`]: status, fitness bits,
//!   evaluations, fault bits; or [`Refusal::summary_line`] for a refused trace), which
//!   `scripts/parity` compares line for line with the firmware's in QEMU.
//!
//! `--model-config FILE` switches the monitor model's effect terms on from a model configuration
//! file (`effect ID SEVERITY` lines, [`ema_monitor::effects::parse_model_config`]), the same file
//! and the same parser as the firmware build (`EMA_MODEL_CONFIG=FILE cargo run --release`), so a
//! host run and a firmware run of one configuration can be compared.

use std::fmt::{Debug, Display};
use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, ValueEnum};
use ema_monitor::acquisition::{
    AcquisitionConfig, Calibration, FrameCheck, PhaseA, PhaseB, PhaseC, PhaseCurrentReader, ReplayAdc,
};
use ema_monitor::command::{CommandError, CommandSource};
use ema_monitor::conditioning::{MeasuredTrace, DECIMATION};
use ema_monitor::effects::{parse_model_config, ModelEffects};
use ema_monitor::health::{Abstain, HealthReport, Status};
use ema_monitor::monitor::{
    self, AcquisitionSummary, Algorithm, Identification, IdentifyConfig, WarmReport, GROUP_NAMES, ONBOARD_POPULATION,
    ONBOARD_WINDOW,
};
use ema_monitor::optimizer::{Objective, Status as SearchStatus};
use ema_monitor::trace::{packed_len, PackedTrace};
use ema_monitor::FAULT_COUNT;
use ema_monitor::{Command, EmaParams, FaultVector, Profile, SampledCommand};
use rayon::prelude::*;
use serde::Serialize;

use crate::error::CliError;
use crate::input;
use crate::params::ParamsArgs;
use crate::progress::{self, ProgressArgs};
use crate::recording::{LoadSummary, Recording, RecordingArgs};
use crate::schema::Document;
use crate::simulate::resolve_profile;

/// Window capacity for host identifications from CSV: 3.2 s of recording at the 2.5 kHz fitness rate.
pub const HOST_WINDOW: usize = 8192;

/// Most rows `--command recorded` takes: the command buffer holds the host window's length at the
/// control rate, [`HOST_WINDOW`] × [`DECIMATION`] = 32 768 samples (3.2768 s at 10 kHz, 128 KiB).
pub const HOST_COMMAND_SAMPLES: usize = HOST_WINDOW * DECIMATION;

/// Largest difference between the recorded command and the profile before the file is refused.
pub const COMMAND_TOLERANCE_RAD: f64 = 1e-6;

/// Optimizer choice on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AlgorithmArg {
    /// Particle swarm (default, as on board).
    Pso,
    /// Genetic algorithm.
    Ga,
    /// Differential evolution.
    De,
}

impl From<AlgorithmArg> for Algorithm {
    fn from(a: AlgorithmArg) -> Self {
        match a {
            AlgorithmArg::Pso => Algorithm::Pso,
            AlgorithmArg::Ga => Algorithm::Ga,
            AlgorithmArg::De => Algorithm::De,
        }
    }
}

/// What drives the monitor model (`--command` of `ema identify` and `ema discover`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum CommandArg {
    /// The command profile given by `--profile`; the recording's command column must match it.
    Profile,
    /// The recording's own command column, whatever the manoeuvre (no profile needed).
    Recorded,
}

/// The command that drives the monitor model, as `--command` and `--profile` chose it.
#[derive(Clone, Debug, PartialEq)]
#[allow(clippy::large_enum_variant, reason = "one per command run; the sampled command is boxed already")]
pub enum ModelCommand {
    /// A command profile, with the name it was given by (`standard` or a file).
    Profile {
        /// The profile.
        profile: Profile,
        /// `standard` or the profile file's path.
        name: String,
    },
    /// The recording's command column, sampled at the control rate (stride 1).
    Recorded(Box<SampledCommand<HOST_COMMAND_SAMPLES>>),
}

impl ModelCommand {
    /// The core's command source.
    pub fn command(&self) -> Command<'_> {
        match self {
            ModelCommand::Profile { profile, .. } => Command::Profile(*profile),
            ModelCommand::Recorded(samples) => samples.as_command(),
        }
    }

    /// `profile standard`, `profile FILE` or `recorded (8500 samples at 10000 Hz, 0.85 s)`.
    pub fn label(&self) -> String {
        self.to_json().label()
    }

    /// The profile, when a profile drives the model.
    pub fn profile(&self) -> Option<&Profile> {
        match self {
            ModelCommand::Profile { profile, .. } => Some(profile),
            ModelCommand::Recorded(_) => None,
        }
    }

    /// The JSON report's `command`: `{"source": "profile", "profile": NAME}` or
    /// `{"source": "recorded", "samples": N, "duration_s": T}`.
    pub fn to_json(&self) -> CommandJson {
        match self {
            ModelCommand::Profile { name, .. } => {
                CommandJson { source: "profile", profile: Some(name.clone()), samples: None, duration_s: None }
            }
            ModelCommand::Recorded(s) => CommandJson {
                source: "recorded",
                profile: None,
                samples: Some(s.samples().len()),
                duration_s: Some(s.samples().len() as f64 / control_rate_hz()),
            },
        }
    }
}

/// What drove the monitor model, in the JSON reports of `ema identify` and `ema discover`.
#[derive(Clone, Debug, Serialize)]
pub struct CommandJson {
    /// `profile` or `recorded`.
    pub source: &'static str,
    /// The profile's name (`standard` or its file), under `profile`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub profile: Option<String>,
    /// Samples of the recorded command, under `recorded`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// Length of the recorded command (s), under `recorded`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub duration_s: Option<f64>,
}

impl CommandJson {
    /// `profile NAME`, or `recorded (N samples at R Hz, T s)`.
    pub fn label(&self) -> String {
        match (&self.profile, self.samples, self.duration_s) {
            (Some(name), _, _) => format!("profile {name}"),
            (None, Some(n), Some(t)) => format!("recorded ({n} samples at {} Hz, {t} s)", control_rate_hz()),
            _ => self.source.to_owned(),
        }
    }
}

/// The nominal control rate in Hz, rounded to an integer (10 000).
fn control_rate_hz() -> f64 {
    (1.0 / f64::from(EmaParams::NOMINAL.control_period_s)).round()
}

/// The command `--command` names for `recording` (read from `path`, named in errors): the profile
/// `profile` (`standard` or a file), or the recording's command column ([`resolve_command`], then
/// [`command_for`]).
pub fn model_command(
    arg: CommandArg,
    profile: &str,
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
) -> Result<ModelCommand, CliError> {
    command_for(resolve_command(arg, profile)?, recording, path, params)
}

/// The flags' part of [`model_command`], checked before the recording is read: the profile
/// `profile` resolved (`Some`) under `--command profile`, `None` under `--command recorded`, which
/// refuses a `--profile` other than `standard` (the recorded command replaces the profile).
pub fn resolve_command(arg: CommandArg, profile: &str) -> Result<Option<ModelCommand>, CliError> {
    match arg {
        CommandArg::Profile => {
            Ok(Some(ModelCommand::Profile { profile: resolve_profile(profile)?, name: profile.to_owned() }))
        }
        CommandArg::Recorded if profile != "standard" => Err(CliError::flag(
            "--profile",
            "--command recorded drives the model by the recording's command column; drop --profile",
        )),
        CommandArg::Recorded => Ok(None),
    }
}

/// The resolved command ([`resolve_command`]), or for `None` the recording's command column
/// ([`recorded_command`]).
pub fn command_for(
    resolved: Option<ModelCommand>,
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
) -> Result<ModelCommand, CliError> {
    match resolved {
        Some(command) => Ok(command),
        None => recorded_command(recording, path, params).map(ModelCommand::Recorded),
    }
}

/// The recording's command column as the core's sampled command at the control rate: at most
/// [`HOST_COMMAND_SAMPLES`] rows, every value inside the end stops of `params`; errors name the
/// file, the line and the limit.
pub fn recorded_command(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
) -> Result<Box<SampledCommand<HOST_COMMAND_SAMPLES>>, CliError> {
    if recording.len() > HOST_COMMAND_SAMPLES {
        let rate_hz = (1.0 / f64::from(params.control_period_s)).round();
        return Err(input_error(
            path,
            &format!(
                "{} rows ({} s); --command recorded holds at most {HOST_COMMAND_SAMPLES} rows ({} s at {rate_hz} Hz): \
                 trim the recording",
                recording.len(),
                recording.len() as f64 / rate_hz,
                HOST_COMMAND_SAMPLES as f64 / rate_hz,
            ),
        ));
    }
    let samples = recording.command_rad.iter().map(|&c| c as f32);
    SampledCommand::new(samples, 1, params.end_stop_rad).map(Box::new).map_err(|e| match e {
        CommandError::NotFinite { index } | CommandError::BeyondEndStops { index } => input_error(
            path,
            &format!(
                "line {}, field command_rad: {} rad; the command must be finite and inside the end stops (±{} rad)",
                line_of(recording, index),
                recording.command_rad.get(index).copied().unwrap_or(f64::NAN),
                params.end_stop_rad
            ),
        ),
        e => input_error(path, &e.to_string()),
    })
}

/// Arguments of `ema identify`.
#[derive(Args, Debug, Clone)]
pub struct IdentifyArgs {
    /// Recording CSV to identify (docs/recordings.md: columns, delimiter, 5-100 kHz, trimming);
    /// several recordings of one actuator (at most 10) are fitted by one fault vector
    /// (`pooled over N recordings`), each read with the same flags.
    #[arg(value_name = "FILE", required_unless_present = "firmware_trace", conflicts_with = "firmware_trace")]
    pub files: Vec<PathBuf>,
    /// How to read the recording.
    #[command(flatten)]
    pub recording: RecordingArgs,
    /// Identify the firmware's packed trace instead, exactly as the firmware does.
    #[arg(long, value_name = "FILE")]
    pub firmware_trace: Option<PathBuf>,
    /// Optimizer.
    #[arg(long, value_enum, default_value = "pso")]
    pub algorithm: AlgorithmArg,
    /// Seed of the optimizer's random generator.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Iteration limit [default: 200 (the paper) for a CSV, the on-board 40 for --firmware-trace].
    #[arg(long)]
    pub max_iterations: Option<u32>,
    /// Model configuration file (`effect ID SEVERITY` lines): the monitor model's effect terms,
    /// as `EMA_MODEL_CONFIG` gives them to the firmware [default: none].
    #[arg(long, value_name = "CONFIG")]
    pub model_config: Option<PathBuf>,
    /// Command profile the recording was made with: `standard`, `pbit` or a profile file.
    #[arg(long, default_value = "standard")]
    pub profile: String,
    /// What drives the monitor model: the command profile (`--profile`, which the recording's
    /// command must match) or the recording's own command column (any manoeuvre, at most
    /// 32768 rows: 3.2768 s at 10 kHz).
    #[arg(long, value_enum, default_value = "profile", conflicts_with = "firmware_trace")]
    pub command: CommandArg,
    /// The paper's method alone: its fitness (fast-regime weight 1), the global search, no model
    /// selection, no polish.
    #[arg(long)]
    pub paper_only: bool,
    /// Weight of the fast-regime samples (step and reversal transients) in the fitness, in (0, 1]
    /// [default: the monitor's, 0.1; 1 with --paper-only].
    #[arg(long, value_name = "RHO")]
    pub fast_regime_weight: Option<f32>,
    /// Warm start from the previous flight's fault vector `K1,...,K8` (its diagnosis): no global
    /// search; model selection and the polish from it, then the new-fault probes
    /// (docs/identification.md, "Warm start").
    #[arg(long, value_name = "K1,...,K8", value_parser = parse_prior)]
    pub prior: Option<[f32; 8]>,
    /// Print JSON instead of the readable report.
    #[arg(long)]
    pub json: bool,
    /// Also print the fault vector's f32 bit patterns and the one-line summary the firmware logs
    /// (for the host/target parity check, `scripts/parity`); a refused --firmware-trace prints its
    /// summary (`summary: REFUSED <stage> <error>`) before the error.
    #[arg(long)]
    pub bits: bool,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
    /// The actuator's parameters.
    #[command(flatten)]
    pub params: ParamsArgs,
}

/// Outcome of one identification.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The report of the core.
    pub report: HealthReport,
    /// Wall time of the identification alone (acquisition and file reading excluded).
    pub seconds: f64,
    /// The warm start's prior and what its stages did (`None`: a cold identification).
    pub warm: Option<WarmStart>,
}

/// The prior of a warm start and what its stages did ([`ema_monitor::monitor::WarmReport`]).
#[derive(Clone, Copy, Debug)]
pub struct WarmStart {
    /// The prior fault vector.
    pub prior: [f32; 8],
    /// Probes, refits and evaluations of the warm stages.
    pub report: WarmReport,
}

impl WarmStart {
    /// Names of the groups whose new-fault probe fired.
    pub fn fired(&self) -> Vec<&'static str> {
        GROUP_NAMES.iter().enumerate().filter(|&(g, _)| self.report.fired_group(g)).map(|(_, &n)| n).collect()
    }
}

/// `--prior K1,...,K8`: eight numbers in [0, 1].
fn parse_prior(s: &str) -> Result<[f32; 8], String> {
    let k: Vec<f32> =
        s.split(',').map(|x| x.trim().parse::<f32>().map_err(|e| format!("'{x}': {e}"))).collect::<Result<_, _>>()?;
    let k: [f32; 8] = k.try_into().map_err(|k: Vec<f32>| format!("8 values expected, got {}", k.len()))?;
    if FaultVector(k).is_valid() {
        Ok(k)
    } else {
        Err("every value must be finite and in [0, 1]".to_owned())
    }
}

/// Runs `ema identify`.
pub fn run(args: &IdentifyArgs) -> Result<String, CliError> {
    let base = if args.firmware_trace.is_some() { IdentifyConfig::onboard() } else { IdentifyConfig::default() };
    check_fast_regime_weight(args.fast_regime_weight)?;
    let config = IdentifyConfig {
        algorithm: args.algorithm.into(),
        seed: args.seed,
        max_iterations: args.max_iterations.unwrap_or(base.max_iterations),
        effects: match &args.model_config {
            Some(path) => read_model_config(path)?,
            None => ModelEffects::NONE,
        },
        prior: args.prior,
        ..base
    };
    let config = method_flags(config, args.paper_only, args.fast_regime_weight);
    let mut loaded = None;
    let params = args.params.load()?;
    if args.files.len() > 1 && args.firmware_trace.is_none() {
        let pooled = crate::pooled::run(args, &config, &params)?;
        return Ok(crate::pooled::render(&pooled, &config.effects, args));
    }
    let (outcome, command) = match (&args.firmware_trace, args.files.first()) {
        (Some(path), _) => match firmware_trace_outcome(&read_firmware_trace(path)?, &params, &config) {
            Ok(outcome) => (outcome, ModelCommand::Profile { profile: Profile::STANDARD, name: "standard".to_owned() }),
            Err(refusal) => {
                if args.bits {
                    // the firmware's summary of the refusal, on stdout as an accepted report's;
                    // a closed stdout changes nothing: the error line follows on stderr
                    let _ = writeln!(std::io::stdout().lock(), "{}", refusal.summary_line());
                }
                return Err(input_error(path, &refusal.message));
            }
        },
        (None, Some(path)) => {
            let resolved = resolve_command(args.command, &args.profile)?;
            let load = args.recording.load(path, resolved.as_ref().and_then(ModelCommand::profile), &params)?;
            let recording = load.recording;
            let config =
                IdentifyConfig { independent_frames_per_block: load.summary.independent_frames_per_block(), ..config };
            loaded = Some(load.summary);
            let command = command_for(resolved, &recording, path, &params)?;
            let spinner = progress::spinner(format!("identifying {}", path.display()), args.progress.visible());
            let outcome = identify_recording_with(&recording, path, &params, &command, &config);
            spinner.finish_and_clear();
            (outcome?, command)
        }
        (None, None) => return Err(CliError::flag("FILE", "give a recording CSV or --firmware-trace FILE")),
    };
    Ok(render(&outcome, &config.effects, &command, loaded.as_ref(), args))
}

/// What `--paper-only` and `--fast-regime-weight` (checked before, [`check_fast_regime_weight`])
/// make of `config` in `ema identify` and `ema campaign`: the paper's method alone (its fitness,
/// weight 1; no model selection, no polish), then the flag's weight when given.
pub fn method_flags(config: IdentifyConfig, paper_only: bool, fast_regime_weight: Option<f32>) -> IdentifyConfig {
    let config = if paper_only {
        IdentifyConfig { model_selection: false, polish: None, fast_regime_weight: 1.0, ..config }
    } else {
        config
    };
    IdentifyConfig { fast_regime_weight: fast_regime_weight.unwrap_or(config.fast_regime_weight), ..config }
}

/// `--fast-regime-weight`, when given, checked by the core's rule, the flag named in the error.
pub fn check_fast_regime_weight(weight: Option<f32>) -> Result<(), CliError> {
    match weight {
        Some(w) if !ema_monitor::fitness::fast_regime_weight_is_valid(w) => {
            Err(CliError::flag("--fast-regime-weight", format!("{w} is not in (0, 1]")))
        }
        _ => Ok(()),
    }
}

/// Largest model configuration file, in bytes: ten effect lines and their comments fit many
/// times over.
pub const MAX_MODEL_CONFIG_BYTES: usize = 64 * 1024;

/// Reads a model configuration file with the core's parser (the firmware build's `EMA_MODEL_CONFIG`);
/// errors name the file, line and field.
pub fn read_model_config(path: &Path) -> Result<ModelEffects, CliError> {
    let file = File::open(path).map_err(|e| input_error(path, &format!("cannot read: {e}")))?;
    read_model_config_from(file, path)
}

/// [`read_model_config`] from any reader: at most [`MAX_MODEL_CONFIG_BYTES`] of UTF-8 text, then
/// [`parse_model_config`]; `path` only names the source in errors.
pub fn read_model_config_from(reader: impl Read, path: &Path) -> Result<ModelEffects, CliError> {
    let text = input::read_text(reader, MAX_MODEL_CONFIG_BYTES).map_err(|e| input_error(path, &e.to_string()))?;
    parse_model_config(&text).map_err(|e| input_error(path, &e.to_string()))
}

/// `none` or `dead_time 0.48, viscous 0.3` (the firmware logs the same, one effect per line).
pub fn effects_label(effects: &ModelEffects) -> String {
    let on: Vec<String> = effects.active().map(|(e, s)| format!("{} {s}", e.id())).collect();
    if on.is_empty() {
        "none".to_owned()
    } else {
        on.join(", ")
    }
}

/// Identifies a recording read from `path` (used for messages) of the actuator `params`, driven
/// by `profile`; the report carries the count of refused frames and is `SENSOR_FAULT` when there
/// are too many.
pub fn identify_recording(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
    profile: &Profile,
    config: &IdentifyConfig,
) -> Result<Outcome, CliError> {
    identify_recording_with(
        recording,
        path,
        params,
        &ModelCommand::Profile { profile: *profile, name: String::new() },
        config,
    )
}

/// [`identify_recording`] driven by `command`: a profile, or the recording's own command.
pub fn identify_recording_with(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
    command: &ModelCommand,
    config: &IdentifyConfig,
) -> Result<Outcome, CliError> {
    let (trace, acquired) = condition_recording_checked_for(recording, path, params, command)?;
    let outcome = identify_trace(&trace, params, command.command(), config, path)?;
    Ok(Outcome { report: outcome.report.with_acquisition(&acquired), ..outcome })
}

/// The check a recording passes before it drives `command`: the profile's ([`check_recording`]:
/// rate and command), or for its own command the rate only.
fn check_for(recording: &Recording, path: &Path, params: &EmaParams, command: &ModelCommand) -> Result<(), CliError> {
    match command {
        ModelCommand::Profile { profile, .. } => check_recording(recording, path, profile, params),
        ModelCommand::Recorded(_) => check_rate(recording, path, params),
    }
}

/// [`condition_recording`] for the model driven by `command` (`ema discover --command`).
pub fn condition_recording_for(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
    command: &ModelCommand,
) -> Result<Box<MeasuredTrace<HOST_WINDOW>>, CliError> {
    check_for(recording, path, params, command)?;
    condition_frames(recording, path)
}

/// [`condition_recording_checked`] for the model driven by `command` (`ema identify --command`).
pub fn condition_recording_checked_for(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
    command: &ModelCommand,
) -> Result<(Box<MeasuredTrace<HOST_WINDOW>>, AcquisitionSummary), CliError> {
    check_for(recording, path, params, command)?;
    condition_frames_checked(recording, path)
}

/// Checks a recording made under `profile` (read from `path`, used for messages) and conditions it into the
/// measured trace the core identifies (`I_3eq` block means and weights), every frame as it is:
/// the input of `ema discover`, `ema campaign` and the investigations, which study the model on
/// recordings whose sensor effects the frame checks would refuse (a sensor offset breaks the sum
/// rule). `ema identify` conditions through [`condition_recording_checked`].
pub fn condition_recording(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
    profile: &Profile,
) -> Result<Box<MeasuredTrace<HOST_WINDOW>>, CliError> {
    check_recording(recording, path, profile, params)?;
    condition_frames(recording, path)
}

/// Every frame of a checked recording into the measured trace, as it is.
fn condition_frames(recording: &Recording, path: &Path) -> Result<Box<MeasuredTrace<HOST_WINDOW>>, CliError> {
    let mut trace = Box::new(MeasuredTrace::<HOST_WINDOW>::new());
    for k in 0..recording.len() {
        trace
            .push(recording.ia_a[k] as f32, recording.ib_a[k] as f32, recording.ic_a[k] as f32)
            .map_err(|e| input_error(path, &format!("line {}: {e}", line_of(recording, k))))?;
    }
    trace.finish().map_err(|e| input_error(path, &e.to_string()))?;
    Ok(trace)
}

/// As [`condition_recording`], as on board: every frame passes the core's frame checks
/// ([`FrameCheck::amps`], nominal calibration, default settings); a refused frame is held at the
/// last good one (zero currents before the first) and counted in the returned summary.
pub fn condition_recording_checked(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
    profile: &Profile,
) -> Result<(Box<MeasuredTrace<HOST_WINDOW>>, AcquisitionSummary), CliError> {
    check_recording(recording, path, profile, params)?;
    condition_frames_checked(recording, path)
}

/// Every frame of a checked recording through the core's frame checks into the measured trace.
fn condition_frames_checked(
    recording: &Recording,
    path: &Path,
) -> Result<(Box<MeasuredTrace<HOST_WINDOW>>, AcquisitionSummary), CliError> {
    let mut check = FrameCheck::new(Calibration::NOMINAL, AcquisitionConfig::DEFAULT)
        .map_err(|e| input_error(path, &e.to_string()))?;
    let mut summary = AcquisitionSummary::default();
    let (mut run, mut held) = (0u32, [0.0f32; 3]);
    let mut trace = Box::new(MeasuredTrace::<HOST_WINDOW>::new());
    for k in 0..recording.len() {
        let frame = [recording.ia_a[k] as f32, recording.ib_a[k] as f32, recording.ic_a[k] as f32];
        match check.amps(frame) {
            Ok(f) => {
                held = f.currents_a();
                summary.count(false, &mut run);
            }
            Err(_) => summary.count(true, &mut run),
        }
        trace
            .push(held[0], held[1], held[2])
            .map_err(|e| input_error(path, &format!("line {}: {e}", line_of(recording, k))))?;
    }
    trace.finish().map_err(|e| input_error(path, &e.to_string()))?;
    Ok((trace, summary))
}

/// Identifies a conditioned trace (any window size) of the actuator `params`, the model driven by
/// `command` (a profile or a sampled command); `path` names the input in messages.
pub fn identify_trace<'c, const W: usize>(
    trace: &MeasuredTrace<W>,
    params: &EmaParams,
    command: impl CommandSource<'c>,
    config: &IdentifyConfig,
    path: &Path,
) -> Result<Outcome, CliError> {
    run_identification(trace, params, command.into_command(), config).map_err(|e| input_error(path, &e.to_string()))
}

/// The identification of a conditioned trace to its end, as the firmware's `identify` runs it.
fn run_identification<const W: usize>(
    trace: &MeasuredTrace<W>,
    params: &EmaParams,
    command: Command<'_>,
    config: &IdentifyConfig,
) -> Result<Outcome, monitor::MonitorError> {
    let start = Instant::now();
    let mut id: Box<Identification<'_, W, ONBOARD_POPULATION>> =
        Box::new(Identification::new(trace, *params, command, config)?);
    run_to_end(&mut id);
    let warm = config.prior.zip(id.warm_report()).map(|(prior, report)| WarmStart { prior, report });
    let seconds = start.elapsed().as_secs_f64();
    // the 1σ and detectable-below severities of the reported vector, as the firmware logs them
    Ok(Outcome { report: id.with_uncertainty(id.report()), seconds, warm })
}

/// Runs `id` to its end as [`Identification::run`] does, with each sweep of the PSO global search
/// evaluated in parallel on the current rayon pool (on clones of the fitness) and the costs handed
/// back in order ([`Identification::pending_global`]): a particle's cost depends on nothing its
/// sweep changes, so the identification is bit for bit the firmware's sequential one. The
/// particles after the one whose cost ends the global search are evaluated and not recorded.
pub fn run_to_end<const W: usize, const P: usize>(id: &mut Identification<'_, W, P>) {
    loop {
        let batch: Vec<([f32; FAULT_COUNT], f32)> = id.pending_global().map(|(x, above)| (*x, above)).collect();
        if batch.len() > 1 {
            let costs: Vec<f32> =
                batch.par_iter().map_with(id.fitness().clone(), |fit, (x, above)| fit.cost(x, *above)).collect();
            for cost in costs {
                if let SearchStatus::Done(_) = id.step_with_global_cost(cost) {
                    return;
                }
                if id.pending_global().next().is_none() {
                    break; // the global search ended inside the sweep
                }
            }
        } else if let SearchStatus::Done(_) = id.step() {
            return;
        }
    }
}

/// Largest packed trace the on-board window takes, in bytes: [`ONBOARD_WINDOW`] blocks of
/// [`DECIMATION`] frames and a trailing partial block (which conditioning drops); a longer one
/// would stop acquisition with a full window anyway, so a larger file is refused unread.
pub const MAX_FIRMWARE_TRACE_BYTES: usize = packed_len(ONBOARD_WINDOW * DECIMATION + DECIMATION - 1);

/// Why the firmware's path refused a packed trace, named as the firmware names it in its summary
/// line (`src/main.rs`, `log_refusal`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Refusal {
    /// The step that refused: `trace` (the packed format), `reader` (the acquisition settings),
    /// `acquisition` (conditioning the frames) or `identification` (its settings or the trace).
    pub stage: &'static str,
    /// The core's error as `Debug` writes it (`Padding`, `Conditioning(TooShort)`): the text the
    /// firmware's `defmt::Format` derive writes for these field-less or nested variants.
    pub error: String,
    /// The error's message (`Display`), for the command's error line.
    pub message: String,
}

impl Refusal {
    fn new<E: Debug + Display>(stage: &'static str, e: E) -> Self {
        Self { stage, error: format!("{e:?}"), message: e.to_string() }
    }

    /// `summary: REFUSED <stage> <error>`, the firmware's summary of a refused trace.
    pub fn summary_line(&self) -> String {
        format!("summary: REFUSED {} {}", self.stage, self.error)
    }
}

/// Reads a packed trace file (`--firmware-trace`).
fn read_firmware_trace(path: &Path) -> Result<Vec<u8>, CliError> {
    let file = File::open(path).map_err(|e| input_error(path, &format!("cannot read: {e}")))?;
    input::read_bounded(file, MAX_FIRMWARE_TRACE_BYTES).map_err(|e| input_error(path, &e.to_string()))
}

/// The firmware's path on the bytes of a packed trace, step for step as `src/main.rs`: parse,
/// replay ADC and `OneShot` reader (nominal calibration, default checks), [`monitor::acquire`]
/// into the on-board window, the identification under `config` (the firmware's is
/// `IdentifyConfig::onboard()` with its model effects) of the actuator `params` (the firmware's
/// are `EMA_PARAMS`'), the acquisition's verdict, then
/// `INCONCLUSIVE (rate mismatch)` when the header's rate is not 10 kHz. A step that refuses the
/// trace gives the [`Refusal`] the firmware logs.
pub fn firmware_trace_outcome(bytes: &[u8], params: &EmaParams, config: &IdentifyConfig) -> Result<Outcome, Refusal> {
    firmware_trace_outcome_for(bytes, params, &Profile::STANDARD, config)
}

/// [`firmware_trace_outcome`] of a trace of the manoeuvre `profile` (the firmware's
/// `EMA_PROFILE`: [`Profile::STANDARD`] or [`Profile::PBIT`]).
pub fn firmware_trace_outcome_for(
    bytes: &[u8],
    params: &EmaParams,
    profile: &Profile,
    config: &IdentifyConfig,
) -> Result<Outcome, Refusal> {
    let packed = PackedTrace::parse(bytes).map_err(|e| Refusal::new("trace", e))?;
    let rate_ok = monitor::rate_matches(packed.sample_rate_hz() as f32, params);
    let adc = ReplayAdc::new(packed);
    let mut reader =
        PhaseCurrentReader::new(adc, (PhaseA, PhaseB, PhaseC), Calibration::NOMINAL, AcquisitionConfig::DEFAULT)
            .map_err(|e| Refusal::new("reader", e))?;
    let mut trace = Box::new(MeasuredTrace::<ONBOARD_WINDOW>::new());
    let acquired = monitor::acquire(&mut reader, &mut trace).map_err(|e| Refusal::new("acquisition", e))?;
    let outcome = run_identification(&trace, params, Command::Profile(*profile), config)
        .map_err(|e| Refusal::new("identification", e))?;
    let report = outcome.report.with_acquisition(&acquired);
    let report = if rate_ok { report } else { report.abstaining(Status::Inconclusive(Abstain::RateMismatch)) };
    Ok(Outcome { report, ..outcome })
}

/// Refuses a recording the monitor cannot use: wrong sample rate, or a command that is not `profile`.
pub(crate) fn check_recording(
    r: &Recording,
    path: &Path,
    profile: &Profile,
    params: &EmaParams,
) -> Result<(), CliError> {
    check_rate(r, path, params)?;
    for k in 0..r.len() {
        let expected = f64::from(profile.command_rad(k as f32 * params.control_period_s));
        if (r.command_rad[k] - expected).abs() > COMMAND_TOLERANCE_RAD {
            return Err(input_error(
                path,
                &format!(
                    "line {}, field command_rad: {} but the profile commands {expected}; pass the profile the recording was made with (--profile)",
                    line_of(r, k),
                    r.command_rad[k]
                ),
            ));
        }
    }
    Ok(())
}

/// Refuses a recording whose sample period is not the control period of `params`.
fn check_rate(r: &Recording, path: &Path, params: &EmaParams) -> Result<(), CliError> {
    let period = f64::from(params.control_period_s);
    let measured = r.sample_period_s();
    if (measured - period).abs() > 1e-3 * period {
        return Err(input_error(
            path,
            &format!("field time_s: sample period {measured} s, the monitor needs {period} s (10 kHz)"),
        ));
    }
    Ok(())
}

/// The file line of row `k` (its index + 1 when the recording was not read from a file).
fn line_of(r: &Recording, k: usize) -> usize {
    r.row_line.get(k).copied().unwrap_or(k + 1)
}

fn input_error(path: &Path, message: &str) -> CliError {
    CliError::Input { path: path.to_path_buf(), message: message.to_string() }
}

/// The fault vector's `f32` bit patterns: 8 lower-case hex words.
fn fault_bits(report: &HealthReport) -> String {
    let words: Vec<String> = report.faults.0.iter().map(|k| format!("{:08x}", k.to_bits())).collect();
    words.join(" ")
}

/// `fault vector bits: xxxxxxxx …` (8 lower-case hex words), as the firmware logs it.
pub fn bits_line(report: &HealthReport) -> String {
    format!("fault vector bits: {}", fault_bits(report))
}

/// The firmware's summary line of a report (`src/main.rs`, `log_summary`), which `scripts/parity`
/// compares whole: `summary: STATUS fitness F evaluations N bits K1 … K8`, `STATUS` the status
/// label with its reason in parentheses under `INCONCLUSIVE` (`INCONCLUSIVE(rate mismatch)`), `F`
/// and `K1 … K8` the `f32` bit patterns of the fitness and of the fault vector.
pub fn summary_line(report: &HealthReport) -> String {
    let status = match report.status.reason() {
        Some(reason) => format!("{}({})", report.status.label(), reason.label()),
        None => report.status.label().to_owned(),
    };
    format!(
        "summary: {status} fitness {:08x} evaluations {} bits {}",
        report.fitness.to_bits(),
        report.evaluations,
        fault_bits(report)
    )
}

/// One fault mode of the JSON report, in physical terms.
#[derive(Clone, Debug, Serialize)]
pub struct ModeJson {
    /// Mode name ([`ema_monitor::health::FaultMode::name`]).
    pub mode: &'static str,
    /// Severity in [0, 1].
    pub severity: f32,
    /// `HEALTHY`, `DEGRADED` or `FAILING`.
    pub condition: &'static str,
    /// The physical value, in `unit`.
    pub value: f32,
    /// The unit of `value`, which differs from mode to mode.
    pub unit: &'static str,
    /// 1σ of `severity` (null when not finite or not computed; absent for a mode reported
    /// healthy by model selection, which has `detectable_below`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub severity_sigma: Option<f32>,
    /// For a mode whose fault groups model selection reports healthy: the smallest severity it
    /// would have kept on this recording.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub detectable_below: Option<f32>,
}

/// The goodness-of-fit test of the JSON report ([`ema_monitor::health::FitCheck`]).
#[derive(Clone, Debug, Serialize)]
pub struct FitTestJson {
    /// The normal score of the chi-square statistic.
    pub z: f32,
    /// The score above which the fit is rejected ([`ema_monitor::health::FIT_TEST_Z`]).
    pub z_limit: f32,
    /// Effective sample count of the residual.
    pub effective_samples: f32,
    /// The variance a residual of noise and known mismatch has (A²).
    #[serde(rename = "expected_A2")]
    pub expected_a2: f32,
    /// Index of the evidence window with the largest window score.
    pub window: u16,
    /// The largest window score `max_j z_j`.
    pub window_z: f32,
    /// The Šidák-corrected limit of `window_z` for the windows tested.
    pub window_z_limit: f32,
}

/// The report of `ema identify --json`; `docs/output-schema.md` documents every key. Under
/// `INCONCLUSIVE` or `SENSOR_FAULT` the fault values are no diagnosis: `k` moves to
/// `k_not_a_diagnosis`, and `overall` and `modes` are left out.
#[derive(Clone, Debug, Serialize)]
pub struct IdentifyJson {
    /// `HEALTHY`, `DEGRADED`, `FAILING`, `INCONCLUSIVE` or `SENSOR_FAULT`.
    pub status: &'static str,
    /// Why `INCONCLUSIVE` (null otherwise).
    pub reason: Option<&'static str>,
    /// Frames the acquisition checks refused.
    pub refused_frames: u32,
    /// The goodness-of-fit test (null when not run).
    pub fit_test: Option<FitTestJson>,
    /// The fitness of the best vector (A²).
    #[serde(rename = "fitness_A2")]
    pub fitness_a2: f32,
    /// Objective evaluations.
    pub evaluations: u32,
    /// Iterations of the global search.
    pub iterations: u32,
    /// Why the optimizer stopped (null: the budget).
    pub termination: Option<String>,
    /// Fault groups model selection had no budget left to test.
    pub untested_groups: u8,
    /// Wall time of the identification alone (s).
    pub identification_s: f64,
    /// The fault vector k1..k8, under a diagnosis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k: Option<[f32; 8]>,
    /// The worst mode's condition, under a diagnosis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub overall: Option<&'static str>,
    /// The five fault modes, under a diagnosis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub modes: Option<Vec<ModeJson>>,
    /// The fault vector when the status is no diagnosis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_not_a_diagnosis: Option<[f32; 8]>,
    /// 1σ of each parameter, aligned with `k` (or `k_not_a_diagnosis`); a non-finite σ (not
    /// identifiable on this recording) is null.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma: Option<[f32; 8]>,
    /// What drove the monitor model: a profile or the recorded command.
    pub command: CommandJson,
    /// How the recording file was read (rate, resampling, trimmed start), for a recording.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recording: Option<LoadSummary>,
    /// The monitor model's effect terms (`--model-config`): effect ID to severity.
    pub model_effects: std::collections::BTreeMap<&'static str, f32>,
    /// `cold` (the global search) or `warm` (from `--prior`).
    pub start: &'static str,
    /// The warm start's prior and stages, under `warm` only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warm: Option<WarmJson>,
}

/// The warm start of the JSON report ([`WarmStart`]).
#[derive(Clone, Debug, Serialize)]
pub struct WarmJson {
    /// The prior fault vector.
    pub prior: [f32; 8],
    /// Probe evaluations run.
    pub probes: u16,
    /// Groups whose probe fired (a new fault).
    pub probes_fired: Vec<&'static str>,
    /// Targeted refits run.
    pub refits: u8,
    /// Evaluations of the warm stages (start, probes, refits).
    pub warm_evaluations: u32,
    /// `true` when the warm result failed its fit check and the identification went on cold.
    pub cold_fallback: bool,
    /// `true` when the next identification must be cold (the warm result failed its fit check).
    pub cold_next: bool,
}

/// The JSON report's body of `outcome`, the monitor model run with `effects`.
pub fn json_body(
    outcome: &Outcome,
    effects: &ModelEffects,
    command: &ModelCommand,
    loaded: Option<&LoadSummary>,
) -> IdentifyJson {
    let r = &outcome.report;
    let diagnosis = r.status.is_diagnosis();
    let modes = r
        .modes
        .iter()
        .enumerate()
        .map(|(j, m)| {
            let floor = r.uncertainty.and_then(|u| u.detectable_below[j]);
            ModeJson {
                mode: m.mode.name(),
                severity: m.severity,
                condition: m.condition.label(),
                value: m.value,
                unit: m.unit(),
                severity_sigma: if floor.is_some() { None } else { r.uncertainty.map(|u| u.severity_sigma(m)) },
                detectable_below: floor,
            }
        })
        .collect();
    IdentifyJson {
        status: r.status.label(),
        reason: r.status.reason().map(|a| a.label()),
        refused_frames: r.refused_frames,
        fit_test: r.fit_check.map(|c| FitTestJson {
            z: c.z,
            z_limit: ema_monitor::health::FIT_TEST_Z,
            effective_samples: c.effective_samples,
            expected_a2: c.expected_a2,
            window: c.window,
            window_z: c.window_z,
            window_z_limit: c.window_limit,
        }),
        fitness_a2: r.fitness,
        evaluations: r.evaluations,
        iterations: r.iterations,
        termination: r.termination.map(|t| format!("{t:?}")),
        untested_groups: r.untested_groups,
        identification_s: outcome.seconds,
        k: diagnosis.then_some(r.faults.0),
        overall: diagnosis.then(|| r.overall().label()),
        modes: diagnosis.then_some(modes),
        k_not_a_diagnosis: (!diagnosis).then_some(r.faults.0),
        sigma: r.uncertainty.map(|u| u.sigma),
        command: command.to_json(),
        recording: loaded.cloned(),
        model_effects: effects.active().map(|(e, s)| (e.id(), s)).collect(),
        start: if outcome.warm.is_some() { "warm" } else { "cold" },
        warm: outcome.warm.map(|w| WarmJson {
            prior: w.prior,
            probes: w.report.probes,
            probes_fired: w.fired(),
            refits: w.report.refits,
            warm_evaluations: w.report.evaluations,
            cold_fallback: w.report.cold_fallback,
            cold_next: w.report.needs_cold(r),
        }),
    }
}

/// The report as a JSON document ([`IdentifyJson`] in a [`Document`] whose `input_file` is the
/// recording or the firmware trace).
pub fn to_json(
    outcome: &Outcome,
    effects: &ModelEffects,
    command: &ModelCommand,
    loaded: Option<&LoadSummary>,
    input_file: Option<&Path>,
) -> String {
    Document::new(input_file, json_body(outcome, effects, command, loaded)).to_json()
}

pub(crate) fn render(
    outcome: &Outcome,
    effects: &ModelEffects,
    command: &ModelCommand,
    loaded: Option<&LoadSummary>,
    args: &IdentifyArgs,
) -> String {
    let mut out = if args.json {
        to_json(
            outcome,
            effects,
            command,
            loaded,
            args.firmware_trace.as_deref().or(args.files.first().map(PathBuf::as_path)),
        )
    } else {
        let mut text = format!(
            "{}\n  command: {}\n  identification took {:.3} s",
            outcome.report,
            command.label(),
            outcome.seconds
        );
        if args.model_config.is_some() {
            text.push_str(&format!("\n  model effects: {}", effects_label(effects)));
        }
        if let Some(w) = &outcome.warm {
            let fired = w.fired();
            text.push_str(&format!(
                "\n  warm start from {:?}: probes fired: {} ({} probes, {} refits, {} evaluations of the warm stages){}{}",
                w.prior,
                if fired.is_empty() { "none".to_owned() } else { fired.join(", ") },
                w.report.probes,
                w.report.refits,
                w.report.evaluations,
                if w.report.cold_fallback { "; the warm result failed its fit check: identified cold" } else { "" },
                if w.report.needs_cold(&outcome.report) { "; the next identification must be cold" } else { "" }
            ));
        }
        if let Some(l) = loaded {
            text.push_str(&format!("\n  {}", l.line()));
        }
        text
    };
    if args.bits {
        out.push('\n');
        out.push_str(&bits_line(&outcome.report));
        out.push('\n');
        out.push_str(&summary_line(&outcome.report));
    }
    out
}
