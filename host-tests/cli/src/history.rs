//! `ema history`: the monitor over a series of flights of one actuator, its trend and remaining
//! useful life per fault mode.
//!
//! ```text
//! ema history FILE… [--json] [--out DIR [--force]] [--params F] [--profile P]
//! ema history --simulate LAW… [--flights N] [--seed S] [--json] [--out DIR]
//! ```
//!
//! Each recording is one flight, in the order given. Every flight runs the on-board sequence
//! through [`identify_flight`]: the core identifies the recording (the first flight cold, a later
//! flight warm from the previous diagnosis, with new-fault probes, unless the core's plan asks
//! for a cold one) with the on-board settings
//! ([`IdentifyConfig::onboard`]: the firmware's iteration budget) and, when its status is a
//! diagnosis, its five mode severities join the history of the core's [`HealthRecord`] (a ring
//! of the last 16 flights per mode, the record the firmware persists). The flight joins the record
//! through the evidence pooled over flights, by the core function the firmware calls
//! ([`evidence::record_flight_on`]): the flight's log-likelihood ratio per mode joins the
//! record's sequential sums, and a mode the sums call present while the flight's own model
//! selection dropped it is *declared by pooled evidence* and refitted into the diagnosis the
//! record keeps (`docs/decisions/0024-declaration-by-pooled-evidence.md`). After each flight the
//! core fits the trend of every mode and the flight at which it reaches the failing threshold,
//! with its interval ([`ema_monitor::prognosis`]).
//!
//! **Degradation campaign** (`--simulate LAW…`): instead of files, the reference model flies
//! `--flights` flights of an actuator whose faults follow the laws, with sensor noise and a noise
//! seed per flight. A law is `MODE=START[+RATE][@ONSET]`: the mode's severity is 0 before flight
//! `ONSET` (default 1) and `START + RATE·(flight − ONSET)` from it on (at most 1), so
//! `friction=0.05+0.04` grows linearly from the first flight and `short_a=0.3@5` is a sudden
//! fault at flight 5. Modes: `friction` (k1), `backlash` (k2), `short_a`, `short_b`, `short_c`
//! (k3–k5), `eccentricity` (k6, minimum gap at 0°), `gain` (k8 = 0.5 + severity/2). Knowing the
//! truth, the command scores each flight (the paper's Err%, cold and warm apart), the probes of
//! the warm flights (false alarms: a drift-only flight, no group present in the truth and absent
//! from the prior, on which a probe fires; misses: a flight with a new fault on which none fires
//! and the report misses it), the detection of each mode (first
//! flight its group is reported after its onset, and reports of a mode that is absent; the same
//! for declarations by pooled evidence), and the prognosis at the last flight against the true
//! crossing of the failing threshold.
//!
//! `--out DIR` writes `history.json` (the `--json` document) and `severity.svg` (severity against
//! flight per mode as the record keeps it, the flights a mode was declared by pooled evidence
//! ringed, the trend lines, the failing threshold and the RUL band).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use clap::Args;
use ema_monitor::conditioning::MeasuredTrace;
use ema_monitor::health::{FaultMode, HealthReport, DEGRADED_AT, FAILING_AT};
use ema_monitor::monitor::evidence::{self, PooledFlight, EVIDENCE_MODES};
use ema_monitor::monitor::{self as core_monitor, group_present, IdentifyConfig, WarmReport, FAULT_GROUPS};
use ema_monitor::optimizer::rng::{splitmix64_mix, SPLITMIX_GAMMA};
use ema_monitor::persist::HealthRecord;
use ema_monitor::prognosis::{Prognosis, HISTORY_CAPACITY, RUL_CONFIDENCE};
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};
use serde::Serialize;

use crate::error::CliError;
use crate::identify::{condition_recording_checked_for, identify_trace, ModelCommand, HOST_WINDOW};
use crate::output::{prepare_dir, write_files, OutputArgs};
use crate::params::ParamsArgs;
use crate::plots::{self, SeveritySeries};
use crate::progress::{self, ProgressArgs};
use crate::recording::{Recording, RecordingArgs};
use crate::schema::Document;
use crate::simulate::resolve_profile;

/// The files `--out DIR` receives.
pub const OUTPUT_FILES: [&str; 2] = ["history.json", "severity.svg"];

/// A mode counts as reported when its severity exceeds this (model selection sets an absent
/// group exactly healthy, severity 0).
pub const PRESENT_SEVERITY: f32 = 1e-3;

/// Arguments of `ema history`.
#[derive(Args, Debug, Clone)]
#[command(mut_arg("out", |a| a.value_name("DIR").help("Write history.json and severity.svg here \
    (created if needed; checked before the first flight)")))]
