//! Model configuration files (`--model-config`, `effect ID SEVERITY` lines): the monitor model's
//! effect terms, read by the core's parser, the same file and parser as the firmware build's
//! `EMA_MODEL_CONFIG`, so a host run and a firmware run of one configuration compare.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use ema_monitor::effects::{parse_model_config, ModelEffects};

use crate::error::CliError;
use crate::input;

/// Largest model configuration file, in bytes: ten effect lines and their comments fit many
/// times over.
pub const MAX_MODEL_CONFIG_BYTES: usize = 64 * 1024;

/// Reads a model configuration file with the core's parser (the firmware build's `EMA_MODEL_CONFIG`);
/// errors name the file, line and field.
pub fn read_model_config(path: &Path) -> Result<ModelEffects, CliError> {
    let file = File::open(path).map_err(|e| CliError::input(path, format!("cannot read: {e}")))?;
    read_model_config_from(file, path)
}

/// [`read_model_config`] from any reader: at most [`MAX_MODEL_CONFIG_BYTES`] of UTF-8 text, then
/// [`parse_model_config`]; `path` only names the source in errors.
pub fn read_model_config_from(reader: impl Read, path: &Path) -> Result<ModelEffects, CliError> {
    let text = input::read_text(reader, MAX_MODEL_CONFIG_BYTES).map_err(|e| e.at(path))?;
    parse_model_config(&text).map_err(|e| {
        // the core's message opens with "line N, field F: ": the place says it
        let shown = e.to_string();
        let message = shown.strip_prefix(&format!("line {}, field {}: ", e.line, e.field)).unwrap_or(&shown);
        CliError::input_line(path, e.line, Some(e.field), message)
    })
}

/// `none` or `dead_time 0.48, viscous 0.3` (the firmware logs the same, one effect per line).
pub fn effects_label(effects: &ModelEffects) -> String {
    let on: Vec<String> = effects.active().map(|(e, s)| format!("{} {s}", e.id())).collect();
    if on.is_empty() {
        "none".to_owned()
    } else {
        on.join(", ")
    }
}
