//! Recording files: CSV written by `ema simulate`, read by `ema identify` (and anything else).
//!
//! ```text
//! # optional comment lines (faults, effects, seed, …)
//! time_s,command_rad,position_rad,ia_A,ib_A,ic_A
//! 0,0,0,0,0,0
//! 0.0001,0,0,-0.009765625,0,0.009765625
//! …
//! ```
//! One row per ACE sample (10 kHz), numbers in Rust's shortest round-trip form (a read gives back
//! exactly the values written). The reader skips `#` comment lines and blank lines and refuses, with
//! the file, line and field named: a missing or unreadable file, an empty file, a wrong header, a
//! wrong number of fields, text, NaN or infinity in a number, a time that does not increase or a
//! non-uniform time step, and fewer than [`MIN_ROWS`] rows.
//!
//! Every size is bounded, so that no file drives an allocation: a line holds at most
//! [`MAX_LINE_BYTES`] bytes, a file at most [`MAX_COMMENT_LINES`] comment lines and [`MAX_ROWS`]
//! rows spanning at most [`MAX_DURATION_S`] (the longest manoeuvre `ema simulate` records, at
//! 10 kHz); beyond any of them the file is refused at the line that crosses the limit.

use std::fmt;
use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};

use crate::error::CliError;
use crate::input::{BoundedLines, ReadError};
use crate::output::{self, Overwrite};

/// Column names, in order.
pub const HEADER: [&str; 6] = ["time_s", "command_rad", "position_rad", "ia_A", "ib_A", "ic_A"];
/// Fewest data rows a recording may have (a time step needs two).
pub const MIN_ROWS: usize = 2;
/// Largest relative deviation of a time step from the first one.
pub const TIME_STEP_TOLERANCE: f64 = 1e-6;
/// Longest line, in bytes (a row in shortest round-trip form takes at most about 150).
pub const MAX_LINE_BYTES: usize = 4096;
/// Most comment lines.
pub const MAX_COMMENT_LINES: usize = 1000;
/// Longest time span of a recording, first to last row: the longest profile the reference model
/// simulates ([`ema_reference::MAX_DURATION_S`]).
pub const MAX_DURATION_S: f64 = ema_reference::MAX_DURATION_S;
/// Most data rows: [`MAX_DURATION_S`] at 10 kHz, both ends included (`ema simulate` writes one
/// row fewer, [`ema_reference::MAX_SAMPLES`], for its longest profile).
pub const MAX_ROWS: usize = ema_reference::MAX_SAMPLES + 1;

/// A recording as stored in a file: columns of equal length.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recording {
    /// Comment lines (without the leading `#` and one space).
    pub comments: Vec<String>,
    /// Sample times, uniform.
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
}

/// What is wrong with a recording file.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum RecordingErrorKind {
    /// The file cannot be opened, read or written.
    Io(String),
    /// No header line.
    Empty,
    /// The header is not [`HEADER`].
    Header {
        /// The header found.
        found: String,
    },
    /// A row has the wrong number of fields.
    FieldCount {
        /// Fields found.
        found: usize,
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
    /// Time step differs from the first one.
    TimeNotUniform {
        /// This row's step.
        step: f64,
        /// The first step.
        expected: f64,
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
    /// A line longer than [`MAX_LINE_BYTES`].
    LineTooLong,
    /// A line that is not UTF-8 text.
    NotText,
}

/// A recording error with its location.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordingError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line in the file, where one line is at fault.
    pub line: Option<usize>,
    /// The column, where one field is at fault.
    pub field: Option<&'static str>,
    /// What is wrong.
    pub kind: RecordingErrorKind,
}

impl fmt::Display for RecordingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "recording '{}'", self.path.display())?;
        if let Some(l) = self.line {
            write!(f, " line {l}")?;
        }
        if let Some(c) = self.field {
            let col = HEADER.iter().position(|h| *h == c).map_or(0, |i| i + 1);
            write!(f, " field '{c}' (column {col})")?;
        }
        f.write_str(": ")?;
        match &self.kind {
            RecordingErrorKind::Io(m) => write!(f, "{m}"),
            RecordingErrorKind::Empty => write!(f, "empty file, expected the header '{}'", HEADER.join(",")),
            RecordingErrorKind::Header { found } => {
                write!(f, "wrong header: expected '{}', found '{found}'", HEADER.join(","))
            }
            RecordingErrorKind::FieldCount { found } => write!(f, "expected {} fields, found {found}", HEADER.len()),
            RecordingErrorKind::NotANumber(s) => write!(f, "'{s}' is not a number"),
            RecordingErrorKind::NotFinite(s) => write!(f, "'{s}' is not a finite number"),
            RecordingErrorKind::TimeNotIncreasing { previous, current } => {
                write!(f, "time {current} s does not increase (previous row {previous} s)")
            }
            RecordingErrorKind::TimeNotUniform { step, expected } => {
                write!(f, "time step {step} s differs from the first step {expected} s (non-uniform sampling)")
            }
            RecordingErrorKind::TooFewRows(n) => write!(f, "too few rows: {n} (need at least {MIN_ROWS})"),
            RecordingErrorKind::TooManyRows => write!(f, "more than {MAX_ROWS} rows"),
            RecordingErrorKind::TooManyComments => write!(f, "more than {MAX_COMMENT_LINES} comment lines"),
            RecordingErrorKind::TooLong { span_s } => {
                write!(f, "the rows span {span_s} s, more than the {MAX_DURATION_S} s a recording may last")
            }
            RecordingErrorKind::LineTooLong => write!(f, "line longer than {MAX_LINE_BYTES} bytes"),
            RecordingErrorKind::NotText => write!(f, "not UTF-8 text"),
        }
    }
}

