//! Recording files: the CSV `ema simulate` writes and any bench's CSV that `ema identify`,
//! `ema discover` and `ema firmware-trace --from` read.
//!
//! ```text
//! time_s,command_rad,position_rad,ia_A,ib_A,ic_A
//! 0,0,0,0,0,0
//! 0.0001,0,0,-0.009765625,0,0.009765625
//! …
//! ```
//!
//! The path from a file to what the monitor identifies, one concept per module:
//! 1. [`read`]: the CSV itself, on the `csv` crate — any header order and names
//!    (`--column KEY=HEADER`), extra columns ignored, the delimiter detected (comma, semicolon,
//!    tab) or given (`--delimiter`), a UTF-8 BOM, `#` comment lines and blank lines accepted;
//! 2. [`grid`]: the time base — a mean sample rate from 5 to 100 kHz, timestamps within
//!    [`grid::JITTER_TOLERANCE_S`] of the uniform grid;
//! 3. [`align`]: where the manoeuvre starts in the file (least squares of the recorded command
//!    against the profile, or `--start SECONDS`), and the command check;
//! 4. [`resample`]: the channels on the monitor's 10 kHz grid from that start, band-limited;
//! 5. [`args`]: the flags of all this ([`RecordingArgs`]) and the pipeline ([`RecordingArgs::load`]).
//!
//! [`mod@write`] writes a plain CSV (header and rows, numbers in Rust's shortest round-trip form:
//! a read gives back exactly the values written) and [`sidecar`] the metadata beside it
//! (`F.csv` → `F.json`).
//!
//! Every size is bounded, so that no file drives an allocation: a file holds at most
//! [`MAX_FILE_BYTES`], a line at most [`MAX_LINE_BYTES`], at most [`MAX_COMMENT_LINES`] comment
//! lines and [`MAX_ROWS`] rows spanning at most [`MAX_DURATION_S`]; beyond any of them the file
//! is refused, the limit stated, at the line that crosses it.

use std::fmt;
use std::path::PathBuf;

pub mod align;
pub mod args;
pub mod grid;
pub mod read;
pub mod resample;
pub mod sidecar;
pub mod write;

pub use args::{LoadSummary, Loaded, RecordingArgs};
pub use read::{parse_recording, parse_recording_with, read_recording, Columns, ReadOptions};
pub use write::{write_csv, write_recording};

/// Default column names, in the order of [`KEYS`].
pub const HEADER: [&str; 6] = ["time_s", "command_rad", "position_rad", "ia_A", "ib_A", "ic_A"];
/// The keys of `--column KEY=HEADER`, in the order of [`HEADER`].
pub const KEYS: [&str; 6] = ["time", "command", "position", "ia", "ib", "ic"];
/// Fewest data rows a recording may have (a time step needs two).
pub const MIN_ROWS: usize = 2;
/// Longest line, in bytes (a row in shortest round-trip form takes at most about 150).
pub const MAX_LINE_BYTES: usize = 4096;
/// Most comment lines.
pub const MAX_COMMENT_LINES: usize = 1000;
/// Largest file, in bytes: [`MAX_ROWS`] rows of six numbers in a bench's usual precision.
pub const MAX_FILE_BYTES: usize = 128 * 1024 * 1024;
/// Longest time span of a recording, first to last row: the longest profile the reference model
/// simulates ([`ema_reference::MAX_DURATION_S`]).
pub const MAX_DURATION_S: f64 = ema_reference::MAX_DURATION_S;
/// Most data rows: 10 s at the highest accepted rate (100 kHz), [`MAX_DURATION_S`] at 10 kHz
/// with room to spare.
pub const MAX_ROWS: usize = 1_000_000;

