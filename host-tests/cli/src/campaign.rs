//! `ema campaign`: the paper's Table II protocol with our reference model and the on-board core.
//!
//! Protocol (Dalla Vedova, Berri, Re, ICSRS 2018, §VII): 5 single-fault modes × {low, high} ×
//! `--runs` runs × algorithms. Each run draws a fault with a seeded generator, lets the reference
//! model record the manoeuvre (`--profile`: standard, pbit or a file) with sensor noise on
//! (`--noise off`: the paper's conditions, no sensor noise), identifies it with the `no_std` core
//! (the firmware's code, built for the host) and scores it with the paper's error
//! `Err% = 100·sqrt(Σ_{i≤6}(k_i − k̂_i)² + k̂6 (k7 − k̂7)² + (k8 − k̂8)²)`.
//!
//! Draws (all from `SplitMix64(seed ⊕ run-key)`, so a run does not depend on the thread count):
//! - low severity uniform in [0.05, 0.25], high in [0.70, 0.95] (the paper: k̂ ≤ 0.25, k̂ ≥ 0.7);
//! - short circuit: the phase uniformly among A, B, C; eccentricity: the phase k7 uniform in [0, 1);
//!   gain drift: `k8 = 0.5 ± severity/2`, the sign drawn;
//! - `--multi N`: N extra runs with 2 or 3 distinct modes at severities uniform in [0.05, 0.95];
//! - `--multi-low N`: N extra runs with every mode at once, each at a low severity uniform in
//!   [0.05, 0.15] (small simultaneous faults), reported as their own row (`multi-low`);
//! - `--audit`: the master seed is [`AUDIT_SEED`], which no test uses, so its draws are fault
//!   vectors the method was never tuned on;
//! - the sensor-noise seed of the reference model and the optimizer's seed come from the same draw;
//! - `--flights N`: each run records the same fault vector N times (same manoeuvre, the sensor
//!   noise of flight `f > 0` seeded by [`flight_seed`]) and identifies the N recordings together
//!   with the pooled fitness (`CurrentFit::pooled_with`, as `ema identify A.csv B.csv …` does),
//!   so the cell measures what pooling evidence over flights buys.
//!
//! **Noise off.** `--noise off` is the paper's conditions: the recordings carry no sensor noise,
//! and the monitor is told so, as a user who calibrated the sensors as noiseless would: its
//! parameters' `current_noise_a` and `position_noise_rad` are 0 ([`monitor_params`]), so the
//! measured envelope, the verdict's noise model and the 1σ assume only the controller's
//! resolution jitter and the sensed hysteresis ripple that a noiseless recording still has.
//!
//! **Coverage.** Each report carries the 1σ of every parameter (`src/monitor/uncertainty.rs`);
//! a run counts how many of its true values lie within ±2σ of the estimate ([`coverage`]), and
//! each cell reports the share (near 95 % when the σ are calibrated).
//!
//! Outputs: a Markdown table with the paper's Table II beside ours; `--out DIR` writes `runs.csv`,
//! `summary.csv`, `summary.json`, `error.svg` and `time.svg` (grouped bars like the paper's
//! Figures 4–5; [`OUTPUT_FILES`]); `--json` prints the summary JSON. `--out DIR` is checked before
//! the first run (an existing file there is replaced only with `--force`) and its files are
//! written whole or not at all ([`crate::output`]).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use clap::Args;
use ema_monitor::conditioning::MeasuredTrace;
use ema_monitor::fitness::{CurrentFit, PooledTrace, MAX_POOLED_RECORDINGS};
use ema_monitor::monitor::{
    group_pays, group_present, without_group, Algorithm, Identification, IdentifyConfig, FAULT_GROUPS,
    ONBOARD_POPULATION,
};
use ema_monitor::optimizer::rng::splitmix64;
use ema_monitor::{Command, EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};
use rayon::prelude::*;
use serde::Serialize;

use crate::error::CliError;
use crate::identify::{condition_recording, identify_trace, AlgorithmArg};
use crate::output::{prepare_dir, write_files, OutputArgs};
use crate::params::ParamsArgs;
use crate::plots;
use crate::progress::{self, ProgressArgs};
use crate::recording::Recording;
use crate::schema::Document;
use crate::simulate::{resolve_profile, Noise};

/// Master seed of `--audit`: no test and no committed campaign draws with it.
pub const AUDIT_SEED: u64 = 0x00A0_D17C_A3BA_1601;

/// Order of the algorithms in the table: the paper's two, then differential evolution (not in the paper).
const ALGORITHM_ORDER: [&str; 3] = ["pso", "ga", "de"];

