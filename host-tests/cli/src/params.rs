//! `ema params` and the `--params FILE` flag: the actuator's parameters as a file.
//!
//! ```text
//! ema params > my.toml          # the nominal set as a commented TOML template
//! ema identify --params my.toml FILE.csv
//! ema params --tolerances > tol.toml   # the unit-to-unit tolerance table (`ema simulate --unit`)
//! ```
//!
//! The file formats and their checks are [`crate::params_file`]'s and
//! [`crate::tolerances_file`]'s.

use std::path::{Path, PathBuf};

use clap::Args;
use ema_monitor::EmaParams;

use crate::error::CliError;
use crate::input::read_text;
use crate::params_file::{parse_params, template};
use crate::tolerances_file;

/// Largest parameter file read (the template is about 4 kB).
pub const MAX_PARAMS_BYTES: usize = 64 * 1024;

/// The `--params FILE` flag, flattened into every command that models the actuator.
#[derive(Args, Debug, Clone, Default)]
pub struct ParamsArgs {
    /// Actuator parameter file (TOML; `ema params` prints the template). Without it: the nominal actuator.
    #[arg(long = "params", value_name = "FILE.toml")]
    pub params: Option<PathBuf>,
}

impl ParamsArgs {
    /// The parameter set: the file's, or [`EmaParams::NOMINAL`] without `--params`.
    pub fn load(&self) -> Result<EmaParams, CliError> {
        match &self.params {
            Some(path) => read_params(path),
            None => Ok(EmaParams::NOMINAL),
        }
    }

    /// How the parameters are named in output metadata: the file as given, or `nominal`.
    pub fn source(&self) -> String {
        self.params.as_ref().map_or_else(|| "nominal".to_owned(), |p| p.display().to_string())
    }
}

/// Reads and checks a parameter file; errors name the file, line and key.
pub fn read_params(path: &Path) -> Result<EmaParams, CliError> {
    let file =
        std::fs::File::open(path).map_err(|e| CliError::input(path, format!("cannot read the parameter file: {e}")))?;
    let text = read_text(file, MAX_PARAMS_BYTES).map_err(|e| e.at(path))?;
    parse_params(&text).map_err(|e| CliError::input_line(path, e.line, e.key.as_deref(), e.message))
}

/// Arguments of `ema params`.
#[derive(Args, Debug, Clone, Default)]
pub struct ParamsCommandArgs {
    /// Print the unit-to-unit tolerance table instead: the typical relative 1-sigma of each
    /// parameter that varies from unit to unit (edit it, pass it with
    /// `ema simulate --unit SEED --tolerances FILE`).
    #[arg(long)]
    pub tolerances: bool,
}

/// Runs `ema params`: the nominal set, or under `--tolerances` the typical tolerance table, as a
/// commented TOML template (printed by `main`).
pub fn run(args: &ParamsCommandArgs) -> Result<String, CliError> {
    let text = if args.tolerances {
        tolerances_file::template(&ema_monitor::Tolerances::TYPICAL)
    } else {
        template(&EmaParams::NOMINAL)
    };
    Ok(text.trim_end().to_owned())
}

/// One line of `name=value` for the recording's metadata: every field that differs from nominal
/// (`nominal` when none does).
pub fn describe(params: &EmaParams) -> String {
    let changed: Vec<String> = ema_monitor::params::FIELDS
        .iter()
        .filter(|f| f.get(params).to_bits() != f.get(&EmaParams::NOMINAL).to_bits())
        .map(|f| format!("{}={:?}", f.name, f.get(params)))
        .collect();
    if changed.is_empty() {
        "nominal".to_owned()
    } else {
        changed.join(",")
    }
}