pub struct HistoryArgs {
    /// Recordings of successive flights of one actuator, oldest first.
    #[arg(required_unless_present = "simulate", conflicts_with = "simulate")]
    pub files: Vec<PathBuf>,
    /// Degradation laws `MODE=START[+RATE][@ONSET]` (repeatable): simulate the flights with the
    /// reference model instead of reading files.
    #[arg(long, value_name = "LAW", num_args = 1..)]
    pub simulate: Vec<String>,
    /// Flights simulated under --simulate.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=200))]
    pub flights: u32,
    /// Master seed of the simulated flights' sensor noise and of the optimizer.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Command profile the recordings were made with (and the simulated flights fly).
    #[arg(long, default_value = "standard")]
    pub profile: String,
    /// Print JSON instead of the tables.
    #[arg(long)]
    pub json: bool,
    /// How to read the recordings.
    #[command(flatten)]
    pub recording: RecordingArgs,
    /// `--out DIR` and `--force`.
    #[command(flatten)]
    pub output: OutputArgs,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
    /// The actuator's parameters.
    #[command(flatten)]
    pub params: ParamsArgs,
}

/// How a flight's identification started.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Start {
    /// From scratch: the global search, model selection and polish.
    Cold,
    /// From the previous flight's diagnosis.
    Warm,
}

/// One flight's identification.
#[derive(Clone, Debug)]
pub struct FlightResult {
    /// The health report.
    pub report: HealthReport,
    /// How it started.
    pub start: Start,
    /// Wall time of the identification (s).
    pub seconds: f64,
    /// What the warm stages did (`None`: a cold flight).
    pub warm: Option<WarmReport>,
    /// The conditioned recording (the evidence of the flight is measured on it).
    pub trace: Box<MeasuredTrace<HOST_WINDOW>>,
}

/// Identifies one flight's `recording` (named `label` in errors) driven by `command`, as the
/// firmware does: warm from the previous diagnosis `prior` when the core's
/// [`core_monitor::plan_start`] allows it (a prior, fewer than
/// [`IdentifyConfig::cold_every_flights`] flights since the last cold one, and a last warm flight
/// that passed its fit check: `flights_since_cold` and `last_warm_needs_cold`), cold otherwise.
pub fn identify_flight(
    recording: &Recording,
    label: &Path,
    prior: Option<[f32; 8]>,
    (flights_since_cold, last_warm_needs_cold): (u32, bool),
    params: &EmaParams,
    command: &ModelCommand,
    config: &IdentifyConfig,
) -> Result<FlightResult, CliError> {
    let warm = matches!(
        core_monitor::plan_start(prior.as_ref(), flights_since_cold, last_warm_needs_cold, config),
        core_monitor::Start::Warm
    );
    let config = IdentifyConfig { prior: if warm { prior } else { None }, ..*config };
    let (trace, acquired) = condition_recording_checked_for(recording, label, params, command)?;
    let outcome = identify_trace(&trace, params, command.command(), &config, label)?;
    let warm = outcome.warm.map(|w| w.report);
    // a warm attempt that failed its fit check went on cold in the same call
    let start = if warm.is_some_and(|w| !w.cold_fallback) { Start::Warm } else { Start::Cold };
    let report = outcome.report.with_acquisition(&acquired);
    Ok(FlightResult { report, start, seconds: outcome.seconds, warm, trace })
}

/// A degradation law of one mode (`MODE=START[+RATE][@ONSET]`).
#[derive(Clone, Debug, PartialEq)]
pub struct Law {
    /// The mode's name as given (`friction`, `short_a`, …).
    pub name: String,
    /// The fault vector index it drives.
    pub index: usize,
    /// Severity at the onset flight.
    pub start: f32,
    /// Severity added per flight.
    pub rate: f32,
    /// First faulty flight.
    pub onset: u32,
}

/// The mode names of a law and the fault-vector index each drives.
pub const LAW_MODES: [(&str, usize); 7] = [
    ("friction", 0),
    ("backlash", 1),
    ("short_a", 2),
    ("short_b", 3),
    ("short_c", 4),
    ("eccentricity", 5),
    ("gain", 7),
];

