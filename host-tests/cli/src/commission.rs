//! `ema commission`: a unit's own parameters from a few recordings of it, healthy.
//!
//! ```text
//! ema commission A.csv B.csv C.csv --out unit.toml
//! ema identify --params unit.toml D.csv
//! ```
//!
//! Each recording is read and acquired as `ema identify` reads it (the host runtime), then the
//! core's commissioning ([`ema_monitor::commissioning`]) fits the unit parameters of the
//! tolerance table (`--tolerances`, or the typical one) to all of them with the faults held
//! healthy, each recording at its own temperature when it has a temperature column (20 °C
//! without). Two files are written: the parameter file that `--params` takes (the base
//! parameters, `--params` or the drawing's, with the unit's own values at 20 °C in place), and
//! beside it `NAME.tolerances.toml`, the 1σ commissioning left on each parameter, which `ema
//! identify --tolerances` takes for its unit check.
//!
//! A recording given twice (the same file, or the same bytes) is refused: it is one flight.
//!
//! Nothing is written when the recordings do not look like a healthy unit within its
//! tolerances, because a fault present at commissioning must not become the baseline:
//! - a resolved parameter more than 3σ from nominal (a friction fault reads as friction far
//!   above its tolerance);
//! - a recording that, diagnosed against the new baseline, is not HEALTHY (a short circuit or an
//!   eccentricity, which no unit parameter can absorb, shows there).

use std::path::PathBuf;

use clap::Args;
use ema_monitor::commissioning::{
    commission, Baseline, BaselineFit, CommissioningFlight, MAX_COMMISSIONING_FLIGHTS, SWARM_ITERATIONS,
    SWARM_PARTICLES,
};
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::{configured_fit, IdentifyConfig};
use ema_monitor::health::Status;
use ema_monitor::unit::{unit_field, unit_name, Tolerances, UNIT_PARAM_COUNT};
use ema_monitor::{Command, EmaParams};
use serde::Serialize;

use crate::error::CliError;
use crate::input::check_distinct;
use crate::output::{check_file, write_files, OutputArgs};
use crate::params::ParamsArgs;
use crate::params_file::template;
use crate::progress::ProgressArgs;
use crate::recording::{RecordingArgs, MAX_FILE_BYTES};
use crate::runtime::command::{command_for, resolve_command, CommandArg, ModelCommand};
use crate::runtime::identification::identify_trace;
use crate::runtime::recording::condition_recording_checked_for;
use crate::runtime::source::HOST_WINDOW;
use crate::schema::Document;
use crate::tolerances_file::{read_tolerances, template as tolerances_template};

/// Arguments of `ema commission`.
#[derive(Args, Debug, Clone)]
#[command(mut_arg("out", |a| a.required(true).value_name("UNIT.toml")
    .help("The unit's parameter file (written whole, only when the recordings look healthy)")))]
pub struct CommissionArgs {
    /// Recordings of the new or freshly maintained unit, healthy (1 to 8; 3 or more advised),
    /// each read with the same flags.
    #[arg(value_name = "FILE", required = true)]
    pub files: Vec<PathBuf>,
    /// How to read the recordings.
    #[command(flatten)]
    pub recording: RecordingArgs,
    /// Command profile the recordings were made with: `standard`, `pbit` or a profile file.
    #[arg(long, default_value = "standard")]
    pub profile: String,
    /// What drives the monitor model: the profile or each recording's own command column.
    #[arg(long, value_enum, default_value = "profile")]
    pub command: CommandArg,
    /// Tolerance table of the unit parameters, the prior (TOML; `ema params --tolerances` prints
    /// the template) [default: the typical tolerances].
    #[arg(long, value_name = "FILE.toml")]
    pub tolerances: Option<PathBuf>,
    /// Print JSON instead of the readable report.
    #[arg(long)]
    pub json: bool,
    /// `--out UNIT.toml` (required) and `--force`.
    #[command(flatten)]
    pub output: OutputArgs,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
    /// The drawing's parameters the unit is a variant of (its unit parameters are the prior's
    /// centre).
    #[command(flatten)]
    pub params: ParamsArgs,
}

/// One unit parameter in the report.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct UnitParamJson {
    /// The parameter-file key.
    pub name: &'static str,
    /// The base (drawing) value.
    pub nominal: f32,
    /// The commissioned value (the nominal one when not resolved).
    pub value: f32,
    /// Deviation from nominal in tolerance standard deviations.
    pub z: f32,
    /// Posterior 1σ of the value, relative to it (0.01: 1 %).
    pub sigma_relative: f32,
    /// The recordings resolve it (posterior 1σ below 0.9 of the tolerance's).
    pub resolved: bool,
}

