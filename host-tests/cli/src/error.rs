//! The command line's error type: one line, printed by `main` after `error: `, exit status 2.

use std::fmt;
use std::path::PathBuf;

use crate::profile_file::ProfileFileError;
use crate::recording::error::RecordingError;

/// Exit status of every failed command (bad input or failed I/O).
pub const EXIT_FAILURE: u8 = 2;

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
    /// A profile file could not be used (names the file and line).
    Profile(ProfileFileError),
    /// A recording could not be read or written (names the file, line and field; boxed, so that
    /// every command's `Result` stays small).
    Recording(Box<RecordingError>),
    /// An output file exists and the command was not given `--force` (checked before any work).
    Exists {
        /// The file.
        path: PathBuf,
    },
    /// A file could not be created or written.
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// The simulator refused its configuration.
    Simulation(String),
    /// An input file is unusable for the monitor (names the file and what is wrong).
    Input {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the line and field where there is one.
        message: String,
    },
}

impl CliError {
    /// A flag error.
    pub fn flag(flag: &'static str, message: impl Into<String>) -> Self {
        CliError::Flag { flag, message: message.into() }
    }

    /// An input error: the file `path` is unusable for the monitor, for the reason `message`.
    pub fn input(path: &std::path::Path, message: impl Into<String>) -> Self {
        CliError::Input { path: path.to_path_buf(), message: message.into() }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::Flag { flag, message } => write!(f, "{flag}: {message}"),
            CliError::Profile(e) => write!(f, "{e}"),
            CliError::Recording(e) => write!(f, "{e}"),
            CliError::Exists { path } => {
                write!(f, "'{}' exists; pass --force to overwrite it", path.display())
            }
            CliError::Io { path, source } => write!(f, "cannot write '{}': {source}", path.display()),
            CliError::Simulation(m) => write!(f, "simulation refused: {m}"),
            CliError::Input { path, message } => write!(f, "{}: {message}", path.display()),
        }
    }
}

impl std::error::Error for CliError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            CliError::Io { source, .. } => Some(source),
            CliError::Profile(e) => Some(e),
            CliError::Recording(e) => Some(e.as_ref()),
            _ => None,
        }
    }
}

impl From<ProfileFileError> for CliError {
    fn from(e: ProfileFileError) -> Self {
        CliError::Profile(e)
    }
}

impl From<RecordingError> for CliError {
    fn from(e: RecordingError) -> Self {
        CliError::Recording(Box::new(e))
    }
}
