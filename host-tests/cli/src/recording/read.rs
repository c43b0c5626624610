//! The CSV of a recording, read with the `csv` crate into the six channels the monitor needs.
//!
//! - **Columns** by header name: [`HEADER`] by default, any of them renamed with
//!   `--column KEY=HEADER` ([`Columns`]); columns in any order, extra columns ignored. A missing
//!   one is refused with the headers found and the `--column` to give.
//! - **Temperature** (optional): the column [`TEMPERATURE_HEADER`] (or the one
//!   `--column temperature=HEADER` names, which must then exist), the actuator's temperature in
//!   °C, each value within [`MIN_TEMPERATURE_C`] and [`MAX_TEMPERATURE_C`]. A file without it reads
//!   as a recording without a temperature.
//! - **Delimiter**: `--delimiter`, or detected from the header line: the most frequent of comma,
//!   semicolon and tab (comma when none occurs). With a semicolon or tab delimiter a decimal comma
//!   (`0,05`, a spreadsheet's export in many locales) reads as a decimal point.
//! - A UTF-8 byte order mark, `#` comment lines (kept in [`Recording::comments`] before the
//!   header, skipped after it) and blank lines are accepted.
//! - **Time**: strictly increasing, then the time base of [`grid::check`] (5–100 kHz, uniform
//!   within the jitter tolerance).
//!
//! The whole file is read into memory first, at most [`MAX_FILE_BYTES`]; every line is checked
//! against [`MAX_LINE_BYTES`] and for UTF-8 before the `csv` crate parses it, so no field drives
//! an allocation beyond the stated limits.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use super::data::{Recording, HEADER, KEYS, MAX_TEMPERATURE_C, MIN_TEMPERATURE_C, TEMPERATURE_HEADER, TEMPERATURE_KEY};
use super::data::{MAX_COMMENT_LINES, MAX_DURATION_S, MAX_FILE_BYTES, MAX_LINE_BYTES, MAX_ROWS, MIN_ROWS};
use super::error::{MissingColumn, RecordingError, RecordingErrorKind};
use super::grid;
use crate::input::{read_bounded, ReadError};

/// The header of each channel, and of the optional temperature column.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Columns {
    /// The header of each channel, in the order of [`KEYS`] (`time`, `command`, `position`, `ia`,
    /// `ib`, `ic`).
    pub channels: [String; 6],
    /// The temperature column as `--column temperature=HEADER` names it, which the file must then
    /// have; `None` reads [`TEMPERATURE_HEADER`] when the file has it.
    pub temperature: Option<String>,
}

impl Default for Columns {
    fn default() -> Self {
        Columns { channels: HEADER.map(str::to_owned), temperature: None }
    }
}

impl Columns {
    /// [`HEADER`] with the `KEY=HEADER` items of `--column` applied (each key at most once; the
    /// keys are [`KEYS`] and [`TEMPERATURE_KEY`]).
    pub fn parse(items: &[String]) -> Result<Self, String> {
        let mut columns = Columns::default();
        let mut seen = [false; 7];
        for item in items {
            let Some((key, header)) = item.split_once('=') else {
                return Err(format!("--column: '{item}' is not KEY=HEADER (e.g. ia=Ia)"));
            };
            let key = key.trim();
            let Some(i) = KEYS.iter().chain([&TEMPERATURE_KEY]).position(|k| *k == key) else {
                return Err(format!(
                    "--column: unknown key '{key}', the keys are {}, {TEMPERATURE_KEY}",
                    KEYS.join(", ")
                ));
            };
            if std::mem::replace(&mut seen[i], true) {
                return Err(format!("--column: the key '{key}' is given more than once"));
            }
            let header = header.trim();
            if header.is_empty() {
                return Err(format!("--column: '{item}' names no header"));
            }
            match columns.channels.get_mut(i) {
                Some(channel) => *channel = header.to_owned(),
                None => columns.temperature = Some(header.to_owned()),
            }
        }
        Ok(columns)
    }
}

