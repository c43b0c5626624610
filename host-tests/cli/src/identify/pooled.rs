//! `ema identify A.csv B.csv …`: one fault vector fitted to several recordings of one actuator
//! (several flights), with the core's pooled fitness ([`ema_monitor::fitness::EquivalentCurrentFit::pooled_with`]):
//! each recording is simulated from rest under its own command and the errors are combined
//! sample-weighted, so model selection's price is paid once for the evidence of every flight.
//!
//! The pooled identification itself is the runtime's [`identify_pooled`] (also the library entry
//! of the flights-to-detection measurement); this module reads the files and renders the report.

use std::path::{Path, PathBuf};

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::{AcquisitionSummary, IdentifyConfig, MonitorError};
use ema_monitor::effects::ModelEffects;
use ema_monitor::fitness::MAX_POOLED_RECORDINGS;
use ema_monitor::{Command, EmaParams};
use serde::Serialize;

use super::args::IdentifyArgs;
use super::report::{json_body, render as render_one, IdentifyJson};
use crate::error::CliError;
use crate::input::check_distinct;
use crate::progress;
use crate::recording::{LoadSummary, Recording, MAX_FILE_BYTES};
use crate::runtime::command::{command_for, resolve_command, ModelCommand};
use crate::runtime::firmware::{bits_line, summary_line};
use crate::runtime::identification::Outcome;
use crate::runtime::recording::condition_recording_checked_for;
use crate::runtime::source::HOST_WINDOW;
use crate::runtime::temperature::pooled_model_params;
use crate::schema::Document;

pub use crate::runtime::identification::identify_pooled;

/// The pooled report of `ema identify FILES…`, with what the text and JSON say of it.
#[derive(Clone, Debug)]
pub struct PooledOutcome {
    /// The report over every recording, its acquisition counts summed.
    pub outcome: Outcome,
    /// The command of the first recording (the report's `command`).
    pub command: ModelCommand,
    /// How the first recording was read.
    pub loaded: LoadSummary,
    /// The recordings, in order.
    pub files: Vec<PathBuf>,
    /// Their mean temperature (°C), at which the model took the actuator's parameters; `None`
    /// without temperature columns.
    pub temperature_c: Option<f64>,
}

