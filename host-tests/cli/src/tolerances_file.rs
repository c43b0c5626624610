//! Tolerance tables: how much each unit of an actuator differs from its parameter set, as a file.
//!
//! A tolerance table is a flat TOML table whose keys are the unit parameters
//! ([`ema_monitor::unit::unit_name`]: `phase_resistance_ohm`, …), each a relative 1σ (unit-less:
//! `0.03` is 3 % of the parameter's value). A key left out keeps [`Tolerances::TYPICAL`]'s value;
//! an unknown key (a misspelt one, or a parameter that does not vary from unit to unit) is refused
//! rather than ignored, and so is a value that is not a number or that [`Tolerances::check`]
//! refuses. Every error names the line and the key ([`ParamsFileError`], the parameter files'
//! error).
//!
//! ```text
//! ema params --tolerances > tol.toml      # the typical table, commented
//! ema simulate --unit 7 --tolerances tol.toml --out unit7.csv
//! ```

use std::fmt::Write as _;
use std::path::Path;

use ema_monitor::unit::{unit_field, unit_name, Tolerances, MAX_RELATIVE_SIGMA, UNIT_PARAM_COUNT};

use crate::error::CliError;
use crate::input::read_text;
use crate::params_file::{distance, flat_entries, toml_number, ParamsFileError};

/// Largest tolerance file read (the template is about 2 kB).
pub const MAX_TOLERANCES_BYTES: usize = 64 * 1024;

/// The index of the unit parameter `name`.
fn unit_index(name: &str) -> Option<usize> {
    (0..UNIT_PARAM_COUNT).find(|&i| unit_name(i) == name)
}

/// Why `name` is not a key, and the nearest key when it looks like a misspelling of one.
fn unknown_key(name: &str) -> String {
    if ema_monitor::params::ParamField::find(name).is_some() {
        return format!(
            "'{name}' does not vary from unit to unit (a parameter file sets it: --params); the keys are {}",
            (0..UNIT_PARAM_COUNT).map(unit_name).collect::<Vec<_>>().join(", ")
        );
    }
    let near =
        (0..UNIT_PARAM_COUNT).map(|i| (distance(name, unit_name(i)), unit_name(i))).filter(|(d, _)| *d <= 4).min();
    match near {
        Some((_, near)) => format!("unknown key '{name}' (did you mean {near}?)"),
        None => format!("unknown key '{name}' (`ema params --tolerances` lists the keys)"),
    }
}

/// Reads a tolerance table's text: every key a unit parameter holding a number, missing keys
/// typical, every value accepted by [`Tolerances::check`].
pub fn parse_tolerances(text: &str) -> Result<Tolerances, ParamsFileError> {
    let mut tolerances = Tolerances::TYPICAL;
    for entry in flat_entries(text)? {
        let name = entry.name.as_str();
        let Some(i) = unit_index(name) else {
            return Err(ParamsFileError { line: entry.line, key: Some(name.to_owned()), message: unknown_key(name) });
        };
        let example = toml_number(Tolerances::TYPICAL.relative_sigma[i], false);
        let sigma = entry.number(&example, "the relative 1-sigma, e.g. ")?;
        let mut one = Tolerances::TYPICAL;
        one.relative_sigma[i] = sigma;
        one.check().map_err(|e| ParamsFileError {
            line: entry.value_line,
            key: Some(name.to_owned()),
            message: format!("{e} (a relative 1-sigma: 0.03 is 3 %)"),
        })?;
        tolerances.relative_sigma[i] = sigma;
    }
    Ok(tolerances)
}

/// Reads and checks a tolerance file; errors name the file, line and key.
pub fn read_tolerances(path: &Path) -> Result<Tolerances, CliError> {
    let file =
        std::fs::File::open(path).map_err(|e| CliError::input(path, format!("cannot read the tolerance file: {e}")))?;
    let text = read_text(file, MAX_TOLERANCES_BYTES).map_err(|e| e.at(path))?;
    parse_tolerances(&text).map_err(|e| CliError::input_line(path, e.line, e.key.as_deref(), e.message))
}

/// The commented TOML template of `tolerances`: a header (what a value means and how a unit is
/// drawn from it), then per unit parameter a comment line (meaning and the parameter's unit) and
/// `name = sigma`. [`parse_tolerances`] reads it back to exactly `tolerances`.
pub fn template(tolerances: &Tolerances) -> String {
    let mut out = format!(
        "# Unit-to-unit tolerances for ema-monitor (`ema params --tolerances` prints the typical table).\n\
         # Each value is a relative 1-sigma, unit-less: 0.03 means 3 % of the parameter's value.\n\
         # A unit differs from its parameter set (--params FILE, or the nominal set) by z standard\n\
         # deviations per parameter: value = base * (1 + sigma * z), z drawn from N(0, 1)\n\
         # independently for each parameter (ema simulate --unit SEED --tolerances FILE).\n\
         # A key left out keeps its typical value; an unknown (misspelt) key is refused;\n\
         # each value must lie in [0, {MAX_RELATIVE_SIGMA}].\n"
    );
    for (i, sigma) in tolerances.relative_sigma.iter().enumerate() {
        let Some(field) = unit_field(i) else { continue };
        let _ = write!(
            out,
            "\n# {}. Parameter unit: {}. Relative 1-sigma (unit-less), typical {}.\n{} = {}\n",
            field.doc,
            field.unit,
            toml_number(Tolerances::TYPICAL.relative_sigma[i], false),
            field.name,
            toml_number(*sigma, false),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn template_reads_back_and_keys_left_out_are_typical() {
        assert_eq!(parse_tolerances(&template(&Tolerances::TYPICAL)), Ok(Tolerances::TYPICAL));
        let mut wide = Tolerances::TYPICAL;
        wide.relative_sigma[6] = 0.2;
        wide.relative_sigma[0] = 0.0;
        assert_eq!(parse_tolerances(&template(&wide)), Ok(wide));
        assert_eq!(parse_tolerances(""), Ok(Tolerances::TYPICAL));
        let text = "static_friction_n_m = 0.2\nphase_resistance_ohm = 0\n";
        assert_eq!(parse_tolerances(text), Ok(wide));
    }

    #[test]
    fn errors_name_the_line_and_the_key() {
        for (text, line, key, needle) in [
            ("\nphase_resistence_ohm = 0.03\n", 2, "phase_resistence_ohm", "did you mean phase_resistance_ohm"),
            ("gear_ratio = 0.01\n", 1, "gear_ratio", "does not vary from unit to unit"),
            ("zzz = 0.01\n", 1, "zzz", "ema params --tolerances"),
            ("# c\n\nphase_inductance_h = \"5 %\"\n", 3, "phase_inductance_h", "is not a number"),
            ("static_friction_n_m = 0.5\n", 1, "static_friction_n_m", "must lie in [0, 0.3]"),
            ("\n\nstatic_friction_n_m = -0.1\n", 3, "static_friction_n_m", "must lie in [0, 0.3]"),
            ("static_friction_n_m = nan\n", 1, "static_friction_n_m", "must lie in [0, 0.3]"),
        ] {
            let e = parse_tolerances(text).expect_err(text);
            assert_eq!((e.line, e.key.as_deref()), (line, Some(key)), "{text}: {e}");
            let shown = e.to_string();
            assert!(shown.starts_with(&format!("line {line}: ")) && shown.contains(needle), "{shown}");
        }
        let e = parse_tolerances("static_friction_n_m 0.1\n").expect_err("syntax");
        assert!(e.line == 1 && e.message.contains("not valid TOML"), "{e}");
    }
}
