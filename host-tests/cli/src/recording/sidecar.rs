//! The metadata of a recording `ema simulate` writes, in a JSON file beside it: `F.csv` →
//! `F.json` ([`sidecar_path`]).
//!
//! The CSV stays plain (a header and rows: pandas, polars and a spreadsheet load it with default
//! options); what made it — fault vector, unmodelled effects, profile, actuator parameters, noise
//! and seed, sample rate — is in [`Sidecar`], with [`SCHEMA_VERSION`] and the tool's version. No command needs it
//! to identify a recording: it tells the user (and the tests) what the file holds.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::CliError;
use crate::input;

/// Version of the sidecar's schema: raised when a field changes meaning or is removed.
pub const SCHEMA_VERSION: u32 = 1;

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
    /// Data rows.
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
    /// The actuator's parameters the reference model simulated: every `EmaParams` field (the unit
    /// is in its name) and its value.
    pub params: BTreeMap<String, f32>,
    /// Sensor noise on.
    pub noise: bool,
    /// Seed of the noise generator.
    pub seed: u64,
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
            Err(e) => return Err(CliError::Input { path, message: format!("cannot read: {e}") }),
        };
        let text = input::read_text(file, MAX_SIDECAR_BYTES)
            .map_err(|e| CliError::Input { path: path.clone(), message: e.to_string() })?;
        let sidecar: Sidecar = serde_json::from_str(&text)
            .map_err(|e| CliError::Input { path: path.clone(), message: format!("not a recording sidecar: {e}") })?;
        if sidecar.schema_version > SCHEMA_VERSION {
            return Err(CliError::Input {
                path,
                message: format!(
                    "schema_version {} is newer than this ema's {SCHEMA_VERSION}; update ema",
                    sidecar.schema_version
                ),
            });
        }
        Ok(Some(sidecar))
    }
}
