//! One flight through the core's flight API ([`HealthMonitor`]), as the firmware flies it: the
//! recording acquired through the frame checks, then planned (warm or cold) from the health
//! record, identified, reported with its uncertainty and added to the record with the evidence
//! pooled over flights, by the core's own code; the host only evaluates the global search's
//! sweeps in parallel ([`HostHooks`]).

use std::path::Path;

use ema_monitor::diagnosis::{IdentifyConfig, ONBOARD_POPULATION};
use ema_monitor::flight::{Flight, HealthMonitor};
use ema_monitor::persist::HealthRecord;
use ema_monitor::EmaParams;
use serde::Serialize;

use crate::error::CliError;
use crate::recording::Recording;
use crate::runtime::command::ModelCommand;
use crate::runtime::flight::{acquire_flight, HostHooks};
use crate::runtime::source::HOST_WINDOW;
use crate::runtime::temperature::ModelParams;

/// How a flight's identification started.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Start {
    /// From scratch: the global search, model selection and polish.
    Cold,
    /// From the previous flight's diagnosis.
    Warm,
}

/// One flight.
#[derive(Clone, Copy, Debug)]
pub struct FlightResult {
    /// The flight as the core diagnosed and recorded it.
    pub flight: Flight,
    /// How it started: cold when planned cold, or when a warm attempt failed its fit check and
    /// went on cold in the same call ([`Flight::cold`]).
    pub start: Start,
    /// Wall time of the identification (s).
    pub seconds: f64,
}

/// Flies one flight's `recording` (named `label` in errors) of the actuator `params` (at 20 °C;
/// `model`: at the recording's temperature) driven by `command`, identified with `config`, and
/// adds it to `record`, as the firmware does ([`HealthMonitor::diagnose`]): warm from the record's
/// diagnosis when the core's plan allows it ([`HealthMonitor::plan`]), cold otherwise.
pub fn identify_flight(
    recording: &Recording,
    label: &Path,
    (params, model): (&EmaParams, &ModelParams),
    command: &ModelCommand,
    config: &IdentifyConfig,
    record: &mut HealthRecord,
) -> Result<FlightResult, CliError> {
    let refused = |e: ema_monitor::diagnosis::MonitorError| CliError::input(label, e.to_string());
    let monitor =
        HealthMonitor::<HOST_WINDOW, ONBOARD_POPULATION>::new(*params, command.command(), *config).map_err(refused)?;
    let (trace, acquired) = acquire_flight(&monitor, recording, label, model, command)?;
    let mut hooks = HostHooks::default();
    let flight = monitor.diagnose(&trace, &acquired, record, &mut hooks).map_err(refused)?;
    let start = if flight.cold { Start::Cold } else { Start::Warm };
    Ok(FlightResult { flight, start, seconds: hooks.seconds() })
}
