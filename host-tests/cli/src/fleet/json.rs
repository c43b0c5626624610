//! The document of `ema fleet`: the counts of the results page's tables, then each unit's
//! flights. `--json` prints it in the envelope ([`crate::schema::Document`]); the markdown
//! tables ([`super::tables()`]) are rendered from it. `docs/output-schema.md` lists every key.

use ema_monitor::faults::FaultMode;
use ema_monitor::health::Status;
use serde::Serialize;

use super::unit::{FaultyFlight, UnitResult, COLD_C, COMMISSIONING_C, FAULTY_C, FOURTH_C, HOT_C, SEVERITY};

/// One flight's report.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct FlightJson {
    /// The flight's temperature (°C), known to the identification.
    pub temperature_c: f32,
    /// `HEALTHY`, `DEGRADED`, `FAILING`, `INCONCLUSIVE` or `SENSOR_FAULT`.
    pub status: &'static str,
    /// Why `INCONCLUSIVE` (null otherwise).
    pub reason: Option<&'static str>,
}

impl FlightJson {
    /// The report `status` of a flight at `temperature_c`.
    pub fn new(temperature_c: f32, status: Status) -> Self {
        FlightJson { temperature_c, status: status.label(), reason: status.reason().map(|r| r.label()) }
    }

    /// The status as the tables print it ([`status_label`]).
    pub fn label(&self) -> String {
        status_label(self.status, self.reason)
    }
}

/// A status as the tables print it: `INCONCLUSIVE (poor fit)`, or the label alone.
pub fn status_label(status: &str, reason: Option<&str>) -> String {
    match reason {
        Some(r) => format!("{status} ({r})"),
        None => status.to_owned(),
    }
}

/// One faulty flight's report.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct FaultyFlightJson {
    /// The fault mode present (`friction`, …, `gain drift`).
    pub mode: &'static str,
    /// The flight's temperature (°C), known to the identification.
    pub temperature_c: f32,
    /// The report's status, as [`FlightJson::status`].
    pub status: &'static str,
    /// Why `INCONCLUSIVE` (null otherwise).
    pub reason: Option<&'static str>,
    /// The paper's Err% of the identified fault vector against the true one.
    pub err_percent: f32,
}

impl FaultyFlightJson {
    /// The status as the tables print it ([`status_label`]).
    pub fn label(&self) -> String {
        status_label(self.status, self.reason)
    }
}

impl From<&FaultyFlight> for FaultyFlightJson {
    fn from(f: &FaultyFlight) -> Self {
        let flight = FlightJson::new(f.temperature_c, f.status);
        FaultyFlightJson {
            mode: f.mode.name(),
            temperature_c: f.temperature_c,
            status: flight.status,
            reason: flight.reason,
            err_percent: f.err_percent,
        }
    }
}

/// One unit's flights.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct UnitJson {
    /// The unit's seed: `--seed` plus its index (`ema simulate --unit SEED` draws the same unit).
    pub seed: u64,
    /// Commissioning gave the unit a baseline.
    pub commissioned: bool,
    /// Why commissioning refused the unit; present only then.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refusal: Option<String>,
    /// The fourth healthy flight against the drawing's parameters.
    pub fourth_drawing: FlightJson,
    /// The fourth healthy flight against the commissioned parameters; present only when
    /// commissioned.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fourth_commissioned: Option<FlightJson>,
    /// The cold healthy flight; present only when commissioned.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cold: Option<FlightJson>,
    /// The hot healthy flight; present only when commissioned.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hot: Option<FlightJson>,
    /// One faulty flight per fault mode (empty when not commissioned).
    pub faulty: Vec<FaultyFlightJson>,
    /// Minimum detectable severity per mode of the fourth flight against the commissioned
    /// parameters (friction, backlash, short circuit, eccentricity, gain drift; null: none).
    pub detectable_below: [Option<f32>; 5],
}

impl From<&UnitResult> for UnitJson {
    fn from(r: &UnitResult) -> Self {
        UnitJson {
            seed: r.seed,
            commissioned: r.commissioned.is_ok(),
            refusal: r.commissioned.as_ref().err().cloned(),
            fourth_drawing: FlightJson::new(FOURTH_C, r.fourth_nominal),
            fourth_commissioned: r.fourth_commissioned.map(|s| FlightJson::new(FOURTH_C, s)),
            cold: r.cold.map(|s| FlightJson::new(COLD_C, s)),
            hot: r.hot.map(|s| FlightJson::new(HOT_C, s)),
            faulty: r.faulty.iter().map(FaultyFlightJson::from).collect(),
            detectable_below: r.detectable,
        }
    }
}

/// The fourth healthy flights against one set of parameters: how many read what.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct AgainstJson {
    /// `drawing` (the drawing's parameters) or `commissioned` (each unit's own).
    pub against: &'static str,
    /// Flights identified (the commissioned units only, against their own parameters).
    pub flights: usize,
    /// False alarms: `DEGRADED` or `FAILING`.
    pub alarms: usize,
    /// `INCONCLUSIVE`.
    pub inconclusive: usize,
    /// `HEALTHY`.
    pub healthy: usize,
}