/// The five fault modes, in the paper's order.
pub const MODES: [&str; 5] = ["friction", "backlash", "short-circuit", "eccentricity", "gain"];

/// One row of the paper's Table II.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PaperRow {
    /// `pso` or `ga` (the paper has no DE).
    pub algorithm: &'static str,
    /// `low` or `high`.
    pub level: &'static str,
    /// Mean Err% per mode, in [`MODES`] order.
    pub err_percent: [f64; 5],
    /// The row's total Err%.
    pub total_err_percent: f64,
    /// Mean identification time per mode (s).
    pub identification_s: [f64; 5],
}

const fn row(algorithm: &'static str, level: &'static str, err: [f64; 5], total: f64, seconds: [f64; 5]) -> PaperRow {
    PaperRow { algorithm, level, err_percent: err, total_err_percent: total, identification_s: seconds }
}

/// The paper's Table II. Source: Dalla Vedova, Berri, Re, ICSRS 2018, Table II (Matlab r2016a,
/// Core i5-6200U, 2 cores).
pub const PAPER_TABLE_II: [PaperRow; 4] = [
    row("ga", "low", [2.093, 1.678, 5.042, 3.323, 1.928], 2.813, [2633.0, 2336.0, 1644.0, 2502.0, 2492.0]),
    row("ga", "high", [4.491, 2.247, 6.253, 1.778, 0.950], 3.144, [2501.0, 2524.0, 2559.0, 2453.0, 2527.0]),
    row("pso", "low", [0.930, 0.294, 0.863, 1.013, 0.452], 0.711, [1662.0, 1242.0, 2152.0, 2099.0, 1395.0]),
    row("pso", "high", [2.773, 1.629, 2.734, 1.465, 0.205], 1.761, [1875.0, 1634.0, 1474.0, 1506.0, 1078.0]),
];

/// Arguments of `ema campaign`.
#[derive(Args, Debug, Clone)]
#[command(mut_arg("out", |a| a.value_name("DIR").help("Write runs.csv, summary.csv, summary.json, \
    error.svg and time.svg here (created if needed; checked before the first run)")))]
pub struct CampaignArgs {
    /// Runs per fault mode, level and algorithm (the paper: 10).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..))]
    pub runs: u32,
    /// Algorithms, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "pso,ga")]
    pub algorithms: Vec<AlgorithmArg>,
    /// Extra multi-fault runs (2–3 simultaneous faults) per algorithm, reported separately.
    #[arg(long, default_value_t = 0)]
    pub multi: u32,
    /// Extra multi-fault runs with every fault mode at once at low severity (0.05–0.15) per
    /// algorithm, reported separately (`multi-low`).
    #[arg(long, default_value_t = 0)]
    pub multi_low: u32,
    /// Sensor noise of the reference model's recordings (`off`: the paper's conditions; the
    /// monitor then identifies with its sensor noise set to 0, as for sensors calibrated noiseless).
    #[arg(long, value_enum, default_value_t = Noise::On)]
    pub noise: Noise,
    /// Recordings per run (flights of the same actuator with the same fault vector), identified
    /// together by the pooled identification; 1 is the paper's protocol.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=MAX_POOLED_RECORDINGS as i64))]
    pub flights: u32,
    /// Iteration limit of each identification (the paper: 200).
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..))]
    pub max_iterations: u32,
    /// The paper's method alone: its fitness (fast-regime weight 1), the global search, no model
    /// selection, no polish.
    #[arg(long)]
    pub paper_only: bool,
    /// Weight of the fast-regime samples (step and reversal transients) in the fitness, in (0, 1]
    /// [default: the monitor's, 0.1; 1 with --paper-only].
    #[arg(long, value_name = "RHO")]
    pub fast_regime_weight: Option<f32>,
    /// Command profile of every run (the manoeuvre the reference model flies and the monitor
    /// model is driven by): `standard`, `pbit` or a profile file (`ema simulate --help` has the
    /// format).
    #[arg(long, value_name = "NAME|FILE", default_value = "standard")]
    pub profile: String,
    /// Master seed of every draw.
    #[arg(long, default_value_t = 2018)]
    pub seed: u64,
    /// Audit draws: the master seed is `AUDIT_SEED`, which no test uses (replaces `--seed`).
    #[arg(long, conflicts_with = "seed")]
    pub audit: bool,
    /// Worker threads (default: the available cores). The results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Only these modes (comma-separated), e.g. for a quick look.
    #[arg(long, value_delimiter = ',')]
    pub modes: Vec<String>,
    /// Print the summary as JSON instead of the Markdown table.
    #[arg(long)]
    pub json: bool,
    /// `--out DIR` and `--force`.
    #[command(flatten)]
    pub output: OutputArgs,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
    /// The actuator's parameters: the reference model simulates it, the monitor model identifies it.
    #[command(flatten)]
    pub params: ParamsArgs,
}

