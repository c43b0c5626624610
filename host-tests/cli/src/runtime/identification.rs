//! The core's identification run to its end on the host: on one conditioned trace, on a
//! recording (conditioned through the frame checks first), or pooled over several traces.
//! [`run_to_end`] evaluates each sweep of the PSO global search in parallel ([`ParallelSweeps`])
//! and is bit for bit the firmware's sequential run.

use ema_monitor::acquisition::SensorCheck;
use std::collections::VecDeque;
use std::path::Path;
use std::time::Instant;

use ema_monitor::command::CommandSource;
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::{
    configured_fit, Identification, IdentifyConfig, MonitorError, StepDriver, WarmReport, ONBOARD_POPULATION,
};
use ema_monitor::faults::FaultGroup;
use ema_monitor::fitness::{PoolError, PooledTrace, MAX_POOLED_RECORDINGS};
use ema_monitor::health::HealthReport;
use ema_monitor::operating_temperature::estimate_temperature_c;
use ema_monitor::optimizer::Objective;
use ema_monitor::unit::Tolerances;
use ema_monitor::FAULT_COUNT;
use ema_monitor::{Command, EmaParams, Profile};
use rayon::prelude::*;

use super::command::ModelCommand;
use super::position_check::{check_position, PositionCheck};
use super::recording::condition_recording_checked_for;
use super::unit_check::{check_unit, with_unit_check, UnitCheck};
use crate::error::CliError;
use crate::recording::Recording;

/// Outcome of one identification.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The report of the core.
    pub report: HealthReport,
    /// Wall time of the identification alone (acquisition and file reading excluded).
    pub seconds: f64,
    /// The warm start's prior and what its stages did (`None`: a cold identification).
    pub warm: Option<WarmStart>,
    /// The best healthy unit within the unit's tolerances against a fault found
    /// ([`super::unit_check`]; `None`: not checked).
    pub unit_check: Option<UnitCheck>,
    /// What the current sensors' self-calibration found (the declared calibration where the
    /// recording was not acquired through the frame checks).
    pub sensors: SensorCheck,
    /// The recording's position column against its command and the identified model
    /// ([`super::position_check`]; `None`: not checked, a trace without a position column).
    pub position: Option<PositionCheck>,
}

/// The prior of a warm start and what its stages did ([`ema_monitor::diagnosis::WarmReport`]).
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
        FaultGroup::ALL.into_iter().filter(|&g| self.report.fired_group(g)).map(FaultGroup::name).collect()
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
    Ok(Outcome { report: outcome.report.with_acquisition(&acquired), sensors: acquired.sensors, ..outcome })
}

/// [`identify_recording_with`] for a unit known to within `tolerances`: a fault found must also
/// pay against the best healthy unit within them ([`super::unit_check`]), or the report abstains
/// with `unit mismatch`. With `estimate_temperature` (a recording without a temperature reading),
/// the unit is first taken at the temperature where it fits the recording best
/// ([`ema_monitor::operating_temperature::estimate_temperature_c`]), returned beside the outcome.
pub fn identify_unit_recording(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
    command: &ModelCommand,
    config: &IdentifyConfig,
    tolerances: &Tolerances,
    estimate_temperature: bool,
) -> Result<(Outcome, Option<f32>), CliError> {
    let (trace, acquired) = condition_recording_checked_for(recording, path, params, command)?;
    let temperature_c = if estimate_temperature {
        let fit = configured_fit(&*trace, *params, command.command(), config)
            .map_err(|e| CliError::input(path, e.to_string()))?;
        Some(estimate_temperature_c(&fit, params))
    } else {
        None
    };
    let params = &temperature_c.map_or(*params, |t| params.at_temperature(t));
    let outcome = identify_trace(&trace, params, command.command(), config, path)?;
    let start = Instant::now();
    let check = check_unit(&trace, params, command.command(), config, tolerances, &outcome.report);
    let report = with_unit_check(outcome.report, check.as_ref()).with_acquisition(&acquired);
    let seconds = outcome.seconds + start.elapsed().as_secs_f64();
    let position = check_position(recording, params, &report.faults);
    Ok((Outcome { report, seconds, unit_check: check, sensors: acquired.sensors, position, ..outcome }, temperature_c))
}

/// Identifies a conditioned trace (any window size) of the actuator `params`, the model driven by
/// `command` (a profile or a sampled command); `path` names the input in messages.
pub fn identify_trace<'c, const W: usize>(
    trace: &ConditionedWindow<W>,
    params: &EmaParams,
    command: impl CommandSource<'c>,
    config: &IdentifyConfig,
    path: &Path,
) -> Result<Outcome, CliError> {
    run_identification(trace, params, command.into_command(), config).map_err(|e| CliError::input(path, e.to_string()))
}

