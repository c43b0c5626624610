//! One flight through the on-board sequence: warm or cold as the core plans it, acquired
//! through the frame checks and identified by the host runtime.

use std::path::Path;

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::health::HealthReport;
use ema_monitor::monitor::{self as core_monitor, IdentifyConfig, WarmReport};
use ema_monitor::EmaParams;
use serde::Serialize;

use crate::error::CliError;
use crate::recording::Recording;
use crate::runtime::command::ModelCommand;
use crate::runtime::identification::identify_trace;
use crate::runtime::recording::condition_recording_checked_for;
use crate::runtime::source::HOST_WINDOW;

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
    pub trace: Box<ConditionedWindow<HOST_WINDOW>>,
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
