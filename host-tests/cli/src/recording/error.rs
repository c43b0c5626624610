//! What is wrong with a recording file, and where: the file, line and field, shown as every
//! file error of the command line is ([`Place`]).

use std::fmt;
use std::path::PathBuf;

use crate::error::{num, CliError, Place};

use super::data::{
    HEADER, JITTER_TOLERANCE_S, MAX_COMMENT_LINES, MAX_DURATION_S, MAX_FILE_BYTES, MAX_LINE_BYTES, MAX_RATE_HZ,
    MAX_ROWS, MAX_TEMPERATURE_C, MIN_RATE_HZ, MIN_ROWS, MIN_TEMPERATURE_C, STEP_TOLERANCE,
};

/// What is wrong with a recording file.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum RecordingErrorKind {
    /// The file cannot be opened, read or written.
    Io(String),
    /// No header line.
    Empty,
    /// A column the monitor needs is not in the header.
    MissingColumn(Box<MissingColumn>),
    /// A row has fewer fields than the header.
    FieldCount {
        /// Fields found.
        found: usize,
        /// Fields of the header.
        expected: usize,
    },
    /// A field is not a number.
    NotANumber(String),
    /// A field is NaN or infinite.
    NotFinite(String),
    /// A temperature (°C) outside [`MIN_TEMPERATURE_C`]..=[`MAX_TEMPERATURE_C`].
    Temperature(f64),
    /// Time does not increase.
    TimeNotIncreasing {
        /// Previous row's time.
        previous: f64,
        /// This row's time.
        current: f64,
    },
    /// A time step far from the others (a missing or repeated row).
    TimeNotUniform {
        /// This row's step.
        step: f64,
        /// The median step.
        expected: f64,
    },
    /// A timestamp farther than [`JITTER_TOLERANCE_S`] from the uniform grid.
    Jitter {
        /// Its distance from the grid.
        deviation_s: f64,
        /// The grid's (mean) period.
        period_s: f64,
    },
    /// The mean sample rate is outside [`MIN_RATE_HZ`]..=[`MAX_RATE_HZ`].
    Rate {
        /// The file's mean sample rate.
        rate_hz: f64,
    },
    /// Fewer than [`MIN_ROWS`] data rows.
    TooFewRows(usize),
    /// More than [`MAX_ROWS`] data rows.
    TooManyRows,
    /// More than [`MAX_COMMENT_LINES`] comment lines.
    TooManyComments,
    /// The rows span more than [`MAX_DURATION_S`] (this row's time minus the first row's).
    TooLong {
        /// The span so far.
        span_s: f64,
    },
    /// More than [`MAX_FILE_BYTES`] bytes.
    TooLarge,
    /// A line longer than [`MAX_LINE_BYTES`].
    LineTooLong,
    /// A line that is not UTF-8 text.
    NotText,
    /// The file does not hold the manoeuvre where the profile or `--start` puts it (the message says why).
    Manoeuvre(String),
    /// A flag of [`RecordingArgs`](super::args::RecordingArgs) is malformed (the message names it).
    Flag(String),
}

/// A column the monitor needs that the header lacks (boxed in [`RecordingErrorKind`], which stays small).
#[derive(Clone, Debug, PartialEq)]
pub struct MissingColumn {
    /// The key (`time`, `command`, …).
    pub key: &'static str,
    /// The header looked for.
    pub wanted: String,
    /// The headers found.
    pub found: Vec<String>,
}

/// A recording error with its location.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordingError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line in the file, where one line is at fault.
    pub line: Option<usize>,
    /// The column's header as the file names it, where one field is at fault.
    pub field: Option<String>,
    /// 1-based column of `field` in the file.
    pub column: Option<usize>,
    /// What is wrong.
    pub kind: RecordingErrorKind,
}

impl RecordingError {
    /// An error about the file as a whole.
    pub fn file(path: &std::path::Path, kind: RecordingErrorKind) -> Self {
        Self { path: path.to_owned(), line: None, field: None, column: None, kind }
    }

    /// Where the error is: the file, and the line, field and column where one is at fault.
    pub fn place(&self) -> Place {
        Place { path: self.path.clone(), line: self.line, field: self.field.clone(), column: self.column }
    }
}

