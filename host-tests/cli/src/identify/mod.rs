//! `ema identify`: the `no_std` core built for the host — the same code as the firmware —
//! identifies the faults behind a recording and prints the health report.
//!
//! Two inputs:
//! - a recording CSV (`ema simulate`'s format, 10 kHz): phase currents in amperes go through the
//!   core's own acquisition ([`ema_monitor::diagnosis::acquire`], on the recording as its
//!   phase-current source, [`crate::runtime::source`]), so they pass the same range,
//!   stuck-channel and sum checks as on board
//!   ([`FrameCheck::amps`](ema_monitor::acquisition::FrameCheck::amps), nominal calibration); a
//!   refused frame is held at the last good one and counted, and too many make the report
//!   `SENSOR_FAULT`. The monitor model is driven by the command profile (`--command profile`,
//!   the default: `--profile`, default `standard`), and then the command column must match it,
//!   or by the recording's own command column (`--command recorded`: any manoeuvre, sampled at
//!   10 kHz into the core's [`SampledCommand`](ema_monitor::SampledCommand), at most
//!   [`HOST_COMMAND_SAMPLES`] rows, every value inside the end stops);
//! - `--firmware-trace FILE`: the firmware's packed 12-bit trace, read through the same replay ADC,
//!   `OneShot` reader and fixed-point calibration as on the MCU, with the on-board window, swarm
//!   and settings, and the firmware's first flight through the core's
//!   [`HealthMonitor`](ema_monitor::flight::HealthMonitor) on a new health record — its report is
//!   bit-identical to the firmware's. `--bits` flies the firmware's second flight too, planned
//!   from the record the first left, saved and read back as the firmware does
//!   ([`firmware_trace_flights_for`]), and prints each flight's fault vector bits and summary
//!   line ([`summary_line`]: status, fitness bits, evaluations, fault bits; or one
//!   [`Refusal::summary_line`] for a refused trace), which `scripts/parity` compares line for
//!   line with the firmware's in QEMU. With `--prior` the trace is identified once, warm from it.
//!
//! A recording with a temperature column is identified with the actuator's parameters at its
//! mean temperature ([`crate::runtime::temperature`]); the report says so
//! (`temperature: T °C (recording)`, `temperature_c` in the JSON).
//!
//! `--model-config FILE` switches the monitor model's effect terms on from a model configuration
//! file (`effect ID SEVERITY` lines, [`ema_monitor::effects::parse_model_config`]), the same file
//! and the same parser as the firmware build (`EMA_MODEL_CONFIG=FILE cargo run --release`), so a
//! host run and a firmware run of one configuration can be compared.
//!
//! The command is four files on top of the host runtime ([`crate::runtime`]): [`args`] (the
//! flags and the settings they make), this module's [`run`] (read, acquire, identify),
//! [`report`] (text and JSON) and [`pooled`] (several recordings fitted by one fault vector).

pub mod args;
pub mod pooled;
pub mod report;

use std::io::Write;

use ema_monitor::diagnosis::IdentifyConfig;
use ema_monitor::effects::ModelEffects;
use ema_monitor::unit::Tolerances;
use ema_monitor::Profile;

use crate::error::CliError;
use crate::exit::Done;
use crate::progress;
use crate::runtime::firmware::read_firmware_trace;
use crate::tolerances_file::read_tolerances;

pub use args::{check_fast_regime_weight, method_flags, AlgorithmArg, IdentifyArgs};
pub use report::{json_body, render, to_json, FitTestJson, IdentifyJson, ModeJson, WarmJson};

/// The host runtime's items under the paths of `ema identify`'s library, which the tests,
/// benches, investigations and fuzz targets use.
pub use crate::runtime::command::{
    command_for, model_command, recorded_command, resolve_command, CommandArg, CommandJson, ModelCommand,
    HOST_COMMAND_SAMPLES,
};
pub use crate::runtime::firmware::{
    bits_line, checksum_warning, firmware_trace_flights_for, firmware_trace_outcome, firmware_trace_outcome_for,
    summary_line, FirmwareFlights, Refusal, FIRMWARE_FLIGHTS, MAX_FIRMWARE_TRACE_BYTES,
};
pub use crate::runtime::identification::{
    identify_recording, identify_recording_with, identify_trace, identify_unit_recording, run_to_end, Outcome,
    WarmStart,
};
pub use crate::runtime::model_config::{
    effects_label, read_model_config, read_model_config_from, MAX_MODEL_CONFIG_BYTES,
};
pub use crate::runtime::recording::{
    condition_recording, condition_recording_checked, condition_recording_checked_for, condition_recording_for,
    COMMAND_TOLERANCE_RAD,
};
pub use crate::runtime::source::HOST_WINDOW;
pub use crate::runtime::temperature::{model_params, pooled_model_params, ModelParams, POOLED_TEMPERATURE_SPREAD_K};

