//! # ema-params-file: actuator parameter files of ema-monitor
//!
//! The commented TOML template of a parameter set and its reader, shared by the `ema` command
//! line (`--params`, `ema params`; re-exported there as `ema_cli::params_file`) and the firmware's
//! build script (`EMA_PARAMS`), so that both accept the same files with the same messages.
//!
//! A parameter file is a flat TOML table whose keys are the fields of [`EmaParams`] (their names
//! carry the unit: `phase_resistance_ohm`), each a number. A key left out keeps its nominal value;
//! an unknown key (a misspelt one) is refused rather than ignored, so a typo never falls back to
//! the nominal value silently. The values then go through [`EmaParams::check`]: the ranges of
//! [`FIELDS`] and the relations between fields.
//!
//! It depends only on `std`, the `toml` crate (a build dependency of the firmware, which never
//! reaches the MCU binary) and the parameter table of `ema-model-config`.
#![deny(missing_docs)]
#![forbid(unsafe_code)]

use std::collections::BTreeMap;
use std::fmt::Write as _;

use ema_model_config::params::{EmaParams, ParamField, FIELDS};

/// Why a parameter file (or a tolerance table, the command line's `tolerances_file.rs`) was
/// refused: the 1-based line (0 when the error has no place in the file, e.g. a relation involving
/// only nominal values) and what to change.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParamsFileError {
    /// Line of the offending key or value (0: none).
    pub line: usize,
    /// The key, when the error is about one.
    pub key: Option<String>,
    /// What is wrong and what to change.
    pub message: String,
}

impl std::fmt::Display for ParamsFileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line > 0 {
            write!(f, "line {}: ", self.line)?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for ParamsFileError {}

/// The 1-based line of byte offset `at` in `text`.
pub fn line_of(text: &str, at: usize) -> usize {
    text.get(..at).map_or(0, |head| head.matches('\n').count()) + 1
}

/// Edit distance of two keys (for "did you mean").
pub fn distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != *cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// The field nearest to an unknown key, if it is a plausible misspelling.
fn nearest(key: &str) -> Option<&'static str> {
    FIELDS.iter().map(|f| (distance(key, f.name), f.name)).filter(|(d, _)| *d <= 4).min().map(|(_, name)| name)
}

/// One `key = value` entry of a flat TOML table ([`flat_entries`]).
pub struct FlatEntry {
    /// The key.
    pub name: String,
    /// The line of the key (1-based).
    pub line: usize,
    /// The line of the value.
    pub value_line: usize,
    /// The value as TOML.
    pub value: toml::Value,
}

impl FlatEntry {
    /// The value as a number (a float or an integer), or an error naming the value's line and
    /// the key, with `example` as what to write instead (`hint` before it, e.g. `"e.g. "`).
    pub fn number(&self, example: &str, hint: &str) -> Result<f32, ParamsFileError> {
        match &self.value {
            toml::Value::Float(x) => Ok(*x as f32),
            toml::Value::Integer(i) => Ok(*i as f32),
            other => {
                let name = &self.name;
                Err(ParamsFileError {
                    line: self.value_line,
                    key: Some(name.clone()),
                    message: format!("{name} = {other} is not a number (write {hint}{name} = {example})"),
                })
            }
        }
    }
}

/// The entries of a flat TOML table (a parameter or tolerance file), in key order, each with its
/// lines; text that is not TOML is refused with its line.
pub fn flat_entries(text: &str) -> Result<Vec<FlatEntry>, ParamsFileError> {
    type Table = BTreeMap<toml::Spanned<String>, toml::Spanned<toml::Value>>;
    let table: Table = toml::from_str(text).map_err(|e| ParamsFileError {
        line: e.span().map_or(0, |s| line_of(text, s.start)),
        key: None,
        message: format!("not valid TOML: {}", e.message().trim()),
    })?;
    Ok(table
        .into_iter()
        .map(|(key, value)| FlatEntry {
            line: line_of(text, key.span().start),
            value_line: line_of(text, value.span().start),
            name: key.into_inner(),
            value: value.into_inner(),
        })
        .collect())
}

/// Reads a parameter file's text: every key a field of [`EmaParams`] holding a number, missing
/// keys nominal, the whole set checked by [`EmaParams::check`].
pub fn parse_params(text: &str) -> Result<EmaParams, ParamsFileError> {
    let mut params = EmaParams::NOMINAL;
    let mut lines: BTreeMap<&'static str, usize> = BTreeMap::new();
    for entry in flat_entries(text)? {
        let (name, line) = (entry.name.as_str(), entry.line);
        let Some(field) = ParamField::find(name) else {
            let hint = match nearest(name) {
                Some(near) => format!(" (did you mean {near}?)"),
                None => " (`ema params` lists the keys)".to_owned(),
            };
            return Err(ParamsFileError {
                line,
                key: Some(name.to_owned()),
                message: format!("unknown key '{name}'{hint}"),
            });
        };
        let number = entry.number(&toml_number(field.get(&EmaParams::NOMINAL), field.integer), "e.g. ")?;
        field.set(&mut params, number);
        lines.insert(field.name, line);
    }
    params.check().map_err(|e| {
        let field = e.field();
        let unit = ParamField::find(field).map_or("", |f| f.unit);
        let (line, place) = match lines.get(field) {
            Some(&line) => (line, String::new()),
            None => (0, " (not in the file: nominal value)".to_owned()),
        };
        ParamsFileError { line, key: Some(field.to_owned()), message: format!("{e}{place}; unit: {unit}") }
    })?;
    Ok(params)
}

/// A number as TOML that reads back to exactly `x` (`f32`'s shortest round-trip form; whole
/// fields without a fractional part).
pub fn toml_number(x: f32, integer: bool) -> String {
    if integer {
        format!("{}", x as i64)
    } else {
        format!("{x:?}")
    }
}

/// The commented TOML template of `params`: a header, then per field a comment line (meaning,
/// unit, range) and `name = value`. [`parse_params`] reads it back to exactly `params`.
pub fn template(params: &EmaParams) -> String {
    let mut out = String::new();
    out.push_str(
        "# Actuator parameters for ema-monitor (`ema params` prints the nominal set).\n\
         # Edit the values to describe your actuator; the unit is in each key's name.\n\
         # A key left out keeps the nominal value; an unknown (misspelt) key is refused.\n\
         # Every value must lie in its range, and: dynamic_friction_n_m <= static_friction_n_m,\n\
         # hysteresis_half_band_a < current_limit_a, control_period_s < derivative_filter_s,\n\
         # position_resolution_rad < end_stop_rad, and the electrical (L/R) and mechanical\n\
         # time constants at least 10 control periods.\n\
         # Use: ema simulate|identify|discover|campaign --params FILE;\n\
         #      EMA_PARAMS=FILE cargo run --release (firmware).\n",
    );
    for f in FIELDS.iter() {
        let _ = write!(
            out,
            "\n# {}. Unit: {}. Range: {} to {}{}.\n{} = {}\n",
            f.doc,
            f.unit,
            toml_number(f.min, f.integer),
            toml_number(f.max, f.integer),
            if f.integer { ", a whole number" } else { "" },
            f.name,
            toml_number(f.get(params), f.integer),
        );
    }
    out
}
