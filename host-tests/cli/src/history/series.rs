//! A series of flights of one actuator (the files, or flights simulated under the laws), each
//! joining the core's health record through the evidence pooled over flights, with the
//! prognosis after each.

use std::path::PathBuf;

use ema_monitor::diagnosis::evidence::PooledFlight;
use ema_monitor::diagnosis::{group_present, IdentifyConfig};
use ema_monitor::faults::{FaultGroup, FaultMode};
use ema_monitor::health::{HealthReport, Status};
use ema_monitor::optimizer::rng::{splitmix64_mix, SPLITMIX_GAMMA};
use ema_monitor::persist::HealthRecord;
use ema_monitor::prognosis::Prognosis;
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};

use super::args::HistoryArgs;
use super::flight::identify_flight;
use super::json::FlightJson;
use super::law::{truth_at, Law};
use crate::error::CliError;
use crate::input::check_distinct;
use crate::progress;
use crate::recording::{Recording, MAX_FILE_BYTES};
use crate::runtime::command::ModelCommand;
use crate::runtime::temperature::model_params;
use crate::simulate::resolve_profile;

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
    /// The status of the last flight's report as the record keeps it (the flight's own, with
    /// each mode declared by pooled evidence refitted in): the actuator's current state; `None`
    /// without flights.
    pub current: Option<Status>,
}

/// Checks every recording of `ema history FILE…` before the first flight: no file given twice
/// ([`check_distinct`]), and each read (`--column`, `--start`, … and the profile's alignment) and
/// taken at its temperature exactly as its flight will take it; the first error names its file.
/// The recordings are read again flight by flight, so that one flight's recording is in memory
/// at a time.
pub fn check_flights(args: &HistoryArgs, params: &EmaParams) -> Result<(), CliError> {
    let profile = resolve_profile(&args.profile)?;
    check_distinct(&args.files, MAX_FILE_BYTES)?;
    for path in &args.files {
        let load = args.recording.load(path, Some(&profile), params)?;
        model_params(&load.recording, path, params)?;
    }
    Ok(())
}

/// Runs the series: every flight through [`identify_flight`] (the core's
/// [`HealthMonitor`](ema_monitor::flight::HealthMonitor) on the health record), the history and
/// prognosis after each.
pub fn run_series(args: &HistoryArgs, laws: &[Law], params: &EmaParams) -> Result<Series, CliError> {
    let profile = resolve_profile(&args.profile)?;
    let command = ModelCommand::Profile { profile, name: args.profile.clone() };
    let count = if laws.is_empty() { args.files.len() } else { args.flights as usize };
    let bar = progress::bar(count as u64, "flights", args.progress.visible());
    let mut record = HealthRecord::new();
    let (mut probe_false_alarms, mut probe_misses) = (0u32, 0u32);
    let (mut flights, mut reports) = (Vec::new(), Vec::new());
    let mut prognosis = [None; 5];
    let mut declared: [Vec<u32>; 5] = Default::default();
    let mut current = None;
    for n in 0..count {
        let f = flight_source(args, laws, params, &profile, n)?;
        // the actuator at the flight's temperature, when its recording has one
        let model = model_params(&f.recording, &f.label, params)?;
        let config = IdentifyConfig { seed: f.seed, ..IdentifyConfig::onboard() };
        let prior = record.has_prior().then(|| record.faults().0);
        let result = identify_flight(&f.recording, &f.label, (params, &model), &command, &config, &mut record)?;
        let flight = &result.flight;
        let r = &flight.report;
        if let (Some(w), Some(truth), Some(prior)) = (flight.warm, f.truth, prior) {
            // per warm flight: a new fault is a group present in the truth and absent from the prior
            let new = |g: FaultGroup| group_present(&truth.0, g) && !group_present(&prior, g);
            let any_new = FaultGroup::ALL.into_iter().any(new);
            let unreported = FaultGroup::ALL.into_iter().any(|g| new(g) && !group_present(&r.faults.0, g));
            probe_false_alarms += u32::from(!any_new && w.fired != 0);
            probe_misses += u32::from(any_new && w.fired == 0 && unreported);
        }
        bar.inc(1);
        let number = flight.number;
        let pooled: Option<PooledFlight> = flight.pooled;
        let names = pooled.map_or_else(Vec::new, |p| {
            FaultMode::ALL.into_iter().filter(|m| p.declared[m.index()]).map(FaultMode::name).collect::<Vec<_>>()
        });
        if let Some(p) = &pooled {
            for (m, d) in declared.iter_mut().enumerate() {
                if p.declared[m] {
                    d.push(number);
                }
            }
        }
        let kept = *flight.recorded_report();
        current = Some(kept.status);
        for mode in FaultMode::ALL {
            prognosis[mode.index()] = Prognosis::of_record(&record, mode);
        }
        flights.push(FlightJson {
            flight: number,
            file: f.file,
            temperature_c: model.temperature_c,
            start: result.start,
            evaluations: r.evaluations,
            probes_fired: flight
                .warm
                .map(|w| FaultGroup::ALL.into_iter().filter(|&g| w.fired_group(g)).map(FaultGroup::name).collect()),
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
        reports.push(*r);
    }
    bar.finish_and_clear();
    Ok(Series { flights, record, prognosis, reports, probe_false_alarms, probe_misses, declared, current })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flight_seeds_differ() {
        assert_ne!(flight_seed(1, 1), flight_seed(1, 2));
        assert_ne!(flight_seed(1, 1), flight_seed(2, 1));
    }
}