/// How to read a recording file: which columns, which delimiter.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ReadOptions {
    /// The header of each channel.
    pub columns: Columns,
    /// The field delimiter; `None` detects it from the header line ([`detect_delimiter`]).
    pub delimiter: Option<u8>,
}

/// Reads and validates a recording file with the default columns and a detected delimiter.
pub fn read_recording(path: impl AsRef<Path>) -> Result<Recording, RecordingError> {
    read_recording_with(path.as_ref(), &ReadOptions::default())
}

/// Reads and validates a recording file under `options`.
pub fn read_recording_with(path: &Path, options: &ReadOptions) -> Result<Recording, RecordingError> {
    read_file(path, options).map(|p| p.recording)
}

/// [`read_recording_with`], with the time base and the columns found.
pub fn read_file(path: &Path, options: &ReadOptions) -> Result<Parsed, RecordingError> {
    let file = File::open(path)
        .map_err(|e| RecordingError::file(path, RecordingErrorKind::Io(format!("cannot open: {e}"))))?;
    parse_file(file, path, options)
}

/// [`read_recording`] from any reader; `path` only names the source in errors.
pub fn parse_recording(reader: impl Read, path: &Path) -> Result<Recording, RecordingError> {
    parse_recording_with(reader, path, &ReadOptions::default())
}

/// The delimiter of a header line: the most frequent of `,`, `;` and tab (`,` when none occurs;
/// on a tie the earlier in that order).
pub fn detect_delimiter(header: &str) -> u8 {
    let mut best = (b',', 0usize);
    for d in [b',', b';', b'\t'] {
        let n = header.bytes().filter(|&b| b == d).count();
        if n > best.1 {
            best = (d, n);
        }
    }
    best.0
}

/// A field as a number: trimmed; with a delimiter other than comma, a decimal comma is a point.
fn number(text: &str, delimiter: u8) -> Result<f64, RecordingErrorKind> {
    let t = text.trim();
    let parsed = if delimiter != b',' && t.contains(',') && !t.contains('.') {
        t.replacen(',', ".", 1).parse::<f64>()
    } else {
        t.parse::<f64>()
    };
    match parsed {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(RecordingErrorKind::NotFinite(t.to_owned())),
        Err(_) => Err(RecordingErrorKind::NotANumber(t.to_owned())),
    }
}

/// A recording as read, with its time base and where each channel is in the file.
#[derive(Clone, Debug)]
pub struct Parsed {
    /// The rows.
    pub recording: Recording,
    /// The grid fitted to its times.
    pub grid: grid::Grid,
    /// Each channel's header and 1-based column in the file, in the order of [`KEYS`].
    pub headers: [(String, usize); 6],
    /// The temperature column's header and 1-based column, when the file has one.
    pub temperature_header: Option<(String, usize)>,
}

/// Reads and validates a recording from any reader under `options`: the columns of
/// `options.columns`, at strictly increasing times, within every limit of the module, on a time
/// base [`grid::check`] accepts. `path` only names the source in errors.
pub fn parse_recording_with(
    reader: impl Read,
    path: &Path,
    options: &ReadOptions,
) -> Result<Recording, RecordingError> {
    parse_file(reader, path, options).map(|p| p.recording)
}

