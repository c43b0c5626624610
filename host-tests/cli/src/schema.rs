//! The envelope of every JSON output of `ema`: a serde-derived body inside [`Document`], which
//! adds `schema_version` ([`SCHEMA_VERSION`]), `tool_version` (the crate's version) and, where
//! the command reads one, `input_file`. Every key carries its unit (`_s`, `_A`, `_A2`, `_rad`,
//! `_percent`) and is the same as the matching CSV column; `docs/output-schema.md` lists every
//! key of every output, and the `output_schema` test checks the outputs against it.

use std::path::Path;

use serde::Serialize;

/// Version of the JSON and CSV output schema. It changes when a key is renamed or removed or
/// changes meaning; a new key does not change it.
pub const SCHEMA_VERSION: u32 = 1;

/// The version of `ema` that wrote an output (`CARGO_PKG_VERSION`).
pub const TOOL_VERSION: &str = env!("CARGO_PKG_VERSION");

/// One JSON output: the envelope keys, then the body's keys at the same level.
#[derive(Serialize, Debug, Clone)]
pub struct Document<T> {
    /// [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// [`TOOL_VERSION`].
    pub tool_version: &'static str,
    /// The file the command read (a recording, a firmware trace), as given on the command line;
    /// absent when the command reads none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input_file: Option<String>,
    /// The command's own keys.
    #[serde(flatten)]
    pub body: T,
}

impl<T: Serialize> Document<T> {
    /// Wraps `body`, read from `input_file` if any.
    pub fn new(input_file: Option<&Path>, body: T) -> Self {
        Document {
            schema_version: SCHEMA_VERSION,
            tool_version: TOOL_VERSION,
            input_file: input_file.map(|p| p.display().to_string()),
            body,
        }
    }

    /// The document as one line of JSON. Non-finite numbers become `null` (JSON has no
    /// infinities). Serialization cannot fail for these types (plain structs, string-keyed maps,
    /// no fallible `Serialize` impl); the fallback keeps the output valid JSON regardless.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_else(|e| {
            format!("{{\"schema_version\":{SCHEMA_VERSION},\"error\":{}}}", serde_json::Value::from(e.to_string()))
        })
    }
}