impl std::error::Error for RecordingError {}

/// Reads and validates a recording file.
pub fn read_recording(path: impl AsRef<Path>) -> Result<Recording, RecordingError> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|e| RecordingError {
        path: path.to_owned(),
        line: None,
        field: None,
        kind: RecordingErrorKind::Io(format!("cannot open: {e}")),
    })?;
    parse_recording(BufReader::new(file), path)
}

/// Reads and validates a recording from any reader (what [`read_recording`] does once the file
/// is open); `path` only names the source in errors.
pub fn parse_recording(reader: impl BufRead, path: &Path) -> Result<Recording, RecordingError> {
    let err = |line: Option<usize>, field: Option<&'static str>, kind| RecordingError {
        path: path.to_owned(),
        line,
        field,
        kind,
    };
    let mut rec = Recording::default();
    let mut header_seen = false;
    let mut step0: Option<f64> = None;
    let mut lines = BoundedLines::new(reader, MAX_LINE_BYTES);
    while let Some(line) = lines.next_line() {
        let (n, line) = line.map_err(|e| match e {
            ReadError::LineTooLong { line, .. } => err(Some(line), None, RecordingErrorKind::LineTooLong),
            ReadError::NotUtf8 { line } => err(Some(line), None, RecordingErrorKind::NotText),
            other => err(None, None, RecordingErrorKind::Io(other.to_string())),
        })?;
        let text = line.trim();
        if text.is_empty() {
            continue;
        }
        if let Some(c) = text.strip_prefix('#') {
            if rec.comments.len() == MAX_COMMENT_LINES {
                return Err(err(Some(n), None, RecordingErrorKind::TooManyComments));
            }
            rec.comments.push(c.strip_prefix(' ').unwrap_or(c).to_owned());
            continue;
        }
        if !header_seen {
            let fields: Vec<&str> = text.split(',').map(str::trim).collect();
            if fields != HEADER {
                return Err(err(Some(n), None, RecordingErrorKind::Header { found: text.to_owned() }));
            }
            header_seen = true;
            continue;
        }
        let fields: Vec<&str> = text.split(',').map(str::trim).collect();
        if fields.len() != HEADER.len() {
            return Err(err(Some(n), None, RecordingErrorKind::FieldCount { found: fields.len() }));
        }
        let mut v = [0.0f64; 6];
        for (i, s) in fields.iter().enumerate() {
            v[i] = match s.parse::<f64>() {
                Ok(x) if x.is_finite() => x,
                Ok(_) => return Err(err(Some(n), Some(HEADER[i]), RecordingErrorKind::NotFinite((*s).to_owned()))),
                Err(_) => return Err(err(Some(n), Some(HEADER[i]), RecordingErrorKind::NotANumber((*s).to_owned()))),
            };
        }
        if let Some(&previous) = rec.time_s.last() {
            let step = v[0] - previous;
            if step <= 0.0 {
                let kind = RecordingErrorKind::TimeNotIncreasing { previous, current: v[0] };
                return Err(err(Some(n), Some(HEADER[0]), kind));
            }
            match step0 {
                None => step0 = Some(step),
                Some(expected) if (step - expected).abs() > TIME_STEP_TOLERANCE * expected => {
                    return Err(err(Some(n), Some(HEADER[0]), RecordingErrorKind::TimeNotUniform { step, expected }));
                }
                Some(_) => {}
            }
        }
        if let Some(&first) = rec.time_s.first() {
            let span_s = v[0] - first;
            if span_s > MAX_DURATION_S {
                return Err(err(Some(n), Some(HEADER[0]), RecordingErrorKind::TooLong { span_s }));
            }
        }
        if rec.len() == MAX_ROWS {
            return Err(err(Some(n), None, RecordingErrorKind::TooManyRows));
        }
        rec.time_s.push(v[0]);
        rec.command_rad.push(v[1]);
        rec.position_rad.push(v[2]);
        rec.ia_a.push(v[3]);
        rec.ib_a.push(v[4]);
        rec.ic_a.push(v[5]);
        rec.row_line.push(n);
    }
    if !header_seen {
        return Err(err(None, None, RecordingErrorKind::Empty));
    }
    if rec.len() < MIN_ROWS {
        return Err(err(None, None, RecordingErrorKind::TooFewRows(rec.len())));
    }
    Ok(rec)
}