/// The files `--out DIR` receives, checked before the first run and written together at the end.
pub const OUTPUT_FILES: [&str; 5] = ["runs.csv", "summary.csv", "summary.json", "error.svg", "time.svg"];

/// One planned run.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Algorithm.
    pub algorithm: AlgorithmArg,
    /// Fault mode name (`MODES`) or `multi`.
    pub mode: String,
    /// `low`, `high` or `multi`.
    pub level: &'static str,
    /// Run index within its cell.
    pub run: u32,
    /// Seed of the reference model's noise and of the optimizer.
    pub seed: u64,
    /// The injected fault vector.
    pub truth: FaultVector,
    /// Recordings of the truth identified together (`--flights`).
    pub flights: u32,
}

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
}

/// `(counted, covered)`: the parameters of the fault groups present in the truth or in the
/// estimate, and those of them whose true value lies within ±2σ of the estimate. A group healthy
/// in both is left out (its exact healthy value would be covered by any σ); the eccentricity
/// phase counts only when both have an eccentricity, by its distance on the circle.
pub fn coverage(truth: &FaultVector, estimate: &FaultVector, sigma: &[f32; 8]) -> (u32, u32) {
    let (mut counted, mut covered) = (0u32, 0u32);
    for &(first, last) in &FAULT_GROUPS {
        let (in_truth, in_estimate) =
            (group_present(&truth.0, (first, last)), group_present(&estimate.0, (first, last)));
        if !in_truth && !in_estimate {
            continue;
        }
        for (i, &s) in sigma.iter().enumerate().take(last + 1).skip(first) {
            let mut d = (truth.0[i] - estimate.0[i]).abs();
            if i == 6 {
                if !(in_truth && in_estimate) {
                    continue;
                }
                d = d.min(1.0 - d);
            }
            counted += 1;
            if d <= 2.0 * s {
                covered += 1;
            }
        }
    }
    (counted, covered)
}

/// The truth with every fault group removed that model selection's criterion would refuse even
/// at the truth: a group of `truth` stays when `group_pays(E(k), E(k without it), parameters,
/// n_eff(k))` at `k = truth`, with the identification's fitness (its fast-regime weight and
/// effect terms). No estimator that applies the criterion can be expected to report a fault
/// whose evidence is below it at the true vector, so the Err% of this vector is the part of a
/// run's error that is a limit of the recording (its noise and manoeuvre), not of the search.
/// Not a strict bound: the truth is not the monitor model's best fit (its mismatch floor), and a
/// nearby vector can fit better.
pub fn detectability_floor<const W: usize>(
    trace: &MeasuredTrace<W>,
    params: &EmaParams,
    profile: &Profile,
    config: &IdentifyConfig,
    truth: &FaultVector,
) -> FaultVector {
    detectability_floor_pooled(trace, &[], params, profile, config, truth)
}

/// [`detectability_floor`] of the pooled fitness over `trace` and the recordings `more` (every
/// one under `profile`): the criterion weighs the evidence of every flight at once.
pub fn detectability_floor_pooled<'a, const W: usize>(
    trace: &'a MeasuredTrace<W>,
    more: &'a [PooledTrace<'a, W>],
    params: &EmaParams,
    profile: &Profile,
    config: &IdentifyConfig,
    truth: &FaultVector,
) -> FaultVector {
    let Some(fit) = CurrentFit::new(trace, *params, *profile)
        .ok()
        .map(|fit| fit.with_effects(config.effects))
        .and_then(|fit| fit.with_fast_regime_weight(config.fast_regime_weight))
        .and_then(|fit| if more.is_empty() { Some(fit) } else { fit.pooled_with(more).ok() })
    else {
        return *truth;
    };
    let error_with = fit.error(truth);
    let n = fit.effective_samples(truth);
    let mut floor = truth.0;
    for &group in &FAULT_GROUPS {
        if group_present(&truth.0, group) {
            let error_without = fit.error(&FaultVector(without_group(&truth.0, group)));
            if !group_pays(error_with, error_without, group.1 - group.0 + 1, n) {
                floor = without_group(&floor, group);
            }
        }
    }
    FaultVector(floor)
}

/// SplitMix64 (Steele, Lea, Flood, OOPSLA 2014), the core's ([`splitmix64`]), as a stream: the
/// campaign's seeded generator (one stream per run key), also the tests' generator of fault
/// vectors. The field is the generator's state.
pub struct SplitMix(pub u64);