/// [`parse_recording_with`], with the time base and the columns found.
pub fn parse_file(reader: impl Read, path: &Path, options: &ReadOptions) -> Result<Parsed, RecordingError> {
    let at = |line: usize, kind| RecordingError { line: Some(line), ..RecordingError::file(path, kind) };
    let bytes = read_bounded(reader, MAX_FILE_BYTES).map_err(|e| match e {
        ReadError::TooLarge { .. } => RecordingError::file(path, RecordingErrorKind::TooLarge),
        other => RecordingError::file(path, RecordingErrorKind::Io(other.to_string())),
    })?;
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&bytes);
    // every line within the length limit, then the whole file UTF-8 (the first bad line named)
    for (n, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let content = line.strip_suffix(b"\r").unwrap_or(line);
        if content.len() > MAX_LINE_BYTES {
            return Err(at(n + 1, RecordingErrorKind::LineTooLong));
        }
        if std::str::from_utf8(line).is_err() {
            return Err(at(n + 1, RecordingErrorKind::NotText));
        }
    }
    let text = std::str::from_utf8(bytes).map_err(|_| RecordingError::file(path, RecordingErrorKind::NotText))?;

    // comment lines and blank lines up to the header
    let mut rec = Recording::default();
    let mut offset = 0;
    let mut header_line = 0;
    let mut header = None;
    for (n, line) in text.split_inclusive('\n').enumerate() {
        let t = line.trim();
        if let Some(c) = t.strip_prefix('#') {
            if rec.comments.len() == MAX_COMMENT_LINES {
                return Err(at(n + 1, RecordingErrorKind::TooManyComments));
            }
            rec.comments.push(c.strip_prefix(' ').unwrap_or(c).to_owned());
        } else if !t.is_empty() {
            header_line = n + 1;
            header = Some(t);
            break;
        }
        offset += line.len();
    }
    let Some(header) = header else {
        return Err(RecordingError::file(path, RecordingErrorKind::Empty));
    };
    let delimiter = options.delimiter.unwrap_or_else(|| detect_delimiter(header));
    let mut csv = csv::ReaderBuilder::new()
        .delimiter(delimiter)
        .comment(Some(b'#'))
        .flexible(true)
        .has_headers(false)
        .from_reader(&bytes[offset..]);
    let mut records = csv.records();
    let io = |e: csv::Error| RecordingError::file(path, RecordingErrorKind::Io(e.to_string()));
    let names: Vec<String> = match records.next() {
        Some(r) => r.map_err(io)?.iter().map(|h| h.trim().to_owned()).collect(),
        None => return Err(RecordingError::file(path, RecordingErrorKind::Empty)),
    };
    let missing = |key: &'static str, wanted: &str| {
        at(
            header_line,
            RecordingErrorKind::MissingColumn(Box::new(MissingColumn {
                key,
                wanted: wanted.to_owned(),
                found: names.clone(),
            })),
        )
    };
    let mut index = [0usize; 6];
    for (i, wanted) in options.columns.channels.iter().enumerate() {
        index[i] = names.iter().position(|h| h == wanted).ok_or_else(|| missing(KEYS[i], wanted))?;
    }
    // the temperature column: required when named, read when the default header is there
    let temperature = match &options.columns.temperature {
        Some(wanted) => Some(names.iter().position(|h| h == wanted).ok_or_else(|| missing(TEMPERATURE_KEY, wanted))?),
        None => names.iter().position(|h| h == TEMPERATURE_HEADER),
    };
    if temperature.is_some() {
        rec.temperature_c = Some(Vec::new());
    }
    for record in records {
        let record = record.map_err(io)?;
        // the csv crate's line is 1-based from the header line
        let n = header_line - 1 + record.position().map_or(0, |p| p.line() as usize);
        if record.len() == 1 && record[0].trim().is_empty() {
            continue; // a line of blanks
        }
        if record.len() != names.len() {
            return Err(at(n, RecordingErrorKind::FieldCount { found: record.len(), expected: names.len() }));
        }
        let mut v = [0.0f64; 6];
        for (i, &c) in index.iter().enumerate() {
            v[i] = number(&record[c], delimiter).map_err(|kind| RecordingError {
                field: Some(names[c].clone()),
                column: Some(c + 1),
                ..at(n, kind)
            })?;
        }
        let field_error =
            |c: usize, kind| RecordingError { field: Some(names[c].clone()), column: Some(c + 1), ..at(n, kind) };
        let temperature_c = match temperature {
            Some(c) => {
                let t = number(&record[c], delimiter).map_err(|kind| field_error(c, kind))?;
                if !(MIN_TEMPERATURE_C..=MAX_TEMPERATURE_C).contains(&t) {
                    return Err(field_error(c, RecordingErrorKind::Temperature(t)));
                }
                Some(t)
            }
            None => None,
        };
        let time_error =
            |kind| RecordingError { field: Some(names[index[0]].clone()), column: Some(index[0] + 1), ..at(n, kind) };
        if let Some(&previous) = rec.time_s.last() {
            if v[0] <= previous {
                return Err(time_error(RecordingErrorKind::TimeNotIncreasing { previous, current: v[0] }));
            }
        }
        if let Some(&first) = rec.time_s.first() {
            let span_s = v[0] - first;
            if span_s > MAX_DURATION_S {
                return Err(time_error(RecordingErrorKind::TooLong { span_s }));
            }
        }
        if rec.len() == MAX_ROWS {
            return Err(at(n, RecordingErrorKind::TooManyRows));
        }
        rec.time_s.push(v[0]);
        rec.command_rad.push(v[1]);
        rec.position_rad.push(v[2]);
        rec.ia_a.push(v[3]);
        rec.ib_a.push(v[4]);
        rec.ic_a.push(v[5]);
        rec.row_line.push(n);
        if let (Some(column), Some(t)) = (rec.temperature_c.as_mut(), temperature_c) {
            column.push(t);
        }
    }
    if rec.len() < MIN_ROWS {
        return Err(RecordingError::file(path, RecordingErrorKind::TooFewRows(rec.len())));
    }
    let grid = grid::check(&rec, path, &names[index[0]], index[0] + 1)?;
    let headers = index.map(|c| (names[c].clone(), c + 1));
    let temperature_header = temperature.map(|c| (names[c].clone(), c + 1));
    Ok(Parsed { recording: rec, grid, headers, temperature_header })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::Overwrite;
    use crate::recording::write::write_recording;

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
            rest_currents_a: Vec::new(),
            temperature_c: None,
        };
        let path = std::env::temp_dir().join(format!("ema-rt-{}.csv", std::process::id()));
        let _ = std::fs::remove_file(&path);
        write_recording(&path, &rec, Overwrite::Refuse).expect("writable temp dir");
        let back = read_recording(&path).expect("valid file");
        assert_eq!(back, rec);
        // with a temperature column: written after the channels, read back exactly
        let rec = Recording { temperature_c: Some(vec![-40.0, -39.5, 1.0 / 3.0, 200.0]), ..rec };
        write_recording(&path, &rec, Overwrite::Replace).expect("writable temp dir");
        let back = read_recording(&path).expect("valid file");
        let _ = std::fs::remove_file(&path);
        assert_eq!(back, rec);
        assert_eq!(back.mean_temperature_c(), Some((-79.5 + 1.0 / 3.0 + 200.0) / 4.0));
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
        assert_eq!((e.line, e.field.as_deref()), (Some(5), Some("time_s")));
        assert_eq!(e.kind, RecordingErrorKind::TooLong { span_s: 90.0 });
        assert!(e.to_string().contains("field 'time_s' (column 1): the rows span 90 s, more than the 60 s"), "{e}");
        // 10 kHz: exactly MAX_DURATION_S is accepted, one row more is refused
        let longest = rows(600_001, 1e4);
        assert_eq!(parse(longest.as_bytes()).map(|r| r.len()), Ok(600_001));
        let e = parse(rows(600_002, 1e4).as_bytes()).unwrap_err();
        assert!(matches!(e.kind, RecordingErrorKind::TooLong { .. }), "{e}");
        // 100 kHz: the row count is the limit
        let e = parse(rows(MAX_ROWS + 1, 1e5).as_bytes()).unwrap_err();
        assert_eq!((e.line, &e.kind), (Some(MAX_ROWS + 2), &RecordingErrorKind::TooManyRows));
        assert!(e.to_string().contains("more than 1000000 rows"), "{e}");
    }

    #[test]
    fn delimiters_bom_comments_and_renamed_columns_read() {
        let want = parse(rows(3, 1e4).as_bytes()).expect("valid");
        for (text, options) in [
            (rows(3, 1e4).replace(',', ";"), ReadOptions::default()),
            (rows(3, 1e4).replace(',', "\t"), ReadOptions::default()),
            (format!("\u{feff}# a\n\n{}", rows(3, 1e4)), ReadOptions::default()),
            (rows(3, 1e4).replace(',', "|"), ReadOptions { delimiter: Some(b'|'), ..ReadOptions::default() }),
        ] {
            let r = parse_recording_with(text.as_bytes(), Path::new("r.csv"), &options).expect(&text);
            assert_eq!(r.time_s, want.time_s);
        }
        // columns in another order, renamed, with an extra one; a decimal comma under semicolons
        let text = "Ic;Ib;Ia;x;pos;cmd;t\n0;0;0,5;7;0;0;0\n0;0;0,25;7;0;0;0,0001\n";
        let items: Vec<String> =
            ["time=t", "command=cmd", "position=pos", "ia=Ia", "ib=Ib", "ic=Ic"].map(String::from).to_vec();
        let options = ReadOptions { columns: Columns::parse(&items).expect("valid"), delimiter: None };
        let r = parse_recording_with(text.as_bytes(), Path::new("r.csv"), &options).expect("valid");
        assert_eq!((r.ia_a, r.time_s, r.row_line), (vec![0.5, 0.25], vec![0.0, 1e-4], vec![2, 3]));
    }

    #[test]
    fn the_temperature_column_is_optional_and_checked() {
        let head = "time_s,command_rad,position_rad,ia_A,ib_A,ic_A";
        // absent: no temperature; present under its default header: read, in any place
        assert_eq!(parse(rows(3, 1e4).as_bytes()).expect("valid").temperature_c, None);
        let text = format!("temperature_C,{head}\n-40,0,0,0,0,0,0\n-39.5,0.0001,0,0,0,0,0\n");
        let r = parse(text.as_bytes()).expect("valid");
        assert_eq!((r.temperature_c.clone(), r.mean_temperature_c()), (Some(vec![-40.0, -39.5]), Some(-39.75)));
        // renamed with --column temperature=T; a named column the file lacks is refused
        let text = format!("{head},T\n0,0,0,0,0,0,85\n0.0001,0,0,0,0,0,85\n");
        let named = |h: &str| ReadOptions {
            columns: Columns::parse(&[format!("temperature={h}")]).expect("valid"),
            delimiter: None,
        };
        let r = parse_recording_with(text.as_bytes(), Path::new("r.csv"), &named("T")).expect("valid");
        assert_eq!(r.mean_temperature_c(), Some(85.0));
        let e = parse_recording_with(text.as_bytes(), Path::new("r.csv"), &named("temp")).expect_err("missing");
        assert!(e.to_string().contains("line 1: no column 'temp' for the temperature channel"), "{e}");
        // out of range, not finite, not a number: the file, line and field named
        for (value, needle) in
            [("-100.5", "outside"), ("201", "outside"), ("NaN", "not a finite"), ("cold", "not a number")]
        {
            let text = format!("{head},temperature_C\n0,0,0,0,0,0,20\n0.0001,0,0,0,0,0,{value}\n");
            let e = parse(text.as_bytes()).expect_err(value);
            assert_eq!((e.line, e.field.as_deref(), e.column), (Some(3), Some("temperature_C"), Some(7)), "{e}");
            assert!(e.to_string().contains("'r.csv' line 3, field 'temperature_C' (column 7): "), "{e}");
            assert!(e.to_string().contains(needle), "{e}");
        }
        for bad in [["temperature=a", "temperature=b"], ["temp=a", "ia=b"]] {
            let items: Vec<String> = bad.map(String::from).to_vec();
            assert!(Columns::parse(&items).is_err(), "{bad:?}");
        }
    }
}
