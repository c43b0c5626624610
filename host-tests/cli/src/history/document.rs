//! The document of a finished series: every mode's trend, RUL and detection scores, and the
//! campaign's scores under `--simulate`.

use ema_monitor::faults::FaultMode;
use ema_monitor::health::{HealthReport, FAILING_AT};
use ema_monitor::prognosis::{HISTORY_CAPACITY, RUL_CONFIDENCE};
use ema_monitor::{EmaParams, FaultVector};

use super::args::HistoryArgs;
use super::flight::Start;
use super::json::{CampaignJson, FlightJson, HistoryJson, ModeJson};
use super::law::{true_crossing, Law};
use super::series::Series;

/// A mode counts as reported when its severity exceeds this (model selection sets an absent
/// group exactly healthy, severity 0).
pub const PRESENT_SEVERITY: f32 = 1e-3;

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
            let truth = true_crossing(laws, mode, f64::from(FAILING_AT));
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