/// The identification of a conditioned trace to its end, as the firmware's flight
/// (`HealthMonitor::diagnose`) runs it,
/// with the 1σ and detectable-below severities of the reported vector.
pub fn run_identification<const W: usize>(
    trace: &ConditionedWindow<W>,
    params: &EmaParams,
    command: Command<'_>,
    config: &IdentifyConfig,
) -> Result<Outcome, MonitorError> {
    let start = Instant::now();
    let mut id: Box<Identification<'_, W, ONBOARD_POPULATION>> =
        Box::new(Identification::new(trace, *params, command, config)?);
    run_to_end(&mut id);
    let warm = config.prior.zip(id.warm_report()).map(|(prior, report)| WarmStart { prior, report });
    let seconds = start.elapsed().as_secs_f64();
    // the 1σ and detectable-below severities of the reported vector, as the firmware logs them
    Ok(Outcome {
        report: id.with_uncertainty(id.report()),
        seconds,
        warm,
        unit_check: None,
        sensors: SensorCheck::DECLARED,
        position: None,
    })
}

/// Runs `id` to its end as [`Identification::run`] does, with each sweep of the PSO global search
/// evaluated in parallel on the current rayon pool (on clones of the fitness) and the costs handed
/// back in order ([`ParallelSweeps`], the driver of the core's one loop,
/// [`Identification::run_with`]): a particle's cost depends on nothing its sweep changes, so the
/// identification is bit for bit the firmware's sequential one.
pub fn run_to_end<const W: usize, const P: usize>(id: &mut Identification<'_, W, P>) {
    id.run_with(u32::MAX, &mut ParallelSweeps::default());
}

/// The costs of the PSO global search's current sweep, evaluated in parallel when the sweep has
/// more than one particle left ([`Identification::pending_global`]), handed back one per step. A
/// global search that ends inside the sweep leaves no particle pending, and the costs left are
/// dropped unrecorded.
#[derive(Debug, Default)]
pub struct ParallelSweeps {
    /// The costs of the sweep's pending particles not handed back yet, in order.
    costs: VecDeque<f32>,
}

impl StepDriver for ParallelSweeps {
    fn global_cost<const W: usize, const P: usize>(&mut self, id: &Identification<'_, W, P>) -> Option<f32> {
        if id.pending_global().next().is_none() {
            self.costs.clear();
            return None;
        }
        if self.costs.is_empty() {
            let batch: Vec<([f32; FAULT_COUNT], f32)> = id.pending_global().map(|(x, above)| (*x, above)).collect();
            if batch.len() <= 1 {
                return None;
            }
            self.costs =
                batch.par_iter().map_with(id.fitness().clone(), |fit, (x, above)| fit.cost(x, *above)).collect();
        }
        self.costs.pop_front()
    }
}

/// Identifies one fault vector from several conditioned traces of the actuator `params`, trace
/// `i` measured under `commands[i]`: the pipeline of [`IdentifyConfig`] on the pooled fitness.
/// One trace gives exactly the single-recording identification. At most
/// [`MAX_POOLED_RECORDINGS`] traces, as many commands as traces.
pub fn identify_pooled<const W: usize>(
    traces: &[&ConditionedWindow<W>],
    commands: &[Command<'_>],
    params: &EmaParams,
    config: &IdentifyConfig,
) -> Result<Outcome, MonitorError> {
    let (Some((&first, rest)), Some((&first_command, rest_commands))) = (traces.split_first(), commands.split_first())
    else {
        return Err(MonitorError::Pool(PoolError::TooMany));
    };
    if traces.len() != commands.len() || traces.len() > MAX_POOLED_RECORDINGS {
        return Err(MonitorError::Pool(PoolError::TooMany));
    }
    let more: Vec<PooledTrace<'_, W>> =
        rest.iter().zip(rest_commands).map(|(&trace, &command)| PooledTrace { trace, command }).collect();
    let start = Instant::now();
    let mut id: Box<Identification<'_, W, ONBOARD_POPULATION>> =
        Box::new(Identification::new(first, *params, first_command, config)?.pooled_with(&more)?);
    id.run(u32::MAX);
    Ok(Outcome {
        report: id.report(),
        seconds: start.elapsed().as_secs_f64(),
        warm: None,
        unit_check: None,
        sensors: SensorCheck::DECLARED,
        position: None,
    })
}