impl Law {
    /// Parses `MODE=START[+RATE][@ONSET]`.
    pub fn parse(text: &str) -> Result<Self, CliError> {
        let bad = |m: String| CliError::flag("--simulate", format!("'{text}': {m}"));
        let (name, rest) = text.split_once('=').ok_or_else(|| bad("not MODE=START[+RATE][@ONSET]".into()))?;
        let name = name.trim();
        let index = LAW_MODES.iter().find(|(n, _)| *n == name).map(|&(_, i)| i).ok_or_else(|| {
            let names: Vec<&str> = LAW_MODES.iter().map(|(n, _)| *n).collect();
            bad(format!("unknown mode '{name}' (expected one of {})", names.join(", ")))
        })?;
        let (rest, onset) = match rest.split_once('@') {
            Some((r, o)) => {
                let onset: u32 = o.trim().parse().map_err(|_| bad(format!("onset '{o}' is not a flight number")))?;
                if onset == 0 {
                    return Err(bad("flights count from 1".into()));
                }
                (r, onset)
            }
            None => (rest, 1),
        };
        let (start, rate) = match rest.split_once('+') {
            Some((s, r)) => (s, r),
            None => (rest, "0"),
        };
        let number = |s: &str, what: &str| -> Result<f32, CliError> {
            let v: f32 = s.trim().parse().map_err(|_| bad(format!("{what} '{s}' is not a number")))?;
            if (0.0..=1.0).contains(&v) {
                Ok(v)
            } else {
                Err(bad(format!("{what} {v} is outside [0, 1]")))
            }
        };
        Ok(Self { name: name.to_owned(), index, start: number(start, "start")?, rate: number(rate, "rate")?, onset })
    }

    /// The law's severity at flight `flight` (continuous: the crossing search reads between
    /// flights).
    pub fn severity(&self, flight: f64) -> f64 {
        if flight < f64::from(self.onset) {
            0.0
        } else {
            (f64::from(self.start) + f64::from(self.rate) * (flight - f64::from(self.onset))).min(1.0)
        }
    }
}

/// The true fault vector of flight `flight` under `laws`.
pub fn truth_at(laws: &[Law], flight: u32) -> FaultVector {
    let mut k = FaultVector::HEALTHY;
    for law in laws {
        let s = law.severity(f64::from(flight)) as f32;
        match law.index {
            7 => k.0[7] = 0.5 + 0.5 * s,
            i => k.0[i] = s,
        }
    }
    k
}

/// The report mode (in [`FaultMode::ALL`] order) a law's index belongs to.
fn law_mode(index: usize) -> usize {
    match index {
        0 => 0,
        1 => 1,
        2..=4 => 2,
        5 | 6 => 3,
        _ => 4,
    }
}

/// The first flight at which the laws of mode `mode` reach `threshold` (a law at `START` from
/// `ONSET` reaches it at `ONSET` when `START ≥ threshold`, else at `ONSET + (threshold − START)/RATE`
/// when it rises); `None` when they never do.
pub fn true_crossing(laws: &[Law], mode: usize, threshold: f64) -> Option<f64> {
    laws.iter()
        .filter(|l| law_mode(l.index) == mode)
        .filter_map(|l| {
            let (start, rate, onset) = (f64::from(l.start), f64::from(l.rate), f64::from(l.onset));
            if start >= threshold {
                Some(onset)
            } else if rate > 0.0 && threshold <= 1.0 {
                Some(onset + (threshold - start) / rate)
            } else {
                None
            }
        })
        .min_by(f64::total_cmp)
}

/// One flight of the JSON document.
#[derive(Clone, Debug, Serialize)]
pub struct FlightJson {
    /// Flight number (1 for the first).
    pub flight: u32,
    /// The recording (absent under `--simulate`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// `cold` or `warm`.
    pub start: Start,
    /// Objective evaluations.
    pub evaluations: u32,
    /// Groups whose new-fault probe fired, under a warm flight.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub probes_fired: Option<Vec<&'static str>>,
    /// Wall time of the identification (s).
    pub identification_s: f64,
    /// The report's status.
    pub status: &'static str,
    /// Severity per mode (friction, backlash, short circuit, eccentricity, gain drift).
    pub severity: [f32; 5],
    /// The identified fault vector.
    pub k: [f32; 8],
    /// Flights remaining to the failing threshold per mode after this flight (null: none).
    pub remaining_flights: [Option<f32>; 5],
    /// This flight's log-likelihood ratio per mode (nats; null: no diagnosis, no evidence).
    pub evidence_llr: Option<[f32; 5]>,
    /// The record's sequential sum per mode after this flight (nats).
    pub evidence_sum: [f32; 5],
    /// Modes declared by pooled evidence on this flight: present by the sums, dropped by the
    /// flight's own model selection, refitted into the diagnosis the record keeps.
    pub declared: Vec<&'static str>,
    /// The fault vector the record keeps when a declaration changed it (`k` with the declared
    /// modes refitted in; absent: the record keeps `k`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_pooled: Option<[f32; 8]>,
    /// Severity per mode as the record keeps it (`severity` with the declared modes refitted in).
    pub pooled_severity: [f32; 5],
    /// The true fault vector (under `--simulate`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_true: Option<[f32; 8]>,
    /// The paper's Err% of this flight (under `--simulate`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub err_percent: Option<f32>,
}