impl SplitMix {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        splitmix64(&mut self.0)
    }
    /// Uniform in `[0, 1)` from the top 24 bits.
    pub fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
}

/// Sets mode `mode` to `severity` in `k` (drawing the phase/direction it needs from `rng`).
fn inject(k: &mut FaultVector, mode: usize, severity: f32, rng: &mut SplitMix) {
    match mode {
        0 => k.0[0] = severity,
        1 => k.0[1] = severity,
        2 => k.0[2 + (rng.next_u64() % 3) as usize] = severity,
        3 => {
            k.0[5] = severity;
            k.0[6] = rng.unit();
        }
        _ => k.0[7] = if rng.next_u64().is_multiple_of(2) { 0.5 - 0.5 * severity } else { 0.5 + 0.5 * severity },
    }
}

/// The planned runs of a campaign, in a fixed order.
pub fn plan(args: &CampaignArgs) -> Result<Vec<Plan>, CliError> {
    let master = master_seed(args);
    let modes: Vec<usize> = if args.modes.is_empty() {
        (0..MODES.len()).collect()
    } else {
        args.modes
            .iter()
            .map(|m| {
                MODES.iter().position(|x| x == m).ok_or_else(|| {
                    CliError::flag("--modes", format!("unknown mode '{m}' (expected one of {})", MODES.join(", ")))
                })
            })
            .collect::<Result<_, _>>()?
    };
    let mut out = Vec::new();
    for &algorithm in &args.algorithms {
        let alg_key = match algorithm {
            AlgorithmArg::Pso => 1u64,
            AlgorithmArg::Ga => 2,
            AlgorithmArg::De => 3,
        };
        for &mode in &modes {
            for (level_key, level, lo, hi) in [(1u64, "low", 0.05f32, 0.25f32), (2, "high", 0.70, 0.95)] {
                for run in 0..args.runs {
                    // The fault depends on (mode, level, run) only, so every algorithm sees the
                    // same faults; the seed of the noise and of the optimizer adds the algorithm.
                    let key = (mode as u64 + 1) << 40 | level_key << 32 | u64::from(run);
                    let mut rng = SplitMix(master ^ key.wrapping_mul(0xD1B5_4A32_D192_ED03));
                    let mut truth = FaultVector::HEALTHY;
                    let severity = rng.range(lo, hi);
                    inject(&mut truth, mode, severity, &mut rng);
                    let seed = rng.next_u64() ^ alg_key;
                    out.push(Plan {
                        algorithm,
                        mode: MODES[mode].to_string(),
                        level,
                        run,
                        seed,
                        truth,
                        flights: args.flights,
                    });
                }
            }
        }
        for run in 0..args.multi {
            let key = 7u64 << 40 | u64::from(run);
            let mut rng = SplitMix(master ^ key.wrapping_mul(0xD1B5_4A32_D192_ED03));
            let count = 2 + (rng.next_u64() % 2) as usize;
            let mut chosen: Vec<usize> = Vec::new();
            while chosen.len() < count {
                let m = (rng.next_u64() % MODES.len() as u64) as usize;
                if !chosen.contains(&m) {
                    chosen.push(m);
                }
            }
            chosen.sort_unstable();
            let mut truth = FaultVector::HEALTHY;
            for &m in &chosen {
                let severity = rng.range(0.05, 0.95);
                inject(&mut truth, m, severity, &mut rng);
            }
            let names: Vec<&str> = chosen.iter().map(|&m| MODES[m]).collect();
            let seed = rng.next_u64() ^ alg_key;
            out.push(Plan {
                algorithm,
                mode: names.join("+"),
                level: "multi",
                run,
                seed,
                truth,
                flights: args.flights,
            });
        }
        for run in 0..args.multi_low {
            let key = 8u64 << 40 | u64::from(run);
            let mut rng = SplitMix(master ^ key.wrapping_mul(0xD1B5_4A32_D192_ED03));
            let mut truth = FaultVector::HEALTHY;
            for m in 0..MODES.len() {
                let severity = rng.range(0.05, 0.15);
                inject(&mut truth, m, severity, &mut rng);
            }
            let seed = rng.next_u64() ^ alg_key;
            out.push(Plan {
                algorithm,
                mode: "all-low".to_string(),
                level: "multi-low",
                run,
                seed,
                truth,
                flights: args.flights,
            });
        }
    }
    Ok(out)
}

/// The master seed of the draws: [`AUDIT_SEED`] with `--audit`, else `--seed`.
pub fn master_seed(args: &CampaignArgs) -> u64 {
    if args.audit {
        AUDIT_SEED
    } else {
        args.seed
    }
}

