//! The command line's error type: one line, printed by `main` after `error: `, with the exit
//! status of its kind ([`CliError::exit_code`], the contract of [`crate::exit`]).
//!
//! Every error about a file opens with the same place ([`Place`]), whatever the file (a recording,
//! a parameter, tolerance, sensor or profile file, a model configuration, a sidecar, a packed
//! trace):
//!
//! ```text
//! 'PATH' line N, field 'NAME' (column C): what is wrong
//! ```
//!
//! the line, field and column where the reader knows them (`'PATH': what is wrong` for the file
//! as a whole). Numbers in messages go through [`num`]: at most six significant digits, so no
//! value prints at full length.
//!
//! This module depends on no other module of the crate but [`crate::exit`] (a leaf): the readers
//! convert their own errors into a [`CliError`] (`impl From<RecordingError> for CliError` lives
//! with `RecordingError`).

use std::fmt;
use std::path::{Path, PathBuf};

use crate::exit::{RUNTIME_FAILURE, USAGE_ERROR};

/// Where in a file an error is: the file, and the line, field and column where one is at fault.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Place {
    /// The file.
    pub path: PathBuf,
    /// 1-based line.
    pub line: Option<usize>,
    /// The field (a column's header, a key).
    pub field: Option<String>,
    /// 1-based column of the field in a table.
    pub column: Option<usize>,
}

impl Place {
    /// The file as a whole.
    pub fn file(path: &Path) -> Self {
        Self { path: path.to_path_buf(), line: None, field: None, column: None }
    }

    /// A line (when known) and a field (when known) of the file.
    pub fn at(path: &Path, line: Option<usize>, field: Option<&str>) -> Self {
        Self { path: path.to_path_buf(), line, field: field.map(str::to_owned), column: None }
    }
}

impl fmt::Display for Place {
    /// `'PATH' line N, field 'NAME' (column C)`, each part only when known.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "'{}'", self.path.display())?;
        if let Some(l) = self.line {
            write!(f, " line {l}")?;
        }
        if let Some(name) = &self.field {
            if self.line.is_some() {
                f.write_str(",")?;
            }
            write!(f, " field '{name}'")?;
            if let Some(c) = self.column {
                write!(f, " (column {c})")?;
            }
        }
        Ok(())
    }
}

/// A number for a message: at most six significant digits, in plain form from 1e-4 to below 1e6
/// (`650`, `0.0125`) and in exponent form beyond (`1e308`, `-2.5e-7`), trailing zeros dropped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f64);

/// [`Num`] of `x` (an `f32` or `f64`).
pub fn num(x: impl Into<f64>) -> Num {
    Num(x.into())
}

/// `digits` without the trailing zeros of its fractional part (and without a bare `.`).
fn trimmed(digits: &str) -> &str {
    if digits.contains('.') {
        digits.trim_end_matches('0').trim_end_matches('.')
    } else {
        digits
    }
}

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        if !x.is_finite() || x == 0.0 {
            // NaN, inf, -inf, 0 (and -0 as 0)
            return write!(f, "{}", if x == 0.0 { 0.0 } else { x });
        }
        let sci = format!("{x:.5e}");
        let (mantissa, exponent) = sci.split_once('e').unwrap_or((&sci, "0"));
        let exponent: i32 = exponent.parse().unwrap_or(0);
        if (-4..6).contains(&exponent) {
            let decimals = usize::try_from(5 - exponent).unwrap_or(0);
            f.write_str(trimmed(&format!("{x:.decimals$}")))
        } else {
            write!(f, "{}e{exponent}", trimmed(mantissa))
        }
    }
}

/// Anything that stops a subcommand.
#[derive(Debug)]
#[non_exhaustive]
pub enum CliError {
    /// A flag's value is wrong: names the flag and what is expected.
    Flag {
        /// The flag, e.g. `--faults`.
        flag: &'static str,
        /// What is wrong with it.
        message: String,
    },
    /// The command line as a whole is wrong (no input, too many or repeated inputs).
    Usage(String),
    /// An output file exists and the command was not given `--force` (checked before any work).
    Exists {
        /// The file.
        path: PathBuf,
    },
    /// An output path cannot be used: its directory is missing or not writable, it is a directory,
    /// or something other than a regular file is there (checked before any work, and again just
    /// before the file is put in place).
    Unwritable {
        /// The path.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A file could not be written (the disk, not the command line, failed).
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// The simulator refused its configuration (the flags' or the parameter file's values).
    Simulation(String),
    /// The work itself failed for a reason that is not the input's (e.g. no worker thread).
    Runtime(String),
    /// An input file is unusable (names the file, and the line and field where there is one).
    Input {
        /// Where.
        place: Box<Place>,
        /// What is wrong.
        message: String,
    },
}

impl CliError {
    /// A flag error.
    pub fn flag(flag: &'static str, message: impl Into<String>) -> Self {
        CliError::Flag { flag, message: message.into() }
    }