/// One mode's trend and RUL at the last flight.
#[derive(Clone, Debug, Serialize)]
pub struct ModeJson {
    /// The mode's name.
    pub mode: &'static str,
    /// Diagnoses in the history.
    pub points: u16,
    /// Slope of the trend (severity per flight; null: no trend).
    pub slope_per_flight: Option<f32>,
    /// Its standard error.
    pub slope_se_per_flight: Option<f32>,
    /// The flight at which the trend reaches the failing threshold (null: it does not rise).
    pub crossing_flight: Option<f32>,
    /// The interval's lower end (null: no crossing, or unbounded).
    pub crossing_lower_flight: Option<f32>,
    /// The interval's upper end (null: no crossing, or unbounded).
    pub crossing_upper_flight: Option<f32>,
    /// Flights remaining from the last flight (at least 0).
    pub remaining_flights: Option<f32>,
    /// Lower end of the remaining flights.
    pub remaining_lower_flights: Option<f32>,
    /// Upper end of the remaining flights (null: unbounded).
    pub remaining_upper_flights: Option<f32>,
    /// The true crossing flight (under `--simulate`; null: never).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub true_crossing_flight: Option<Option<f64>>,
    /// The predicted crossing minus the true one, in flights (under `--simulate`; null when
    /// either is missing).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crossing_error_flights: Option<Option<f64>>,
    /// First faulty flight (under `--simulate`; null: never faulty).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub onset_flight: Option<Option<u32>>,
    /// First flight from the onset on at which the mode was reported (under `--simulate`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub detected_flight: Option<Option<u32>>,
    /// Flights reporting the mode before its onset or without one (under `--simulate`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub false_reports: Option<u32>,
    /// First flight the mode was declared by pooled evidence (null: never).
    pub declared_flight: Option<u32>,
    /// Flights declaring the mode before its onset or without one (under `--simulate`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub false_declarations: Option<u32>,
}

/// The scores of a degradation campaign (under `--simulate`).
#[derive(Clone, Debug, Serialize)]
pub struct CampaignJson {
    /// The laws as given.
    pub laws: Vec<String>,
    /// Master seed.
    pub seed: u64,
    /// Mean Err% of the cold flights.
    pub cold_mean_err_percent: Option<f32>,
    /// Mean Err% of the warm flights (null: none).
    pub warm_mean_err_percent: Option<f32>,
    /// Drift-only warm flights on which a probe fired (null: no warm flight).
    pub probe_false_alarms: Option<u32>,
    /// Warm flights with a new fault that no probe caught and the report missed (null: no warm
    /// flight).
    pub probe_misses: Option<u32>,
}

/// `ema history --json` and `history.json`.
#[derive(Clone, Debug, Serialize)]
pub struct HistoryJson {
    /// [`RUL_CONFIDENCE`].
    pub confidence: f32,
    /// The failing threshold of a severity.
    pub failing_at: f32,
    /// Flights the on-board history holds.
    pub history_capacity: usize,
    /// Every flight.
    pub flights: Vec<FlightJson>,
    /// Every mode's trend at the last flight.
    pub modes: Vec<ModeJson>,
    /// The scores against the truth (under `--simulate`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub campaign: Option<CampaignJson>,
}

/// One flight to identify: its recording and, under `--simulate`, the truth.
struct Flight {
    recording: Recording,
    label: PathBuf,
    file: Option<String>,
    truth: Option<FaultVector>,
    seed: u64,
}

/// The seed of flight `flight` from the master seed: SplitMix64's `flight`-th output from the
/// state `master` ([`SPLITMIX_GAMMA`] `flight` times, then [`splitmix64_mix`]).
fn flight_seed(master: u64, flight: u32) -> u64 {
    splitmix64_mix(master.wrapping_add(u64::from(flight).wrapping_mul(SPLITMIX_GAMMA)))
}

/// The flights to run: the files read, or the flights simulated under the laws.
fn flight_source(
    args: &HistoryArgs,
    laws: &[Law],
    params: &EmaParams,
    profile: &Profile,
    n: usize,
) -> Result<Flight, CliError> {
    if laws.is_empty() {
        let path = &args.files[n];
        let load = args.recording.load(path, Some(profile), params)?;
        return Ok(Flight {
            recording: load.recording,
            label: path.clone(),
            file: Some(path.display().to_string()),
            truth: None,
            seed: args.seed,
        });
    }
    let flight = n as u32 + 1;
    let truth = truth_at(laws, flight);
    let seed = flight_seed(args.seed, flight);
    let config = SimConfig { params: *params, faults: truth, seed, profile: *profile, ..SimConfig::default() };
    let rec = simulate(&config).map_err(|e| CliError::Simulation(e.to_string()))?;
    Ok(Flight {
        recording: Recording::from_reference(&rec, Vec::new()),
        label: PathBuf::from(format!("simulated flight {flight}")),
        file: None,
        truth: Some(truth),
        seed,
    })
}