/// The identification settings of `ema campaign`'s flags (algorithm and seed are per run).
pub fn identify_config(args: &CampaignArgs) -> IdentifyConfig {
    let base = IdentifyConfig { max_iterations: args.max_iterations, ..IdentifyConfig::default() };
    crate::identify::method_flags(base, args.paper_only, args.fast_regime_weight)
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

/// Seed of the sensor noise of flight `flight` of a run seeded `seed`: `seed` itself for the
/// first flight (so one flight is the single-recording protocol), an independent SplitMix64
/// draw for the others.
pub fn flight_seed(seed: u64, flight: u32) -> u64 {
    if flight == 0 {
        seed
    } else {
        SplitMix(seed ^ u64::from(flight).wrapping_mul(0x9FB2_1C65_1E98_DF25)).next_u64()
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
    let label = PathBuf::from(format!("campaign run {} {} {} #{}", alg_name(p.algorithm), p.mode, p.level, p.run));
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
    let more: Vec<PooledTrace<'_, { crate::identify::HOST_WINDOW }>> =
        rest.iter().map(|t| PooledTrace { trace: &**t, command: Command::Profile(*profile) }).collect();
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
    })
}

/// The pooled identification of `first` and `more` (every recording under `profile`) to its
/// end, as `ema identify A.csv B.csv …` runs it, with the report's 1σ on the pooled fitness.
fn identify_pooled<'a, const W: usize>(
    first: &'a MeasuredTrace<W>,
    more: &'a [PooledTrace<'a, W>],
    params: &EmaParams,
    profile: &Profile,
    config: &IdentifyConfig,
) -> Result<crate::identify::Outcome, ema_monitor::monitor::MonitorError> {
    let start = std::time::Instant::now();
    let mut id: Box<Identification<'_, W, ONBOARD_POPULATION>> =
        Box::new(Identification::new(first, *params, *profile, config)?.pooled_with(more)?);
    id.run(u32::MAX);
    let report = id.with_uncertainty(id.report());
    Ok(crate::identify::Outcome { report, seconds: start.elapsed().as_secs_f64(), warm: None })
}

fn alg_name(a: AlgorithmArg) -> &'static str {
    match a {
        AlgorithmArg::Pso => "pso",
        AlgorithmArg::Ga => "ga",
        AlgorithmArg::De => "de",
    }
}

/// Runs every planned run of the actuator `params` under `profile` (sensor noise on when `noise`) on `threads` workers (a rayon pool of its own);
/// results in plan order, whatever the thread count, since every run's draws come from its plan.
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
        .map_err(|e| CliError::Simulation(format!("cannot start {threads} campaign workers: {e}")))?;
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

/// Mean error and time per (algorithm, mode, level).
#[derive(Clone, Debug, Default, Serialize)]
pub struct Cell {
    /// Runs in the cell.
    pub runs: usize,
    /// Mean Err%.
    pub mean_err_percent: f64,
    /// Mean identification time (s).
    pub mean_identification_s: f64,
    /// Mean evaluations.
    pub mean_evaluations: f64,
    /// Mean Err% of the detectability floor ([`detectability_floor`]).
    pub mean_floor_err_percent: f64,
    /// Share of the true values within ±2σ of the estimate ([`coverage`]; NaN, `null` in JSON,
    /// when no parameter was counted).
    pub coverage_2sigma: f64,
    /// Parameters counted for `coverage_2sigma`.
    pub coverage_parameters: u32,
}

/// `(algorithm, mode, level)` of a summary cell.
pub type CellKey = (String, String, String);

/// Running sums of a cell: runs, Err%, seconds, evaluations, floor Err%, coverage counted and
/// covered.
type CellSums = (usize, f64, f64, f64, f64, u32, u32);

/// Groups results by `(algorithm, mode, level)` (mode `total` pools the single-fault modes).
pub fn summarize(results: &[RunResult]) -> BTreeMap<CellKey, Cell> {
    let mut sums: BTreeMap<CellKey, CellSums> = BTreeMap::new();
    for r in results {
        let alg = alg_name(r.plan.algorithm).to_string();
        let mut keys = vec![(alg.clone(), r.plan.mode.clone(), r.plan.level.to_string())];
        match r.plan.level {
            "multi" | "multi-low" => keys = vec![(alg.clone(), r.plan.level.to_string(), r.plan.level.to_string())],
            level => keys.push((alg.clone(), "total".to_string(), level.to_string())),
        }
        for key in keys {
            let e = sums.entry(key).or_default();
            e.0 += 1;
            e.1 += r.err_percent;
            e.2 += r.seconds;
            e.3 += f64::from(r.evaluations);
            e.4 += r.floor_err_percent;
            e.5 += r.coverage.0;
            e.6 += r.coverage.1;
        }
    }
    sums.into_iter()
        .map(|(k, (n, err, s, ev, floor, counted, covered))| {
            let n_f = n as f64;
            let cell = Cell {
                runs: n,
                mean_err_percent: err / n_f,
                mean_identification_s: s / n_f,
                mean_evaluations: ev / n_f,
                mean_floor_err_percent: floor / n_f,
                coverage_2sigma: if counted == 0 { f64::NAN } else { f64::from(covered) / f64::from(counted) },
                coverage_parameters: counted,
            };
            (k, cell)
        })
        .collect()
}