impl fmt::Display for RecordingError {
    /// `'PATH' line N, field 'NAME' (column C): what is wrong` ([`Place`]).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.place(), self.kind)
    }
}

impl From<RecordingError> for CliError {
    fn from(e: RecordingError) -> Self {
        CliError::input_at(e.place(), e.kind.to_string())
    }
}

impl fmt::Display for RecordingErrorKind {
    /// What is wrong, without the place.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RecordingErrorKind::Io(m) => write!(f, "{m}"),
            RecordingErrorKind::Empty => write!(f, "empty file, expected a header such as '{}'", HEADER.join(",")),
            RecordingErrorKind::MissingColumn(m) => write!(
                f,
                "no column '{}' for the {} channel; the header has '{}'; name the column with --column {}=HEADER",
                m.wanted,
                m.key,
                m.found.join("', '"),
                m.key
            ),
            RecordingErrorKind::FieldCount { found, expected } => {
                write!(f, "expected {expected} fields (as the header), found {found}")
            }
            RecordingErrorKind::NotANumber(s) => write!(f, "'{s}' is not a number"),
            RecordingErrorKind::NotFinite(s) => write!(f, "'{s}' is not a finite number"),
            RecordingErrorKind::Temperature(t) => write!(
                f,
                "temperature {} °C is outside the {MIN_TEMPERATURE_C} to {MAX_TEMPERATURE_C} °C a recording may hold; \
                 give the actuator's temperature in °C",
                num(*t)
            ),
            RecordingErrorKind::TimeNotIncreasing { previous, current } => {
                write!(f, "time {} s does not increase (previous row {} s)", num(*current), num(*previous))
            }
            RecordingErrorKind::TimeNotUniform { step, expected } => write!(
                f,
                "time step {} s differs from the median step {} s by more than {:.0} % (non-uniform sampling: \
                 a missing or repeated row?); give a uniformly sampled file",
                num(*step),
                num(*expected),
                STEP_TOLERANCE * 100.0
            ),
            RecordingErrorKind::Jitter { deviation_s, period_s } => write!(
                f,
                "the time is {} µs off the uniform grid of mean period {} s; timestamp jitter up to {} µs is \
                 tolerated: give the times of a uniformly sampled clock",
                num(deviation_s * 1e6),
                num(*period_s),
                JITTER_TOLERANCE_S * 1e6
            ),
            RecordingErrorKind::Rate { rate_hz } => write!(
                f,
                "sample rate {} Hz is outside the {} to {} kHz the reader resamples from; {}",
                num(*rate_hz),
                MIN_RATE_HZ / 1e3,
                MAX_RATE_HZ / 1e3,
                if *rate_hz < MIN_RATE_HZ {
                    "record at 5 kHz or more"
                } else {
                    "decimate the file to 100 kHz or less first (e.g. keep every n-th row after a low-pass filter)"
                }
            ),
            RecordingErrorKind::TooFewRows(n) => write!(f, "too few rows: {n} (need at least {MIN_ROWS})"),
            RecordingErrorKind::TooManyRows => {
                write!(f, "more than {MAX_ROWS} rows, the most a recording may hold; cut the file to the manoeuvre")
            }
            RecordingErrorKind::TooManyComments => write!(f, "more than {MAX_COMMENT_LINES} comment lines"),
            RecordingErrorKind::TooLong { span_s } => write!(
                f,
                "the rows span {} s, more than the {MAX_DURATION_S} s a recording may last; cut the file to the manoeuvre",
                num(*span_s)
            ),
            RecordingErrorKind::TooLarge => {
                write!(f, "larger than {MAX_FILE_BYTES} bytes, the most a recording may hold; cut the file to the manoeuvre")
            }
            RecordingErrorKind::LineTooLong => write!(f, "line longer than {MAX_LINE_BYTES} bytes"),
            RecordingErrorKind::NotText => write!(f, "not UTF-8 text"),
            RecordingErrorKind::Manoeuvre(m) | RecordingErrorKind::Flag(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for RecordingError {}