/// The outcome of a series: one row per flight, the history, and the prognosis per mode.
pub struct Series {
    /// The flights.
    pub flights: Vec<FlightJson>,
    /// The health record after the last flight (its history per mode).
    pub record: HealthRecord,
    /// The prognosis per mode after the last flight.
    pub prognosis: [Option<Prognosis>; 5],
    /// The reports of the flights.
    pub reports: Vec<HealthReport>,
    /// Under `--simulate`: drift-only warm flights (no group present in the truth and absent
    /// from the prior) on which a probe fired.
    pub probe_false_alarms: u32,
    /// Under `--simulate`: warm flights with a new fault on which no probe fired and the new
    /// group went unreported.
    pub probe_misses: u32,
    /// The flights a mode was declared by pooled evidence, per mode.
    pub declared: [Vec<u32>; 5],
}

/// Runs the series: every flight through [`identify_flight`], the history and prognosis after
/// each.
pub fn run_series(args: &HistoryArgs, laws: &[Law], params: &EmaParams) -> Result<Series, CliError> {
    let profile = resolve_profile(&args.profile)?;
    let command = ModelCommand::Profile { profile, name: args.profile.clone() };
    let count = if laws.is_empty() { args.files.len() } else { args.flights as usize };
    let bar = progress::bar(count as u64, "flights", args.progress.visible());
    let mut record = HealthRecord::new();
    let mut last_warm_needs_cold = false;
    let (mut probe_false_alarms, mut probe_misses) = (0u32, 0u32);
    let (mut flights, mut reports) = (Vec::new(), Vec::new());
    let mut prognosis = [None; 5];
    let mut declared: [Vec<u32>; 5] = Default::default();
    for n in 0..count {
        let f = flight_source(args, laws, params, &profile, n)?;
        let config = IdentifyConfig { seed: f.seed, ..IdentifyConfig::onboard() };
        let prior = record.has_prior().then(|| record.k().0);
        let since_cold = (record.flights_since_cold(), last_warm_needs_cold);
        let result = identify_flight(&f.recording, &f.label, prior, since_cold, params, &command, &config)?;
        last_warm_needs_cold = result.warm.is_some_and(|w| w.needs_cold(&result.report));
        if let (Some(w), Some(truth), Some(prior)) = (result.warm, f.truth, prior) {
            // per warm flight: a new fault is a group present in the truth and absent from the prior
            let new = |g: &(usize, usize)| group_present(&truth.0, *g) && !group_present(&prior, *g);
            let any_new = FAULT_GROUPS.iter().any(new);
            let unreported = FAULT_GROUPS.iter().any(|g| new(g) && !group_present(&result.report.faults.0, *g));
            probe_false_alarms += u32::from(!any_new && w.fired != 0);
            probe_misses += u32::from(any_new && w.fired == 0 && unreported);
        }
        bar.inc(1);
        let number = n as u32 + 1;
        let r = &result.report;
        let cold = result.start == Start::Cold;
        let pooled: Option<PooledFlight> =
            evidence::record_flight_on(&mut record, &*result.trace, *params, command.command(), &config, r, cold);
        let names = pooled.map_or_else(Vec::new, |p| {
            (0..EVIDENCE_MODES).filter(|&m| p.declared[m]).map(evidence::mode_name).collect::<Vec<_>>()
        });
        if let Some(p) = &pooled {
            for (m, d) in declared.iter_mut().enumerate() {
                if p.declared[m] {
                    d.push(number);
                }
            }
        }
        let kept = pooled.map_or(*r, |p| p.report);
        for mode in FaultMode::ALL {
            prognosis[mode.index()] = Prognosis::of_record(&record, mode);
        }
        flights.push(FlightJson {
            flight: number,
            file: f.file,
            start: result.start,
            evaluations: r.evaluations,
            probes_fired: result.warm.map(|w| {
                core_monitor::GROUP_NAMES
                    .iter()
                    .enumerate()
                    .filter(|&(g, _)| w.fired_group(g))
                    .map(|(_, &n)| n)
                    .collect()
            }),
            identification_s: result.seconds,
            status: r.status.label(),
            severity: r.modes.map(|m| m.severity),
            k: r.faults.0,
            remaining_flights: prognosis.map(|p| p.and_then(|p| p.remaining()).map(|r| r.0)),
            evidence_llr: pooled.map(|p| p.flight.llr),
            evidence_sum: *record.evidence(),
            declared: names,
            k_pooled: (kept.faults != r.faults).then_some(kept.faults.0),
            pooled_severity: kept.modes.map(|m| m.severity),
            k_true: f.truth.map(|t| t.0),
            err_percent: f.truth.map(|t| r.faults.paper_error_percent(&t)),
        });
        reports.push(result.report);
    }
    bar.finish_and_clear();
    Ok(Series { flights, record, prognosis, reports, probe_false_alarms, probe_misses, declared })
}