/// Runs `ema identify`: the report, and the exit status of its status ([`crate::exit::status_code`]
/// under `--fail-on`).
pub fn run(args: &IdentifyArgs) -> Result<Done, CliError> {
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
    let mut temperature = None;
    let mut later = Vec::new();
    let params = args.params.load()?;
    if args.files.len() > 1 && args.firmware_trace.is_none() {
        let pooled = pooled::run(args, &config, &params)?;
        let status = pooled.outcome.report.status;
        return Ok(Done::report(pooled::render(&pooled, &config.effects, args), status, args.fail_on));
    }
    let (outcome, command) = match (&args.firmware_trace, args.files.first()) {
        (Some(path), _) => {
            let bytes = read_firmware_trace(path)?;
            if let Some(warning) = checksum_warning(path, &bytes) {
                eprintln!("{warning}");
            }
            // under --bits, the firmware's flights, each with its summary; with --prior, the one
            // identification warm from it
            let flights = if args.bits && config.prior.is_none() {
                firmware_trace_flights_for(&bytes, &params, &Profile::STANDARD, &config, FIRMWARE_FLIGHTS)
            } else {
                firmware_trace_outcome(&bytes, &params, &config).map(|first| FirmwareFlights { first, later: vec![] })
            };
            match flights {
                Ok(flights) => {
                    later = flights.later;
                    let command = ModelCommand::Profile { profile: Profile::STANDARD, name: "standard".to_owned() };
                    (flights.first, command)
                }
                Err(refusal) => {
                    if args.bits {
                        // the firmware's summary of the refusal, on stdout as an accepted report's;
                        // a closed stdout changes nothing: the error line follows on stderr
                        let _ = writeln!(std::io::stdout().lock(), "{}", refusal.summary_line());
                    }
                    return Err(CliError::input(path, refusal.message));
                }
            }
        }
        (None, Some(path)) => {
            let resolved = resolve_command(args.command, &args.profile)?;
            let load = args.recording.load(path, resolved.as_ref().and_then(ModelCommand::profile), &params)?;
            let recording = load.recording;
            // the actuator at the recording's temperature, when it has one
            let model = model_params(&recording, path, &params)?;
            let params = model.params;
            temperature = model.temperature_c.map(|t| (t, false));
            let config =
                IdentifyConfig { independent_frames_per_block: load.summary.independent_frames_per_block(), ..config };
            loaded = Some(load.summary);
            let command = command_for(resolved, &recording, path, &params)?;
            let tolerances = match &args.tolerances {
                Some(file) => read_tolerances(file)?,
                None => Tolerances::TYPICAL,
            };
            // without a temperature reading, --estimate-temperature takes it as a nuisance parameter
            let estimate = temperature.is_none() && args.estimate_temperature;
            let spinner = progress::spinner(format!("identifying {}", path.display()), args.progress.visible());
            let outcome = identify_unit_recording(&recording, path, &params, &command, &config, &tolerances, estimate);
            spinner.finish_and_clear();
            let (outcome, estimated_c) = outcome?;
            if let Some(t) = estimated_c {
                temperature = Some((f64::from(t), true));
            }
            (outcome, command)
        }
        (None, None) => return Err(CliError::usage("give a recording CSV or --firmware-trace PACKED_TRACE")),
    };
    let mut text = render(&outcome, &config.effects, &command, loaded.as_ref(), temperature, args);
    for flight in &later {
        // the firmware's later flights on the same trace: their bits and summary lines (--bits)
        text.push_str(&format!("\n{}\n{}", bits_line(&flight.report), summary_line(&flight.report)));
    }
    Ok(Done::report(text, outcome.report.status, args.fail_on))
}
