//! One planned run simulated by the reference model and identified by the core (alone, or pooled
//! over its flights), and every run of a campaign on a pool of workers.

use std::path::PathBuf;

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::{Algorithm, Identification, IdentifyConfig, MonitorError, ONBOARD_POPULATION};
use ema_monitor::fitness::PooledTrace;
use ema_monitor::{Command, EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};
use rayon::prelude::*;

use super::plan::{flight_seed, Plan};
use super::scoring::{bounds_vs_truth, coverage, detectability_floor, detectability_floor_pooled, BoundsVsTruth};
use crate::error::CliError;
use crate::progress;
use crate::recording::Recording;
use crate::runtime::identification::{identify_trace, Outcome};
use crate::runtime::recording::condition_recording;
use crate::runtime::source::HOST_WINDOW;

/// One finished run.
#[derive(Clone, Debug)]
pub struct RunResult {
    /// What was run.
    pub plan: Plan,
    /// The identified vector.
    pub estimate: FaultVector,
    /// The paper's error, percent.
    pub err_percent: f64,
    /// Identification wall time.
    pub seconds: f64,
    /// Objective evaluations.
    pub evaluations: u32,
    /// Err% of the detectability floor ([`detectability_floor`]).
    pub floor_err_percent: f64,
    /// The report's 1σ per parameter (`+∞`: not identifiable; NaN: not computed).
    pub sigma: [f32; 8],
    /// Parameters counted by [`coverage`] and those of them within ±2σ.
    pub coverage: (u32, u32),
    /// The report's "not detectable below" bounds against the truth ([`bounds_vs_truth`]).
    pub bounds: BoundsVsTruth,
}

/// The parameters the monitor identifies with: the actuator's `params`, with the sensor noise
/// (`current_noise_a`, `position_noise_rad`) set to 0 when the recordings carry none (`noise`
/// false), as a user who calibrated the sensors as noiseless would declare them.
pub fn monitor_params(params: &EmaParams, noise: bool) -> EmaParams {
    if noise {
        *params
    } else {
        EmaParams { current_noise_a: 0.0, position_noise_rad: 0.0, ..*params }
    }
}

/// Simulates (sensor noise on when `noise`) and identifies one planned run of the actuator
/// `params` under `profile`: `p.flights` recordings of its truth, identified together by the
/// pooled identification when more than one. `base` gives the identification's settings; the
/// algorithm and the seed come from the plan. Without noise the monitor identifies with
/// [`monitor_params`].
pub fn execute(
    p: &Plan,
    base: &IdentifyConfig,
    params: &EmaParams,
    profile: &Profile,
    noise: bool,
) -> Result<RunResult, CliError> {
    let identify = IdentifyConfig { algorithm: Algorithm::from(p.algorithm), seed: p.seed, ..*base };
    let label = PathBuf::from(format!("campaign run {} {} {} #{}", p.algorithm.name(), p.mode, p.level, p.run));
    let mut traces = Vec::new();
    for flight in 0..p.flights.max(1) {
        let config = SimConfig {
            params: *params,
            faults: p.truth,
            seed: flight_seed(p.seed, flight),
            profile: *profile,
            noise,
            ..SimConfig::default()
        };
        let rec = simulate(&config).map_err(|e| CliError::Simulation(e.to_string()))?;
        let recording = Recording::from_reference(&rec, Vec::new());
        traces.push(condition_recording(&recording, &label, params, profile)?);
    }
    let params = &monitor_params(params, noise);
    let (first, rest) = traces.split_first().ok_or_else(|| CliError::Simulation("no flight".into()))?;
    let more: Vec<PooledTrace<'_, HOST_WINDOW>> =
        rest.iter().map(|t| PooledTrace { trace: &**t, command: Command::Profile(profile) }).collect();
    let (outcome, floor) = if more.is_empty() {
        let outcome = identify_trace(&**first, params, profile, &identify, &label)?;
        (outcome, detectability_floor(&**first, params, profile, &identify, &p.truth))
    } else {
        let outcome = identify_pooled(first, &more, params, profile, &identify)
            .map_err(|e| CliError::Simulation(format!("{}: {e}", label.display())))?;
        (outcome, detectability_floor_pooled(&**first, &more, params, profile, &identify, &p.truth))
    };
    let estimate = outcome.report.faults;
    let sigma = outcome.report.uncertainty.map_or([f32::NAN; 8], |u| u.sigma);
    Ok(RunResult {
        plan: p.clone(),
        estimate,
        err_percent: f64::from(estimate.paper_error_percent(&p.truth)),
        seconds: outcome.seconds,
        evaluations: outcome.report.evaluations,
        floor_err_percent: f64::from(floor.paper_error_percent(&p.truth)),
        sigma,
        coverage: coverage(&p.truth, &estimate, &sigma),
        bounds: bounds_vs_truth(&p.truth, params, outcome.report.uncertainty.as_ref()),
    })
}

/// The pooled identification of `first` and `more` (every recording under `profile`) to its
/// end, as `ema identify A.csv B.csv …` runs it, with the report's 1σ on the pooled fitness.
fn identify_pooled<'a, const W: usize>(
    first: &'a ConditionedWindow<W>,
    more: &'a [PooledTrace<'a, W>],
    params: &EmaParams,
    profile: &Profile,
    config: &IdentifyConfig,
) -> Result<Outcome, MonitorError> {
    let start = std::time::Instant::now();
    let mut id: Box<Identification<'_, W, ONBOARD_POPULATION>> =
        Box::new(Identification::new(first, *params, profile, config)?.pooled_with(more)?);
    id.run(u32::MAX);
    let report = id.with_uncertainty(id.report());
    Ok(Outcome {
        report,
        seconds: start.elapsed().as_secs_f64(),
        warm: None,
        unit_check: None,
        sensors: ema_monitor::acquisition::SensorCheck::DECLARED,
        position: None,
    })
}

/// Runs every planned run of the actuator `params` under `profile` (sensor noise on when
/// `noise`) on `threads` workers (a rayon pool of its own); results in plan order, whatever the
/// thread count, since every run's draws come from its plan.
/// `progress` shows a bar of the runs on stderr ([`progress::bar`]).
pub fn run_all(
    plans: &[Plan],
    base: &IdentifyConfig,
    params: &EmaParams,
    profile: &Profile,
    noise: bool,
    threads: usize,
    progress: bool,
) -> Result<Vec<RunResult>, CliError> {
    let bar = progress::bar(plans.len() as u64, "runs", progress);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .map_err(|e| CliError::Runtime(format!("cannot start {threads} campaign workers: {e}")))?;
    let results: Vec<Result<RunResult, CliError>> = pool.install(|| {
        plans
            .par_iter()
            .map(|p| {
                let r = execute(p, base, params, profile, noise);
                bar.inc(1);
                r
            })
            .collect()
    });
    bar.finish_and_clear();
    results.into_iter().collect()
}