/// The per-mode block of the document.
fn modes_json(series: &Series, laws: &[Law], params: &EmaParams) -> Vec<ModeJson> {
    let simulated = !laws.is_empty();
    FaultMode::ALL
        .iter()
        .map(|&mode| {
            let i = mode.index();
            let p = series.prognosis[i];
            let c = p.and_then(|p| p.failing);
            let rem = p.and_then(|p| p.remaining());
            let truth_severity = |f: &FlightJson| {
                f.k_true.map_or(0.0, |k| {
                    HealthReport::new(FaultVector(k), params, 0.0, 0, 0, None).modes.get(i).map_or(0.0, |m| m.severity)
                })
            };
            let onset = series.flights.iter().find(|f| truth_severity(f) > 0.0).map(|f| f.flight);
            let reported = |f: &FlightJson| f.status_is_diagnosis() && f.severity[i] > PRESENT_SEVERITY;
            let detected =
                onset.and_then(|o| series.flights.iter().find(|f| f.flight >= o && reported(f))).map(|f| f.flight);
            let truth = true_crossing(laws, i, f64::from(FAILING_AT));
            let false_reports =
                series.flights.iter().filter(|f| reported(f) && onset.is_none_or(|o| f.flight < o)).count() as u32;
            let declarations = &series.declared[i];
            let false_declarations = declarations.iter().filter(|&&f| onset.is_none_or(|o| f < o)).count() as u32;
            ModeJson {
                mode: mode.name(),
                points: series.record.history(mode).len() as u16,
                slope_per_flight: p.map(|p| p.trend.slope),
                slope_se_per_flight: p.map(|p| p.trend.slope_se),
                crossing_flight: c.map(|c| c.flight),
                crossing_lower_flight: c.map(|c| c.lower).filter(|v| v.is_finite()),
                crossing_upper_flight: c.and_then(|c| c.upper),
                remaining_flights: rem.map(|r| r.0),
                remaining_lower_flights: rem.map(|r| r.1),
                remaining_upper_flights: rem.and_then(|r| r.2),
                true_crossing_flight: simulated.then_some(truth),
                crossing_error_flights: simulated
                    .then(|| c.zip(truth).map(|(c, t)| (f64::from(c.flight) - t) * 100.0).map(|e| e.round() / 100.0)),
                onset_flight: simulated.then_some(onset),
                detected_flight: simulated.then_some(detected),
                false_reports: simulated.then_some(false_reports),
                declared_flight: if simulated {
                    onset.and_then(|o| declarations.iter().copied().find(|&f| f >= o))
                } else {
                    declarations.first().copied()
                },
                false_declarations: simulated.then_some(false_declarations),
            }
        })
        .collect()
}

impl FlightJson {
    fn status_is_diagnosis(&self) -> bool {
        matches!(self.status, "HEALTHY" | "DEGRADED" | "FAILING")
    }
}

/// The document of a finished series.
pub fn document(series: &Series, laws: &[Law], args: &HistoryArgs, params: &EmaParams) -> HistoryJson {
    let mean = |start: Start| {
        let errs: Vec<f32> = series.flights.iter().filter(|f| f.start == start).filter_map(|f| f.err_percent).collect();
        (!errs.is_empty()).then(|| errs.iter().sum::<f32>() / errs.len() as f32)
    };
    let warm = series.flights.iter().any(|f| f.start == Start::Warm);
    HistoryJson {
        confidence: RUL_CONFIDENCE,
        failing_at: FAILING_AT,
        history_capacity: HISTORY_CAPACITY,
        flights: series.flights.clone(),
        modes: modes_json(series, laws, params),
        campaign: (!laws.is_empty()).then(|| CampaignJson {
            laws: args.simulate.clone(),
            seed: args.seed,
            cold_mean_err_percent: mean(Start::Cold),
            warm_mean_err_percent: mean(Start::Warm),
            probe_false_alarms: warm.then_some(series.probe_false_alarms),
            probe_misses: warm.then_some(series.probe_misses),
        }),
    }
}

fn opt(v: Option<f32>, digits: usize) -> String {
    v.map_or("–".to_owned(), |v| format!("{v:.digits$}"))
}