/// Writes a recording (comment lines, header, rows in shortest round-trip form) through
/// [`output::write_with`]: to a temporary file renamed into place once complete, so a failed write
/// never leaves a truncated recording; an existing file is replaced only with
/// [`Overwrite::Replace`].
pub fn write_recording(path: impl AsRef<Path>, rec: &Recording, overwrite: Overwrite) -> Result<(), CliError> {
    output::write_with(path.as_ref(), overwrite, |mut w| write_csv(&mut w, rec))
}

/// Writes a recording as CSV to any writer.
pub fn write_csv(w: &mut impl Write, rec: &Recording) -> std::io::Result<()> {
    for c in &rec.comments {
        writeln!(w, "# {c}")?;
    }
    writeln!(w, "{}", HEADER.join(","))?;
    for k in 0..rec.len() {
        writeln!(
            w,
            "{},{},{},{},{},{}",
            rec.time_s[k], rec.command_rad[k], rec.position_rad[k], rec.ia_a[k], rec.ib_a[k], rec.ic_a[k]
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_round_trip_is_exact() {
        let rec = Recording {
            comments: vec!["seed: 3".into()],
            time_s: vec![0.0, 1e-4, 2e-4, 0.00030000000000000003],
            command_rad: vec![0.0, 0.05000000074505806, -0.1, 1.0 / 3.0],
            position_rad: vec![1.8310546875e-5, 0.0, -0.0, 0.6],
            ia_a: vec![-0.009765625, 19.990234375, -20.0, 0.1],
            ib_a: vec![0.0; 4],
            ic_a: vec![1e-300, -1e300, 5e-324, 0.0],
            row_line: vec![3, 4, 5, 6], // one comment line, the header, then the rows
        };
        let path = std::env::temp_dir().join(format!("ema-rt-{}.csv", std::process::id()));
        let _ = std::fs::remove_file(&path);
        write_recording(&path, &rec, Overwrite::Refuse).expect("writable temp dir");
        let back = read_recording(&path).expect("valid file");
        let _ = std::fs::remove_file(&path);
        assert_eq!(back, rec);
        assert!((back.sample_period_s() - 1e-4).abs() < 1e-12);
    }

    fn parse(text: &[u8]) -> Result<Recording, RecordingError> {
        parse_recording(text, Path::new("r.csv"))
    }

    const HEAD: &str = "time_s,command_rad,position_rad,ia_A,ib_A,ic_A\n";

    /// `n` rows at `rate_hz` (times `k/rate`, as `ema simulate` writes them), all channels zero.
    fn rows(n: usize, rate_hz: f64) -> String {
        let mut text = String::from(HEAD);
        for k in 0..n {
            text.push_str(&format!("{},0,0,0,0,0\n", k as f64 / rate_hz));
        }
        text
    }

    #[test]
    fn sizes_are_bounded_with_the_line_named() {
        let e = parse(format!("#{}\n{HEAD}", "x".repeat(MAX_LINE_BYTES)).as_bytes()).unwrap_err();
        assert_eq!((e.line, &e.kind), (Some(1), &RecordingErrorKind::LineTooLong));
        assert!(e.to_string().contains("r.csv' line 1: line longer than 4096 bytes"), "{e}");
        let e = parse(&[HEAD.as_bytes(), b"0,0,0,0,0,0\n1e-4,0,0,0,0,\xff\n"].concat()).unwrap_err();
        assert_eq!((e.line, &e.kind), (Some(3), &RecordingErrorKind::NotText));
        let e = parse("# c\n".repeat(MAX_COMMENT_LINES + 1).as_bytes()).unwrap_err();
        assert_eq!((e.line, &e.kind), (Some(MAX_COMMENT_LINES + 1), &RecordingErrorKind::TooManyComments));
        // a uniform 30 s step: the fourth row spans 90 s
        let text = format!("{HEAD}0,0,0,0,0,0\n30,0,0,0,0,0\n60,0,0,0,0,0\n90,0,0,0,0,0\n");
        let e = parse(text.as_bytes()).unwrap_err();
        assert_eq!((e.line, e.field), (Some(5), Some("time_s")));
        assert_eq!(e.kind, RecordingErrorKind::TooLong { span_s: 90.0 });
        assert!(e.to_string().contains("field 'time_s' (column 1): the rows span 90 s, more than the 60 s"), "{e}");
        // 10 kHz: exactly MAX_DURATION_S (MAX_ROWS rows) is accepted, one row more is refused
        let longest = rows(MAX_ROWS, 1e4);
        assert_eq!(parse(longest.as_bytes()).map(|r| r.len()), Ok(MAX_ROWS));
        let e = parse(rows(MAX_ROWS + 1, 1e4).as_bytes()).unwrap_err();
        assert!(matches!(e.kind, RecordingErrorKind::TooLong { .. }), "{e}");
        // 100 kHz: the row count is the limit
        let e = parse(rows(MAX_ROWS + 1, 1e5).as_bytes()).unwrap_err();
        assert_eq!((e.line, &e.kind), (Some(MAX_ROWS + 2), &RecordingErrorKind::TooManyRows));
        assert!(e.to_string().ends_with("more than 600001 rows"), "{e}");
    }
}