/// A recording as columns of equal length: as read from a file (any accepted rate), or on the
/// monitor's 10 kHz grid once [`RecordingArgs::load`] has aligned and resampled it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recording {
    /// Comment lines (`#` lines of files written before the sidecar; without the `#` and one space).
    pub comments: Vec<String>,
    /// Sample times.
    pub time_s: Vec<f64>,
    /// Commanded surface position.
    pub command_rad: Vec<f64>,
    /// Measured surface position.
    pub position_rad: Vec<f64>,
    /// Measured phase current a.
    pub ia_a: Vec<f64>,
    /// Measured phase current b.
    pub ib_a: Vec<f64>,
    /// Measured phase current c.
    pub ic_a: Vec<f64>,
    /// Line of each row in its file (1-based), for messages that name the line.
    pub row_line: Vec<usize>,
}

impl Recording {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// `true` without rows.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// Sample period (mean step), 0 with fewer than two rows.
    pub fn sample_period_s(&self) -> f64 {
        match (self.time_s.first(), self.time_s.last()) {
            (Some(a), Some(b)) if self.len() > 1 => (b - a) / (self.len() - 1) as f64,
            _ => 0.0,
        }
    }

    /// The recorded channels of a reference-model run.
    pub fn from_reference(r: &ema_reference::Recording, comments: Vec<String>) -> Self {
        let comments_len = comments.len();
        let col = |f: &dyn Fn(&ema_reference::Sample) -> f64| r.samples.iter().map(f).collect::<Vec<f64>>();
        Self {
            time_s: col(&|s| s.time_s),
            command_rad: col(&|s| s.command_rad),
            position_rad: col(&|s| s.position_rad),
            ia_a: col(&|s| s.phase_current_a[0]),
            ib_a: col(&|s| s.phase_current_a[1]),
            ic_a: col(&|s| s.phase_current_a[2]),
            // as `write_csv` lays the file out: comments, header, then one line per row
            row_line: (0..r.samples.len()).map(|k| comments_len + 2 + k).collect(),
            comments,
        }
    }

    /// The six channels in the order of [`HEADER`].
    pub fn columns(&self) -> [&Vec<f64>; 6] {
        [&self.time_s, &self.command_rad, &self.position_rad, &self.ia_a, &self.ib_a, &self.ic_a]
    }
}

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
    /// A timestamp farther than [`grid::JITTER_TOLERANCE_S`] from the uniform grid.
    Jitter {
        /// Its distance from the grid.
        deviation_s: f64,
        /// The grid's (mean) period.
        period_s: f64,
    },
    /// The mean sample rate is outside [`grid::MIN_RATE_HZ`]..=[`grid::MAX_RATE_HZ`].
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
    /// A flag of [`RecordingArgs`] is malformed (the message names it).
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
}

impl fmt::Display for RecordingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "recording '{}'", self.path.display())?;
        if let Some(l) = self.line {
            write!(f, " line {l}")?;
        }
        if let Some(c) = &self.field {
            write!(f, " field '{c}'")?;
            if let Some(n) = self.column {
                write!(f, " (column {n})")?;
            }
        }
        f.write_str(": ")?;
        match &self.kind {
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
            RecordingErrorKind::TimeNotIncreasing { previous, current } => {
                write!(f, "time {current} s does not increase (previous row {previous} s)")
            }
            RecordingErrorKind::TimeNotUniform { step, expected } => write!(
                f,
                "time step {step} s differs from the median step {expected} s by more than {:.0} % (non-uniform sampling: \
                 a missing or repeated row?); give a uniformly sampled file",
                grid::STEP_TOLERANCE * 100.0
            ),
            RecordingErrorKind::Jitter { deviation_s, period_s } => write!(
                f,
                "the time is {:.3} µs off the uniform grid of mean period {period_s} s; timestamp jitter up to {} µs is \
                 tolerated: give the times of a uniformly sampled clock",
                deviation_s * 1e6,
                grid::JITTER_TOLERANCE_S * 1e6
            ),
            RecordingErrorKind::Rate { rate_hz } => write!(
                f,
                "sample rate {rate_hz:.1} Hz is outside the {} to {} kHz the reader resamples from; {}",
                grid::MIN_RATE_HZ / 1e3,
                grid::MAX_RATE_HZ / 1e3,
                if *rate_hz < grid::MIN_RATE_HZ {
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
                "the rows span {span_s} s, more than the {MAX_DURATION_S} s a recording may last; cut the file to the manoeuvre"
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