/// The readable report: a table of the flights, then one of the modes.
pub fn text(doc: &HistoryJson) -> String {
    let mut out = String::new();
    let names: Vec<&str> = FaultMode::ALL.iter().map(|m| m.name()).collect();
    let _ = writeln!(
        out,
        "| flight | start | evaluations | status | {} | declared by pooled evidence |",
        names.join(" | ")
    );
    let _ = writeln!(out, "|{}", "---|".repeat(5 + names.len()));
    for f in &doc.flights {
        let sev: Vec<String> = f.severity.iter().map(|s| format!("{s:.3}")).collect();
        let declared: Vec<String> = f
            .declared
            .iter()
            .map(|&name| {
                let i = FaultMode::ALL.iter().position(|m| m.name() == name).unwrap_or(0);
                format!("{name} {:.3}", f.pooled_severity[i])
            })
            .collect();
        let declared = if declared.is_empty() { "–".to_owned() } else { declared.join(", ") };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {declared} |",
            f.flight,
            match f.start {
                Start::Cold => "cold",
                Start::Warm => "warm",
            },
            f.evaluations,
            f.status,
            sev.join(" | ")
        );
    }
    let simulated = doc.campaign.is_some();
    let _ = write!(
        out,
        "\n| mode | slope /flight | crossing flight | {:.0} % interval | flights left | declared (pooled) |",
        100.0 * doc.confidence
    );
    if simulated {
        let _ =
            write!(out, " true crossing | crossing error | onset | detected | false reports | false declarations |");
    }
    let _ = writeln!(out, "\n|{}", "---|".repeat(if simulated { 12 } else { 6 }));
    for m in &doc.modes {
        let interval = match (m.crossing_flight, m.crossing_lower_flight, m.crossing_upper_flight) {
            (None, ..) => "–".to_owned(),
            (Some(_), lo, hi) => format!("[{}, {}]", opt(lo, 2), hi.map_or("∞".to_owned(), |h| format!("{h:.2}"))),
        };
        let left = match (m.remaining_flights, m.remaining_lower_flights, m.remaining_upper_flights) {
            (Some(r), Some(lo), hi) => {
                format!("{r:.2} [{lo:.2}, {}]", hi.map_or("∞".to_owned(), |h| format!("{h:.2}")))
            }
            _ => "–".to_owned(),
        };
        let slope = match (m.slope_per_flight, m.slope_se_per_flight) {
            (Some(b), Some(se)) => format!("{b:.4} ± {se:.4}"),
            _ => "–".to_owned(),
        };
        let declared = m.declared_flight.map_or("–".to_owned(), |f| format!("flight {f}"));
        let _ =
            write!(out, "| {} | {slope} | {} | {interval} | {left} | {declared} |", m.mode, opt(m.crossing_flight, 2));
        if simulated {
            let flight = |v: Option<Option<u32>>| v.flatten().map_or("–".to_owned(), |f| f.to_string());
            let _ = write!(
                out,
                " {} | {} | {} | {} | {} | {} |",
                m.true_crossing_flight.flatten().map_or("–".to_owned(), |f| format!("{f:.2}")),
                m.crossing_error_flights.flatten().map_or("–".to_owned(), |e| format!("{e:+.2}")),
                flight(m.onset_flight),
                flight(m.detected_flight),
                m.false_reports.unwrap_or(0),
                m.false_declarations.unwrap_or(0)
            );
        }
        out.push('\n');
    }
    if let Some(c) = &doc.campaign {
        let _ = write!(
            out,
            "\nlaws {}, seed {}: mean Err% cold {}, warm {}; probes: {}",
            c.laws.join(" "),
            c.seed,
            opt(c.cold_mean_err_percent, 2),
            opt(c.warm_mean_err_percent, 2),
            match (c.probe_false_alarms, c.probe_misses) {
                (Some(fa), Some(miss)) => format!("{fa} false alarms (drift-only flights), {miss} misses"),
                _ => "not run (every flight cold)".to_owned(),
            }
        );
    }
    let _ = write!(
        out,
        "\ntrend: least-squares line over the last {} diagnoses; interval: Fieller's at {:.0} %; failing at severity {}; \
         degraded from {DEGRADED_AT}; declared by pooled evidence: present by the per-mode sequential sum of \
         log-likelihood ratios, dropped by the flight's own model selection, refitted into what the record keeps",
        doc.history_capacity,
        100.0 * doc.confidence,
        doc.failing_at
    );
    out
}

/// Colours of the five modes in the plot.
const MODE_COLOURS: [(u8, u8, u8); 5] = [(31, 119, 180), (214, 39, 40), (44, 160, 44), (148, 103, 189), (255, 127, 14)];