    /// A usage error about the command line as a whole.
    pub fn usage(message: impl Into<String>) -> Self {
        CliError::Usage(message.into())
    }

    /// An input error: the file `path` is unusable, for the reason `message`.
    pub fn input(path: &Path, message: impl Into<String>) -> Self {
        Self::input_at(Place::file(path), message)
    }

    /// An input error at `place` (a line, a field).
    pub fn input_at(place: Place, message: impl Into<String>) -> Self {
        CliError::Input { place: Box::new(place), message: message.into() }
    }

    /// An input error at `line` (when known; 0 is none) and `field` (when known) of `path`.
    pub fn input_line(path: &Path, line: usize, field: Option<&str>, message: impl Into<String>) -> Self {
        Self::input_at(Place::at(path, (line > 0).then_some(line), field), message)
    }

    /// The exit status of this error: [`crate::exit::RUNTIME_FAILURE`] (1) when writing failed
    /// or the work could not run, [`crate::exit::USAGE_ERROR`] (2) for every error of the
    /// command line or of an input file.
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Io { .. } | CliError::Runtime(_) => RUNTIME_FAILURE,
            _ => USAGE_ERROR,
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::Flag { flag, message } => write!(f, "{flag}: {message}"),
            CliError::Usage(m) => write!(f, "{m}"),
            CliError::Exists { path } => {
                write!(f, "'{}' exists (a regular file; --force replaces it)", path.display())
            }
            CliError::Unwritable { path, reason } => write!(f, "cannot write '{}': {reason}", path.display()),
            CliError::Io { path, source } => write!(f, "cannot write '{}': {source}", path.display()),
            CliError::Simulation(m) => write!(f, "simulation refused: {m}"),
            CliError::Runtime(m) => write!(f, "{m}"),
            CliError::Input { place, message } => write!(f, "{place}: {message}"),
        }
    }
}

impl std::error::Error for CliError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            CliError::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_print_six_significant_digits_at_most() {
        let cases: [(f64, &str); 14] = [
            (650.0, "650"),
            (0.0125, "0.0125"),
            (1e308, "1e308"),
            (-2.5e-7, "-2.5e-7"),
            (0.1 + 0.2, "0.3"),
            (0.019_999_999_9, "0.02"),
            (123_456.7, "123457"),
            (999_999.9, "1e6"),
            (1e-4, "0.0001"),
            (0.0, "0"),
            (-0.0, "0"),
            (f64::NAN, "NaN"),
            (f64::NEG_INFINITY, "-inf"),
            (f64::from(f32::MAX), "3.40282e38"),
        ];
        for (x, shown) in cases {
            assert_eq!(num(x).to_string(), shown, "{x:?}");
        }
    }

    #[test]
    fn a_place_names_what_is_known() {
        let p = Path::new("dir/r.csv");
        assert_eq!(Place::file(p).to_string(), "'dir/r.csv'");
        assert_eq!(Place::at(p, Some(3), None).to_string(), "'dir/r.csv' line 3");
        assert_eq!(Place::at(p, Some(3), Some("ia_A")).to_string(), "'dir/r.csv' line 3, field 'ia_A'");
        assert_eq!(Place::at(p, None, Some("k")).to_string(), "'dir/r.csv' field 'k'");
        let with_column = Place { column: Some(4), ..Place::at(p, Some(3), Some("ia_A")) };
        assert_eq!(with_column.to_string(), "'dir/r.csv' line 3, field 'ia_A' (column 4)");
        let e = CliError::input_line(p, 0, Some("k"), "bad");
        assert_eq!(e.to_string(), "'dir/r.csv' field 'k': bad");
    }
}