fn table(summary: &BTreeMap<CellKey, Cell>, args: &CampaignArgs) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| algorithm | level | {} | total | mean time (s) | paper total | paper time (s) |",
        MODES.join(" | ")
    );
    let _ = writeln!(out, "|{}", "---|".repeat(MODES.len() + 6));
    // The paper has no DE rows: its columns show "–" there.
    let order = ALGORITHM_ORDER.into_iter().flat_map(|a| ["low", "high"].map(move |l| (a, l)));
    for (alg, level) in order {
        if !args.algorithms.iter().any(|a| alg_name(*a) == alg) {
            continue;
        }
        let paper = PAPER_TABLE_II.iter().find(|r| r.algorithm == alg && r.level == level);
        let cell = |mode: &str| summary.get(&(alg.to_string(), mode.to_string(), level.to_string()));
        let errs: Vec<String> =
            MODES.iter().map(|m| cell(m).map_or("–".into(), |c| format!("{:.2}", c.mean_err_percent))).collect();
        let total = cell("total");
        let _ = writeln!(
            out,
            "| {alg} | {level} | {} | {} | {} | {} | {} |",
            errs.join(" | "),
            total.map_or("–".into(), |c| format!("{:.2}", c.mean_err_percent)),
            total.map_or("–".into(), |c| format!("{:.2}", c.mean_identification_s)),
            paper.map_or("–".into(), |p| format!("{:.3}", p.total_err_percent)),
            paper.map_or("–".into(), |p| format!("{:.0}", p.identification_s.iter().sum::<f64>() / 5.0)),
        );
    }
    let _ = writeln!(
        out,
        "\nDetectability floor: mean Err% of the truth without the faults model selection's criterion refuses even at the truth (`detectability_floor`)\n\n| algorithm | level | {} | total |",
        MODES.join(" | ")
    );
    let _ = writeln!(out, "|{}", "---|".repeat(MODES.len() + 3));
    let order = ALGORITHM_ORDER.into_iter().flat_map(|a| ["low", "high"].map(move |l| (a, l)));
    for (alg, level) in order {
        let cell = |mode: &str| summary.get(&(alg.to_string(), mode.to_string(), level.to_string()));
        let floor = |mode: &str| cell(mode).map_or("–".into(), |c| format!("{:.2}", c.mean_floor_err_percent));
        if cell("total").is_some() {
            let floors: Vec<String> = MODES.iter().map(|m| floor(m)).collect();
            let _ = writeln!(out, "| {alg} | {level} | {} | {} |", floors.join(" | "), floor("total"));
        }
    }
    for (level, what) in [("multi", "multi-fault"), ("multi-low", "small simultaneous faults (every mode low)")] {
        for alg in ALGORITHM_ORDER {
            if let Some(c) = summary.get(&(alg.to_string(), level.to_string(), level.to_string())) {
                let _ = writeln!(
                    out,
                    "\n{what} ({alg}): {} runs, mean Err% {:.2} (floor {:.2}), mean time {:.2} s, ±2σ coverage {}",
                    c.runs,
                    c.mean_err_percent,
                    c.mean_floor_err_percent,
                    c.mean_identification_s,
                    percent(c.coverage_2sigma)
                );
            }
        }
    }
    out.push_str(&coverage_table(summary));
    let _ = write!(
        out,
        "\nErr% by the paper's formula; ours: {} runs per cell, {} flight{} per run{}, reference model with sensor noise {}, profile {}, max {} iterations, {}, fast-regime weight {}, seed {}{}.",
        args.runs,
        args.flights,
        if args.flights == 1 { "" } else { "s" },
        if args.flights == 1 { "" } else { " (pooled identification)" },
        if args.noise == Noise::On { "on" } else { "off (monitor told: sensor noise 0)" },
        args.profile,
        args.max_iterations,
        if args.paper_only { "global search only" } else { "then model selection and polish" },
        identify_config(args).fast_regime_weight,
        master_seed(args),
        if args.audit { " (--audit)" } else { "" }
    );
    out
}