/// The JSON body of `ema commission`.
#[derive(Serialize, Debug, Clone)]
pub struct CommissionJson {
    /// The recordings, in order.
    pub recordings: Vec<String>,
    /// The parameter file written.
    pub out: String,
    /// The posterior tolerance file written beside it.
    pub tolerances_out: String,
    /// Each unit parameter.
    pub unit: Vec<UnitParamJson>,
    /// Evaluations of the fitness spent (one model run per recording each).
    pub evaluations: u32,
}

/// Runs `ema commission`.
pub fn run(args: &CommissionArgs) -> Result<String, CliError> {
    let overwrite = args.output.overwrite();
    let out = args.output.out.as_deref().ok_or_else(|| CliError::flag("--out", "give the unit's parameter file"))?;
    if args.files.len() > MAX_COMMISSIONING_FLIGHTS {
        return Err(CliError::usage(format!(
            "{} recordings; commissioning takes at most {MAX_COMMISSIONING_FLIGHTS}",
            args.files.len()
        )));
    }
    check_distinct(&args.files, MAX_FILE_BYTES)?;
    let posterior_out = tolerances_path(out);
    check_file(out, overwrite)?;
    check_file(&posterior_out, overwrite)?;
    let base = args.params.load()?;
    let tolerances = match &args.tolerances {
        Some(path) => read_tolerances(path)?,
        None => Tolerances::TYPICAL,
    };
    let resolved = resolve_command(args.command, &args.profile)?;
    let mut traces: Vec<(Box<ConditionedWindow<HOST_WINDOW>>, ModelCommand, f32)> = Vec::new();
    let mut independent = f32::INFINITY;
    for path in &args.files {
        let load = args.recording.load(path, resolved.as_ref().and_then(ModelCommand::profile), &base)?;
        independent = independent.min(load.summary.independent_frames_per_block());
        let command = command_for(resolved.clone(), &load.recording, path, &base)?;
        let (trace, acquired) = condition_recording_checked_for(&load.recording, path, &base, &command)?;
        if acquired.is_sensor_fault() {
            return Err(CliError::input(
                path,
                format!(
                    "{} of {} frames refused: a sensor fault, not a recording to commission from",
                    acquired.refused, acquired.frames
                ),
            ));
        }
        let temperature_c = load.recording.mean_temperature_c().map_or(f32::NAN, |t| t as f32);
        traces.push((trace, command, temperature_c));
    }
    let config = IdentifyConfig { independent_frames_per_block: independent, ..IdentifyConfig::default() };
    let recordings: Vec<CommissioningRecording<'_>> = traces
        .iter()
        .zip(&args.files)
        .map(|((trace, command, temperature_c), path)| CommissioningRecording {
            trace: trace.as_ref(),
            command: command.command(),
            temperature_c: *temperature_c,
            path,
        })
        .collect();
    let spinner = crate::progress::spinner("commissioning".to_owned(), args.progress.visible());
    let baseline = commission_recordings(&recordings, &base, &tolerances, &config);
    spinner.finish_and_clear();
    let baseline = baseline?;
    let unit: Vec<UnitParamJson> = (0..UNIT_PARAM_COUNT)
        .filter_map(|i| {
            let field = unit_field(i)?;
            let value = field.get(&baseline.params);
            let sigma = tolerances.relative_sigma[i] * baseline.sigma_z[i] * field.get(&base) / value;
            Some(UnitParamJson {
                name: field.name,
                nominal: field.get(&base),
                value,
                z: baseline.z[i],
                sigma_relative: sigma.abs(),
                resolved: baseline.resolved[i],
            })
        })
        .collect();
    let names: Vec<String> = args.files.iter().map(|p| p.display().to_string()).collect();
    let file = parameter_file(&baseline.params, &names);
    let posterior = Tolerances {
        relative_sigma: core::array::from_fn(|i| {
            unit.get(i).map_or(0.0, |p| p.sigma_relative.min(ema_monitor::unit::MAX_RELATIVE_SIGMA))
        }),
    };
    let posterior_file = format!(
        "# The 1σ commissioning left on each unit parameter of {} (`ema identify --tolerances`).\n\n{}",
        out.display(),
        tolerances_template(&posterior)
    );
    write_files(&[(out, file.as_bytes()), (&posterior_out, posterior_file.as_bytes())], overwrite)?;
    let body = CommissionJson {
        recordings: names,
        out: out.display().to_string(),
        tolerances_out: posterior_out.display().to_string(),
        unit,
        evaluations: baseline.evaluations,
    };
    Ok(if args.json { Document::new(None, body).to_json() } else { render(&body) })
}