impl AgainstJson {
    /// The counts of `statuses` (a `None` is a flight not flown).
    fn new(against: &'static str, statuses: impl Iterator<Item = Option<Status>> + Clone) -> Self {
        let count = |f: fn(Status) -> bool| statuses.clone().flatten().filter(|&s| f(s)).count();
        AgainstJson {
            against,
            flights: count(|_| true),
            alarms: count(|s| matches!(s, Status::Degraded | Status::Failing)),
            inconclusive: count(|s| matches!(s, Status::Inconclusive(_))),
            healthy: count(|s| s == Status::Healthy),
        }
    }
}

/// The faulty flights of one fault mode over the fleet.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct ModeJson {
    /// The fault mode.
    pub mode: &'static str,
    /// Its faulty flights (one per commissioned unit).
    pub flights: usize,
    /// Flights diagnosed: `DEGRADED` or `FAILING`.
    pub diagnosed: usize,
    /// Mean Err% of its flights (null: no flight).
    pub mean_err_percent: Option<f32>,
    /// Largest Err% of its flights (null: no flight).
    pub max_err_percent: Option<f32>,
}

/// Minimum detectable severity of a healthy flight, for one fault mode.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct DetectableJson {
    /// The fault mode.
    pub mode: &'static str,
    /// The drawing's unit on its own healthy flight (null: none).
    pub drawing: Option<f32>,
    /// The median over the commissioned units' fourth flights, the upper one of an even count
    /// (null: none).
    pub commissioned_median: Option<f32>,
}

/// `ema fleet --json`: the tables' figures, then every unit.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct FleetJson {
    /// `--seed`, the first unit's seed.
    pub seed: u64,
    /// Severity of each faulty flight's fault.
    pub severity: f32,
    /// Temperatures of the three commissioning flights (°C).
    pub commissioning_temperatures_c: [f32; 3],
    /// Temperatures the faulty flights take in turn (°C).
    pub faulty_temperatures_c: [f32; 3],
    /// Units commissioning gave a baseline.
    pub commissioned: usize,
    /// The fourth healthy flights, against the drawing's parameters, then against the
    /// commissioned ones.
    pub fourth_flight: [AgainstJson; 2],
    /// Commissioned units `HEALTHY` on their cold flight.
    pub cold_healthy: usize,
    /// Commissioned units `HEALTHY` on their hot flight.
    pub hot_healthy: usize,
    /// The faulty flights per fault mode.
    pub fault_modes: Vec<ModeJson>,
    /// Faulty flights over all modes.
    pub faulty_flights: usize,
    /// Mean Err% over all faulty flights (null: none).
    pub mean_err_percent: Option<f32>,
    /// Minimum detectable severities per fault mode.
    pub detectable_below: Vec<DetectableJson>,
    /// Every unit, in seed order.
    pub units: Vec<UnitJson>,
}

/// The mean of `values` (null when empty), summed in order.
fn mean(values: &[f32]) -> Option<f32> {
    (!values.is_empty()).then(|| values.iter().sum::<f32>() / values.len() as f32)
}

impl FleetJson {
    /// The document of `results` (in seed order, the first unit's seed `seed`), the drawing's
    /// unit's minimum detectable severities `drawing_detectable`.
    pub fn new(seed: u64, results: &[UnitResult], drawing_detectable: &[Option<f32>; 5]) -> Self {
        let healthy =
            |f: fn(&UnitResult) -> Option<Status>| results.iter().filter(|r| f(r) == Some(Status::Healthy)).count();
        let mut all = Vec::new();
        let fault_modes = FaultMode::ALL
            .iter()
            .map(|&mode| {
                let flights: Vec<&FaultyFlight> =
                    results.iter().flat_map(|r| r.faulty.iter()).filter(|f| f.mode == mode).collect();
                let errs: Vec<f32> = flights.iter().map(|f| f.err_percent).collect();
                all.extend(errs.iter().copied());
                ModeJson {
                    mode: mode.name(),
                    flights: flights.len(),
                    diagnosed: flights
                        .iter()
                        .filter(|f| matches!(f.status, Status::Degraded | Status::Failing))
                        .count(),
                    mean_err_percent: mean(&errs),
                    max_err_percent: (!errs.is_empty()).then(|| errs.iter().copied().fold(0.0f32, f32::max)),
                }
            })
            .collect();
        let detectable_below = FaultMode::ALL
            .iter()
            .enumerate()
            .map(|(m, mode)| {
                let mut v: Vec<f32> = results.iter().filter_map(|r| r.detectable[m]).collect();
                v.sort_by(f32::total_cmp);
                DetectableJson {
                    mode: mode.name(),
                    drawing: drawing_detectable[m],
                    commissioned_median: v.get(v.len() / 2).copied(),
                }
            })
            .collect();
        FleetJson {
            seed,
            severity: SEVERITY,
            commissioning_temperatures_c: COMMISSIONING_C,
            faulty_temperatures_c: FAULTY_C,
            commissioned: results.iter().filter(|r| r.commissioned.is_ok()).count(),
            fourth_flight: [
                AgainstJson::new("drawing", results.iter().map(|r| Some(r.fourth_nominal))),
                AgainstJson::new("commissioned", results.iter().map(|r| r.fourth_commissioned)),
            ],
            cold_healthy: healthy(|r| r.cold),
            hot_healthy: healthy(|r| r.hot),
            fault_modes,
            faulty_flights: all.len(),
            mean_err_percent: mean(&all),
            detectable_below,
            units: results.iter().map(UnitJson::from).collect(),
        }
    }
}
