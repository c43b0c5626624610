//! The document of `ema history --json` and `history.json`: the flights, the modes' trends and
//! RUL, and the degradation campaign's scores.

use serde::Serialize;

use super::flight::Start;

/// One flight of the JSON document.
#[derive(Clone, Debug, Serialize)]
pub struct FlightJson {
    /// Flight number (1 for the first).
    pub flight: u32,
    /// The recording (absent under `--simulate`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// The recording's mean temperature (°C), at which the model took the actuator's parameters
    /// (absent without a temperature column).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub temperature_c: Option<f64>,
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
    /// [`RUL_CONFIDENCE`](ema_monitor::prognosis::RUL_CONFIDENCE).
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

impl FlightJson {
    /// `true` when the flight's status is a diagnosis (`HEALTHY`, `DEGRADED` or `FAILING`).
    pub fn status_is_diagnosis(&self) -> bool {
        matches!(self.status, "HEALTHY" | "DEGRADED" | "FAILING")
    }
}