/// One recording to commission from, acquired.
#[derive(Clone, Copy, Debug)]
pub struct CommissioningRecording<'a> {
    /// Its conditioned window.
    pub trace: &'a ConditionedWindow<HOST_WINDOW>,
    /// What drives the monitor model.
    pub command: Command<'a>,
    /// Its mean temperature (°C); NaN without one (20 °C).
    pub temperature_c: f32,
    /// Its file, for messages.
    pub path: &'a std::path::Path,
}

/// The baseline of the unit behind `recordings` (module doc), the unit being `base` moved by
/// `tolerances`: refused, naming the first recording, when a resolved parameter lies beyond 3σ,
/// and naming the recording, when one of them diagnosed against the baseline is not HEALTHY.
pub fn commission_recordings(
    recordings: &[CommissioningRecording<'_>],
    base: &EmaParams,
    tolerances: &Tolerances,
    config: &IdentifyConfig,
) -> Result<Baseline, CliError> {
    let Some(first) = recordings.first().map(|r| r.path) else {
        return Err(CliError::usage("give at least one recording"));
    };
    let fits = recordings
        .iter()
        .map(|r| configured_fit(r.trace, *base, r.command, config).map_err(|e| CliError::input(r.path, e.to_string())))
        .collect::<Result<Vec<_>, _>>()?;
    let flights: Vec<CommissioningFlight<'_, '_, HOST_WINDOW>> = fits
        .iter()
        .zip(recordings)
        .map(|(fit, r)| CommissioningFlight { fit, temperature_c: r.temperature_c })
        .collect();
    let mut objective = BaselineFit::new(&flights, *base, *tolerances, config.independent_frames_per_block)
        .map_err(|e| CliError::usage(e.to_string()))?;
    let baseline =
        commission::<HOST_WINDOW, SWARM_PARTICLES>(&mut objective, SWARM_ITERATIONS, config.seed, &mut || {})
            .map_err(|e| CliError::input(first, e.to_string()))?;
    if let Some((i, z)) = baseline.out_of_tolerance() {
        return Err(CliError::input(
            first,
            format!(
                "these recordings do not look like a healthy unit: {} fits {z:+.1}σ from nominal, beyond its \
                 tolerance (a fault, or another actuator); nothing written",
                unit_name(i)
            ),
        ));
    }
    for r in recordings {
        let params = baseline.params.at_temperature(r.temperature_c);
        let report = identify_trace(r.trace, &params, r.command, config, r.path)?.report;
        if report.status != Status::Healthy {
            let found: Vec<String> = report
                .modes
                .iter()
                .filter(|m| m.severity > 0.0)
                .map(|m| format!("{} {:.2}", m.mode.name(), m.severity))
                .collect();
            return Err(CliError::input(
                r.path,
                format!(
                    "diagnosed against the commissioned parameters it reads {}{}: not a healthy unit; nothing written",
                    report.status.label(),
                    if found.is_empty() { String::new() } else { format!(" ({})", found.join(", ")) }
                ),
            ));
        }
    }
    Ok(baseline)
}

/// `NAME.tolerances.toml` beside the parameter file `NAME.toml` (or `NAME.EXT`).
pub fn tolerances_path(out: &std::path::Path) -> PathBuf {
    let stem = out.file_stem().map_or_else(|| "unit".into(), |s| s.to_string_lossy().into_owned());
    out.with_file_name(format!("{stem}.tolerances.toml"))
}

/// The parameter file of the unit: a header naming the recordings, then the template.
fn parameter_file(params: &EmaParams, recordings: &[String]) -> String {
    format!(
        "# Commissioned by `ema commission` from {} recording(s): {}\n# The unit parameters of the \
         tolerance table hold this unit's own values.\n\n{}",
        recordings.len(),
        recordings.join(", "),
        template(params)
    )
}

/// The readable report: one line per unit parameter.
pub fn render(body: &CommissionJson) -> String {
    let mut out =
        format!("commissioned from {} recording(s), {} evaluations\n", body.recordings.len(), body.evaluations);
    for p in &body.unit {
        if p.resolved {
            out +=
                &format!("  {:<32} {:>12.6e}  ({:+.1}σ, ±{:.1} %)\n", p.name, p.value, p.z, 100.0 * p.sigma_relative);
        } else {
            out += &format!("  {:<32} {:>12.6e}  not resolved by these recordings: left nominal\n", p.name, p.value);
        }
    }
    out += &format!("wrote {} and {}", body.out, body.tolerances_out);
    out
}