/// A share as a percentage with one decimal (`–` for NaN).
fn percent(share: f64) -> String {
    if share.is_nan() {
        "–".into()
    } else {
        format!("{:.1} %", 100.0 * share)
    }
}

/// The ±2σ coverage of the true values per (algorithm, level) and mode, then over every run.
fn coverage_table(summary: &BTreeMap<CellKey, Cell>) -> String {
    let mut out = format!(
        "\n±2σ coverage: share of the true values within ±2σ of the estimate ([`coverage`], calibrated near 95 %)\n\n| algorithm | level | {} | total |\n|{}\n",
        MODES.join(" | "),
        "---|".repeat(MODES.len() + 3)
    );
    let (mut counted, mut covered) = (0u32, 0.0f64);
    for alg in ALGORITHM_ORDER {
        for level in ["low", "high", "multi"] {
            let cell = |mode: &str| summary.get(&(alg.to_string(), mode.to_string(), level.to_string()));
            let total = if level == "multi" { cell("multi") } else { cell("total") };
            let Some(total) = total else { continue };
            if !total.coverage_2sigma.is_nan() {
                counted += total.coverage_parameters;
                covered += total.coverage_2sigma * f64::from(total.coverage_parameters);
            }
            let modes: Vec<String> =
                MODES.iter().map(|m| cell(m).map_or("–".into(), |c| percent(c.coverage_2sigma))).collect();
            let _ = writeln!(out, "| {alg} | {level} | {} | {} |", modes.join(" | "), percent(total.coverage_2sigma));
        }
    }
    let overall = if counted == 0 { f64::NAN } else { covered / f64::from(counted) };
    let _ = writeln!(out, "\noverall ±2σ coverage: {} of {counted} parameters", percent(overall));
    out
}

/// One summary cell in `summary.json`: its key and its means (the columns of `summary.csv`).
#[derive(Clone, Debug, Serialize)]
pub struct CellJson<'a> {
    /// `pso`, `ga` or `de`.
    pub algorithm: &'a str,
    /// A fault mode ([`MODES`]), `total` (the single-fault modes pooled), `multi` or `multi-low`.
    pub mode: &'a str,
    /// `low`, `high`, `multi` or `multi-low`.
    pub level: &'a str,
    /// The means.
    #[serde(flatten)]
    pub cell: &'a Cell,
}

/// `summary.json` and `ema campaign --json`: the settings, the cells and the paper's Table II.
#[derive(Clone, Debug, Serialize)]
pub struct SummaryJson<'a> {
    /// `--runs`.
    pub runs_per_cell: u32,
    /// `--profile`.
    pub profile: &'a str,
    /// `--max-iterations`.
    pub max_iterations: u32,
    /// The master seed (`--seed`, or [`AUDIT_SEED`] with `--audit`).
    pub seed: u64,
    /// `--noise`: whether the recordings carry sensor noise.
    pub noise: bool,
    /// `--flights`: recordings per run, identified together.
    pub flights: u32,
    /// False with `--paper-only`.
    pub model_selection_and_polish: bool,
    /// The fitness's fast-regime weight.
    pub fast_regime_weight: f32,
    /// One entry per (algorithm, mode, level), sorted.
    pub cells: Vec<CellJson<'a>>,
    /// [`PAPER_TABLE_II`].
    pub paper_table_ii: &'static [PaperRow],
}

/// The summary as a JSON document ([`SummaryJson`] in a [`Document`]).
pub fn summary_json(summary: &BTreeMap<CellKey, Cell>, args: &CampaignArgs) -> String {
    let cells =
        summary.iter().map(|((algorithm, mode, level), cell)| CellJson { algorithm, mode, level, cell }).collect();
    Document::new(
        None,
        SummaryJson {
            runs_per_cell: args.runs,
            profile: &args.profile,
            max_iterations: args.max_iterations,
            seed: master_seed(args),
            noise: args.noise == Noise::On,
            flights: args.flights,
            model_selection_and_polish: !args.paper_only,
            fast_regime_weight: identify_config(args).fast_regime_weight,
            cells,
            paper_table_ii: &PAPER_TABLE_II,
        },
    )
    .to_json()
}

/// `summary.csv`'s header: the keys of a [`CellJson`], in its order.
pub const SUMMARY_CSV_HEADER: &str = "algorithm,mode,level,runs,mean_err_percent,mean_identification_s,\
mean_evaluations,mean_floor_err_percent,coverage_2sigma,coverage_parameters";