/// `severity.svg`: the modes that were ever reported or declared, or have a trend that rises; the
/// flights a mode was declared by pooled evidence ringed.
pub fn plot(doc: &HistoryJson, series: &Series) -> std::io::Result<String> {
    let last = doc.flights.last().map_or(1.0, |f| f64::from(f.flight));
    let mut x_max = last + 1.0;
    let points: Vec<Vec<(f64, f64)>> = FaultMode::ALL
        .into_iter()
        .map(|mode| {
            series.record.history(mode).iter().map(|e| (f64::from(e.flight), f64::from(e.severity))).collect::<Vec<_>>()
        })
        .collect();
    // the flights a mode was declared by pooled evidence, at the severity the record keeps
    let declared: Vec<Vec<(f64, f64)>> = (0..FaultMode::ALL.len())
        .map(|i| {
            doc.flights
                .iter()
                .filter(|f| series.declared[i].contains(&f.flight))
                .map(|f| (f64::from(f.flight), f64::from(f.pooled_severity[i])))
                .collect()
        })
        .collect();
    let mut shown = Vec::new();
    for (i, mode) in FaultMode::ALL.iter().enumerate() {
        let ever = points[i].iter().any(|p| p.1 > f64::from(PRESENT_SEVERITY)) || !declared[i].is_empty();
        let p = series.prognosis[i];
        let crossing = p.and_then(|p| p.failing);
        if !ever && crossing.is_none() {
            continue;
        }
        let trend = p.map(|p| {
            let first = points[i].first().map_or(1.0, |q| q.0);
            let end = crossing.map_or(last, |c| f64::from(c.flight).clamp(last, last + 3.0 * (last - first + 1.0)));
            let at = |f: f64| f64::from(p.trend.at(f as f32));
            ((first, at(first)), (end, at(end)))
        });
        if let Some((_, (end, _))) = trend {
            x_max = x_max.max(end + 1.0);
        }
        let band = crossing.map(|c| (f64::from(c.lower), c.upper.map(f64::from)));
        shown.push((mode.name(), MODE_COLOURS[i], i, trend, band));
    }
    let series_list: Vec<SeveritySeries> = shown
        .iter()
        .map(|&(name, colour, i, trend, band)| SeveritySeries {
            name,
            colour,
            points: &points[i],
            declared: &declared[i],
            trend,
            band,
        })
        .collect();
    plots::severity_plot("Severity per flight, trend and RUL band", &series_list, f64::from(FAILING_AT), x_max)
}

/// Runs `ema history`.
pub fn run(args: &HistoryArgs) -> Result<String, CliError> {
    let laws = args.simulate.iter().map(|l| Law::parse(l)).collect::<Result<Vec<_>, _>>()?;
    if laws.is_empty() && args.files.is_empty() {
        return Err(CliError::flag("FILES", "give recordings of successive flights or --simulate LAW…"));
    }
    let params = args.params.load()?;
    let overwrite = args.output.overwrite();
    if let Some(dir) = &args.output.out {
        prepare_dir(dir, &OUTPUT_FILES, overwrite)?;
    }
    let series = run_series(args, &laws, &params)?;
    let doc = document(&series, &laws, args, &params);
    let json = Document::new(None, &doc).to_json();
    if let Some(dir) = &args.output.out {
        let svg = plot(&doc, &series).map_err(|source| CliError::Io { path: dir.join("severity.svg"), source })?;
        let paths = OUTPUT_FILES.map(|name| dir.join(name));
        write_files(&[(&paths[0], json.as_bytes()), (&paths[1], svg.as_bytes())], overwrite)?;
    }
    Ok(if args.json { json } else { text(&doc) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn laws_parse_and_grow() {
        let l = Law::parse("friction=0.05+0.04").unwrap();
        assert_eq!((l.index, l.start, l.rate, l.onset), (0, 0.05, 0.04, 1));
        assert!((l.severity(3.0) - 0.13).abs() < 1e-6);
        let s = Law::parse("short_b=0.3@5").unwrap();
        assert_eq!((s.index, s.rate, s.onset), (3, 0.0, 5));
        assert_eq!(s.severity(4.0), 0.0);
        assert!((s.severity(9.0) - 0.3).abs() < 1e-6);
        let k = truth_at(&[l.clone(), s.clone(), Law::parse("gain=0.2").unwrap()], 5);
        assert!((k.0[0] - 0.21).abs() < 1e-6 && (k.0[3] - 0.3).abs() < 1e-6 && (k.0[7] - 0.6).abs() < 1e-6);
        // friction reaches 0.5 at flight 1 + 0.45/0.04 = 12.25
        assert!((true_crossing(&[l], 0, 0.5).unwrap() - 12.25).abs() < 1e-4);
        assert_eq!(true_crossing(&[s], 2, 0.5), None);
        for bad in ["friction", "wear=0.1", "friction=1.5", "friction=0.1+x", "friction=0.1@0", "gain=0.1@x"] {
            assert!(Law::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn flight_seeds_differ() {
        assert_ne!(flight_seed(1, 1), flight_seed(1, 2));
        assert_ne!(flight_seed(1, 1), flight_seed(2, 1));
    }
}
