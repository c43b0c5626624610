//! The metadata of a recording `ema simulate` writes, in a JSON file beside it: `F.csv` →
//! `F.json` ([`sidecar_path`]).
//!
//! The CSV stays plain (a header and rows: pandas, polars and a spreadsheet load it with default
//! options); what made it — fault vector, unmodelled effects, profile, actuator parameters, the
//! unit drawn from its tolerances and the temperature (when given), the current sensors' chain,
//! the pre-trigger (when given), noise and seed, sample rate — is in [`Sidecar`], with [`SCHEMA_VERSION`] and the tool's version. No command needs it
//! to identify a recording: it tells the user (and the tests) what the file holds.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::CliError;
use crate::input;

/// Version of the sidecar's schema: raised when a field changes meaning or is removed. Version 2:
/// `params` are the actuator's parameters at 20 °C (the reference model ran them at
/// `temperature_c` when that is given), and the optional `unit` and `temperature_c`.
pub const SCHEMA_VERSION: u32 = 2;

/// Largest sidecar file read, in bytes.
pub const MAX_SIDECAR_BYTES: usize = 64 * 1024;

/// What made a recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sidecar {
    /// [`SCHEMA_VERSION`] of the writer.
    pub schema_version: u32,
    /// The `ema` version that wrote it.
    pub tool_version: String,
    /// What wrote it (`ema simulate: reference model`).
    pub generator: String,
    /// The CSV it describes (file name, in the same directory).
    pub recording: String,
    /// The CSV's columns.
    pub columns: Vec<String>,
    /// Sample rate, in Hz.
    pub sample_rate_hz: u32,
    /// Data rows (the pre-trigger's included).
    pub rows: usize,
    /// Duration of the manoeuvre, in seconds.
    pub duration_s: f64,
    /// The fault vector k1..k8.
    pub faults: Vec<f32>,
    /// Unmodelled effects of the reference model and their severities (empty: none).
    pub effects: BTreeMap<String, f64>,
    /// The command profile (`standard` or the profile file as given).
    pub profile: String,
    /// The actuator's parameter file (`--params`), or `nominal`.
    pub params_file: String,
    /// The actuator's parameters at 20 °C, as a parameter file gives them (the unit's, under
    /// `unit`): every `EmaParams` field (the unit is in its name) and its value. The reference
    /// model simulated them at `temperature_c` when that is given
    /// ([`ema_monitor::EmaParams::at_temperature`]).
    pub params: BTreeMap<String, f32>,
    /// Sensor noise on.
    pub noise: bool,
    /// Seed of the noise generator.
    pub seed: u64,
    /// The unit drawn from the tolerance table (`--unit`); absent without one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<SidecarUnit>,
    /// The actuator's temperature during the manoeuvre (`--temperature`, °C; also the CSV's
    /// `temperature_C` column); absent without one (20 °C, no column).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_c: Option<f64>,
    /// The phase-current sensor chain (`--sensors`); absent in files written before it was
    /// recorded (the ideal chain).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensors: Option<SidecarSensors>,
    /// Seconds at rest before the manoeuvre (`--pre-trigger-ms`): the manoeuvre starts at this time
    /// in the file; absent without a pre-trigger.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pre_trigger_s: Option<f64>,
}

/// The current sensors' chain of a recording ([`ema_reference::SensorChain`], docs/sensors.md):
/// where it comes from and its values, per-phase ones as `[a, b, c]` in a sensor file's units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SidecarSensors {
    /// The preset's name (`ideal`, `nucleo-f446re`, …) or the sensor file as given.
    pub source: String,
    /// ADC resolution, bits.
    pub adc_bits: u32,
    /// The ADC spans `±full_scale_a`, A.
    pub full_scale_a: f64,
    /// Zero errors, A.
    pub offset_a: [f64; 3],
    /// Gain errors (relative).
    pub gain_error: [f64; 3],
    /// First-order bandwidths, Hz.
    pub bandwidth_hz: [f64; 3],
    /// Conversion instants after the frame instant, µs.
    pub skew_us: [f64; 3],
}

impl SidecarSensors {
    /// The record of `chain`, from `source`.
    pub fn of(chain: &ema_reference::SensorChain, source: &str) -> Self {
        let p = &chain.phases;
        Self {
            source: source.to_owned(),
            adc_bits: chain.adc.bits,
            full_scale_a: chain.adc.full_scale_a,
            offset_a: p.map(|s| s.offset_a),
            gain_error: p.map(|s| s.gain_error),
            bandwidth_hz: p.map(|s| s.bandwidth_hz),
            skew_us: p.map(|s| s.skew_s * 1e6),
        }
    }
}

/// The unit of a recording (`ema simulate --unit SEED`, [`crate::unit_draw`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SidecarUnit {
    /// The seed of the unit's draw.
    pub seed: u64,
    /// Draws taken: the last one is the unit (a draw the parameter check refuses is redrawn).
    pub draws: u32,
    /// The tolerance table (`--tolerances FILE` as given), or `typical`.
    pub tolerances_file: String,
    /// Each parameter that varies from unit to unit, in the core's order
    /// ([`ema_monitor::unit::UNIT_PARAMS`]).
    pub parameters: Vec<SidecarUnitParameter>,
}

/// One unit parameter of [`SidecarUnit`]: `value = base·(1 + relative_sigma·z)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SidecarUnitParameter {
    /// The parameter's name (a parameter file's key; the unit is in it).
    pub name: String,
    /// Its relative 1σ in the tolerance table.
    pub relative_sigma: f32,
    /// The unit's deviation, in standard deviations.
    pub z: f32,
    /// Its value in the base set (`--params`, or nominal).
    pub base: f32,
    /// The unit's value (also under `params`).
    pub value: f32,
}

/// The sidecar's path for a recording: the same name with the extension `.json`.
pub fn sidecar_path(recording: &Path) -> PathBuf {
    recording.with_extension("json")
}

impl Sidecar {
    /// As JSON text (pretty, one field a line, a final newline).
    pub fn to_json(&self) -> String {
        let mut text = serde_json::to_string_pretty(self).expect("a sidecar serializes");
        text.push('\n');
        text
    }

    /// The sidecar of `recording` when there is one ([`sidecar_path`]); `Ok(None)` without it.
    pub fn for_recording(recording: &Path) -> Result<Option<Self>, CliError> {
        let path = sidecar_path(recording);
        let file = match File::open(&path) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(CliError::input(&path, format!("cannot read: {e}"))),
        };
        let text = input::read_text(file, MAX_SIDECAR_BYTES).map_err(|e| e.at(&path))?;
        let sidecar: Sidecar = serde_json::from_str(&text).map_err(|e| {
            // serde_json's message ends with " at line L column C": the line goes to the place
            let message = e.to_string();
            let message =
                message.strip_suffix(&format!(" at line {} column {}", e.line(), e.column())).unwrap_or(&message);
            CliError::input_line(&path, e.line(), None, format!("not a recording sidecar: {message}"))
        })?;
        if sidecar.schema_version > SCHEMA_VERSION {
            return Err(CliError::input(
                &path,
                format!(
                    "schema_version {} is newer than this ema's {SCHEMA_VERSION}; update ema",
                    sidecar.schema_version
                ),
            ));
        }
        Ok(Some(sidecar))
    }
}