/// `summary.csv`: one row per (algorithm, mode, level), the columns of [`SUMMARY_CSV_HEADER`].
pub fn summary_csv(summary: &BTreeMap<CellKey, Cell>) -> String {
    let mut csv = format!("{SUMMARY_CSV_HEADER}\n");
    for ((alg, mode, level), c) in summary {
        let _ = writeln!(
            csv,
            "{alg},{mode},{level},{},{},{},{},{},{},{}",
            c.runs,
            c.mean_err_percent,
            c.mean_identification_s,
            c.mean_evaluations,
            c.mean_floor_err_percent,
            c.coverage_2sigma,
            c.coverage_parameters
        );
    }
    csv
}

/// `runs.csv`: one row per run, units in the header.
pub fn runs_csv(results: &[RunResult]) -> String {
    let mut out = String::from("algorithm,mode,level,run,seed");
    for prefix in ["true", "est"] {
        for i in 1..=8 {
            let _ = write!(out, ",k{i}_{prefix}");
        }
    }
    out.push_str(",err_percent,identification_s,evaluations,floor_err_percent");
    for i in 1..=8 {
        let _ = write!(out, ",k{i}_sigma");
    }
    out.push_str(",coverage_counted,coverage_covered,flights\n");
    for r in results {
        let p = &r.plan;
        let _ = write!(out, "{},{},{},{},{}", alg_name(p.algorithm), p.mode, p.level, p.run, p.seed);
        for k in p.truth.0.iter().chain(r.estimate.0.iter()) {
            let _ = write!(out, ",{k}");
        }
        let _ = write!(out, ",{},{},{},{}", r.err_percent, r.seconds, r.evaluations, r.floor_err_percent);
        for s in &r.sigma {
            let _ = write!(out, ",{s}");
        }
        let _ = writeln!(out, ",{},{},{}", r.coverage.0, r.coverage.1, p.flights);
    }
    out
}

/// Grouped bar chart (SVG, [`plots::grouped_bars`]): one group per fault mode, one bar per
/// (algorithm, level); the value axis reaches the largest value of any cell, totals and
/// multi-fault cells included.
pub fn bar_chart(
    title: &str,
    unit: &str,
    summary: &BTreeMap<CellKey, Cell>,
    value: fn(&Cell) -> f64,
) -> std::io::Result<String> {
    let series: Vec<(String, String)> = summary
        .keys()
        .filter(|(_, mode, level)| mode != "total" && !level.starts_with("multi"))
        .map(|(a, _, l)| (a.clone(), l.clone()))
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    let names: Vec<String> = series.iter().map(|(alg, level)| format!("{alg} {level}")).collect();
    let max = summary.values().map(value).fold(0.0f64, f64::max).max(1e-9);
    plots::grouped_bars(title, unit, &MODES, &names, max, |g, s| {
        let (alg, level) = &series[s];
        summary.get(&(alg.clone(), MODES[g].to_string(), level.clone())).map(value)
    })
}

/// Runs `ema campaign`.
pub fn run(args: &CampaignArgs) -> Result<String, CliError> {
    if args.algorithms.is_empty() {
        return Err(CliError::flag("--algorithms", "give at least one of pso, ga, de"));
    }
    crate::identify::check_fast_regime_weight(args.fast_regime_weight)?;
    let profile = resolve_profile(&args.profile)?;
    let params = args.params.load()?;
    let plans = plan(args)?;
    let threads = args.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if threads == 0 {
        return Err(CliError::flag("--threads", "must be at least 1"));
    }
    let overwrite = args.output.overwrite();
    if let Some(dir) = &args.output.out {
        prepare_dir(dir, &OUTPUT_FILES, overwrite)?;
    }
    let noise = args.noise == Noise::On;
    let results = run_all(&plans, &identify_config(args), &params, &profile, noise, threads, args.progress.visible())?;
    let summary = summarize(&results);
    if let Some(dir) = &args.output.out {
        let contents = [
            runs_csv(&results),
            summary_csv(&summary),
            summary_json(&summary, args),
            bar_chart("Mean identification error per fault mode", "Err (%)", &summary, |c| c.mean_err_percent)
                .map_err(|source| CliError::Io { path: dir.join("error.svg"), source })?,
            bar_chart("Mean identification time per fault mode", "identification time (s)", &summary, |c| {
                c.mean_identification_s
            })
            .map_err(|source| CliError::Io { path: dir.join("time.svg"), source })?,
        ];
        let paths = OUTPUT_FILES.map(|name| dir.join(name));
        let files: Vec<(&Path, &[u8])> =
            paths.iter().zip(&contents).map(|(p, c)| (p.as_path(), c.as_bytes())).collect();
        write_files(&files, overwrite)?;
    }
    Ok(if args.json { summary_json(&summary, args) } else { table(&summary, args) })
}