/// `ema identify A.csv B.csv …`: every file read with the same flags (`--params`, `--column`,
/// `--profile`, `--command`, …), the actuator's parameters taken at their common temperature
/// ([`pooled_model_params`]: all within 5 K, or no temperature column at all), every file
/// conditioned through the frame checks, then one identification over all of them. A recording
/// given twice (one file under two names, or two files of the same bytes) is refused
/// ([`check_distinct`]): it is one flight, not two. The noise
/// model takes the fewest independent frames per block of the files; the refused frames add up,
/// and a file with too many makes the report `SENSOR_FAULT`.
pub fn run(args: &IdentifyArgs, config: &IdentifyConfig, params: &EmaParams) -> Result<PooledOutcome, CliError> {
    let files = &args.files;
    if files.len() > MAX_POOLED_RECORDINGS {
        return Err(CliError::usage(format!(
            "{} recordings given; at most {MAX_POOLED_RECORDINGS} are pooled",
            files.len()
        )));
    }
    check_distinct(files, MAX_FILE_BYTES)?;
    let mut loads = Vec::new();
    for path in files {
        let resolved = resolve_command(args.command, &args.profile)?;
        let load = args.recording.load(path, resolved.as_ref().and_then(ModelCommand::profile), params)?;
        loads.push((path, resolved, load));
    }
    let recordings: Vec<(&Path, &Recording)> =
        loads.iter().map(|(path, _, load)| (path.as_path(), &load.recording)).collect();
    let model = pooled_model_params(&recordings, params)?;
    let params = &model.params;
    let mut traces: Vec<Box<ConditionedWindow<HOST_WINDOW>>> = Vec::new();
    let mut commands: Vec<ModelCommand> = Vec::new();
    let mut acquired: Vec<AcquisitionSummary> = Vec::new();
    let mut first_load: Option<LoadSummary> = None;
    let mut frames_per_block = f32::INFINITY;
    for (path, resolved, load) in loads {
        frames_per_block = frames_per_block.min(load.summary.independent_frames_per_block());
        let command = command_for(resolved, &load.recording, path, params)?;
        let (trace, summary) = condition_recording_checked_for(&load.recording, path, params, &command)?;
        traces.push(trace);
        commands.push(command);
        acquired.push(summary);
        first_load.get_or_insert(load.summary);
    }
    let (Some(loaded), Some(first_path)) = (first_load, files.first()) else {
        return Err(CliError::usage("give a recording CSV or --firmware-trace PACKED_TRACE"));
    };
    let config = IdentifyConfig { independent_frames_per_block: frames_per_block, ..*config };
    let refs: Vec<&ConditionedWindow<HOST_WINDOW>> = traces.iter().map(|t| &**t).collect();
    let cores: Vec<Command<'_>> = commands.iter().map(ModelCommand::command).collect();
    let spinner = progress::spinner(format!("identifying {} recordings", files.len()), args.progress.visible());
    let outcome = identify_pooled(&refs, &cores, params, &config).map_err(|e| pooled_error(first_path, &e));
    spinner.finish_and_clear();
    let mut outcome = outcome?;
    let total = acquired.iter().fold(AcquisitionSummary::default(), |a, s| AcquisitionSummary {
        frames: a.frames.saturating_add(s.frames),
        refused: a.refused.saturating_add(s.refused),
        longest_refused_run: a.longest_refused_run.max(s.longest_refused_run),
        // each file's sensors are checked on their own, below
        sensors: a.sensors,
    });
    outcome.report = outcome.report.with_acquisition(&total);
    if let Some(worst) = acquired.iter().find(|s| s.is_sensor_fault()) {
        outcome.report = outcome.report.with_acquisition(worst);
        outcome.report.refused_frames = total.refused;
    }
    drop(cores);
    let command = commands.swap_remove(0);
    Ok(PooledOutcome { outcome, command, loaded, files: files.clone(), temperature_c: model.temperature_c })
}

/// `pooled over N recordings: A.csv, B.csv, …`, the text report's first line.
pub fn pooled_line(files: &[PathBuf]) -> String {
    let names: Vec<String> = files.iter().map(|p| p.display().to_string()).collect();
    format!("pooled over {} recordings: {}", files.len(), names.join(", "))
}

/// The JSON report of a pooled identification: `ema identify --json`'s keys and the recordings.
#[derive(Clone, Debug, Serialize)]
pub struct PooledJson {
    /// The report's keys ([`IdentifyJson`]).
    #[serde(flatten)]
    pub report: IdentifyJson,
    /// How many recordings the fault vector was fitted to.
    pub pooled_recordings: usize,
    /// The recordings, in order (the first is also `input_file`).
    pub input_files: Vec<String>,
}

/// The output of `ema identify A.csv B.csv …`: the single-recording report (text or JSON) with
/// the pooled recordings named (`pooled over N recordings`, or the JSON keys `pooled_recordings`
/// and `input_files`).
pub fn render(pooled: &PooledOutcome, effects: &ModelEffects, args: &IdentifyArgs) -> String {
    if args.json {
        let body = PooledJson {
            report: json_body(&pooled.outcome, effects, &pooled.command, Some(&pooled.loaded), pooled.temperature_c),
            pooled_recordings: pooled.files.len(),
            input_files: pooled.files.iter().map(|p| p.display().to_string()).collect(),
        };
        let mut out = Document::new(pooled.files.first().map(PathBuf::as_path), body).to_json();
        if args.bits {
            out.push('\n');
            out.push_str(&bits_line(&pooled.outcome.report));
            out.push('\n');
            out.push_str(&summary_line(&pooled.outcome.report));
        }
        out
    } else {
        let text = render_one(
            &pooled.outcome,
            effects,
            &pooled.command,
            Some(&pooled.loaded),
            pooled.temperature_c.map(|t| (t, false)),
            args,
        );
        format!("{}\n{text}", pooled_line(&pooled.files))
    }
}

fn pooled_error(path: &Path, e: &MonitorError) -> CliError {
    CliError::input(path, e.to_string())
}
