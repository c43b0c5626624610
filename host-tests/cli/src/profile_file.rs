//! Command profiles in a small text format, validated by [`ema_monitor::Profile::new`].
//!
//! ```text
//! # standard-like manoeuvre (surface angles in rad, times in s, frequencies in Hz)
//! hold 0     0            # hold START VALUE
//! hold 0.01  0.05
//! ramp 0.30  -0.05 0.2    # ramp START START_RAD RATE_RAD_PER_S
//! sine 0.60  0.01 0.01 4  # sine START OFFSET_RAD AMPLITUDE_RAD FREQUENCY_HZ
//! end  0.85               # end DURATION
//! ```
//! One segment per line, from its start time until the next segment's; `#` starts a comment;
//! blank lines are ignored. The first segment starts at 0, start times increase, `end` comes last
//! and exactly once, at most 16 segments, every commanded value stays inside the end stops, the
//! duration is at most [`MAX_DURATION_S`] (the longest manoeuvre the reference model simulates:
//! the duration sizes its recording) and the file holds at most [`MAX_FILE_BYTES`].

use std::fmt;
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

use ema_monitor::profile::{ProfileError, Segment, MAX_SEGMENTS};
use ema_monitor::{EmaParams, Profile};

use crate::error::{num, CliError, Place};
use crate::input;

/// Longest profile duration (s): the reference model's limit, [`ema_reference::MAX_DURATION_S`].
pub const MAX_DURATION_S: f32 = ema_reference::MAX_DURATION_S as f32;

/// Largest profile file, in bytes: 16 segment lines and their comments fit many times over.
pub const MAX_FILE_BYTES: usize = 64 * 1024;

/// Why a profile file was refused: names the file and, where it applies, the line.
#[derive(Clone, Debug, PartialEq)]
pub struct ProfileFileError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line, when one line is at fault.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ProfileFileError {
    /// `'PATH' line N: what is wrong` ([`Place`]).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", Place::at(&self.path, self.line, None), self.message)
    }
}

impl std::error::Error for ProfileFileError {}

impl From<ProfileFileError> for CliError {
    fn from(e: ProfileFileError) -> Self {
        CliError::input_at(Place::at(&e.path, e.line, None), e.message)
    }
}

/// Reads and validates a profile file against the nominal end stops.
pub fn read_profile(path: &Path) -> Result<Profile, ProfileFileError> {
    let file = File::open(path).map_err(|e| ProfileFileError {
        path: path.to_owned(),
        line: None,
        message: format!("cannot read: {e}"),
    })?;
    read_profile_from(file, path)
}

/// [`read_profile`] from any reader (at most [`MAX_FILE_BYTES`] of UTF-8 text); `path` only names
/// the source in errors.
pub fn read_profile_from(reader: impl Read, path: &Path) -> Result<Profile, ProfileFileError> {
    let text = input::read_text(reader, MAX_FILE_BYTES).map_err(|e| {
        let (line, message) = match e {
            input::ReadError::NotUtf8 { line } => (Some(line), "not UTF-8 text".to_owned()),
            other => (None, other.to_string()),
        };
        ProfileFileError { path: path.to_owned(), line, message }
    })?;
    parse_profile(&text, path, EmaParams::NOMINAL.end_stop_rad)
}

/// Parses profile text; `path` only names the source in errors.
pub fn parse_profile(text: &str, path: &Path, end_stop_rad: f32) -> Result<Profile, ProfileFileError> {
    let err = |line: Option<usize>, message: String| ProfileFileError { path: path.to_owned(), line, message };
    let mut segments: Vec<(Segment, usize)> = Vec::new();
    let mut end: Option<(f32, usize, &str)> = None;
    for (idx, raw) in text.lines().enumerate() {
        let line = idx + 1;
        let content = raw.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let mut words = content.split_whitespace();
        let keyword = words.next().unwrap_or("");
        let args: Vec<&str> = words.collect();
        if end.is_some() {
            return Err(err(Some(line), format!("'{keyword}' after 'end': 'end DURATION' must be the last line")));
        }
        let names: &[&str] = match keyword {
            "hold" => &["START", "VALUE"],
            "ramp" => &["START", "START_RAD", "RATE"],
            "sine" => &["START", "OFFSET", "AMPLITUDE", "FREQUENCY"],
            "end" => &["DURATION"],
            other => {
                return Err(err(Some(line), format!("unknown keyword '{other}'; expected hold, ramp, sine or end")))
            }
        };
        if args.len() != names.len() {
            return Err(err(
                Some(line),
                format!(
                    "'{keyword}' takes {} values ({keyword} {}), found {}",
                    names.len(),
                    names.join(" "),
                    args.len()
                ),
            ));
        }
        let mut v = [0.0f32; 4];
        for (i, (a, name)) in args.iter().zip(names).enumerate() {
            v[i] = match a.parse::<f32>() {
                Ok(x) if x.is_finite() => x,
                Ok(_) => return Err(err(Some(line), format!("{name} '{a}' is not a finite number"))),
                Err(_) => return Err(err(Some(line), format!("{name} '{a}' is not a number"))),
            };
        }
        let seg = match keyword {
            "hold" => Segment::Hold { start_s: v[0], value_rad: v[1] },
            "ramp" => Segment::Ramp { start_s: v[0], start_rad: v[1], rate_rad_per_s: v[2] },
            "sine" => Segment::Sine { start_s: v[0], offset_rad: v[1], amplitude_rad: v[2], frequency_hz: v[3] },
            _ => {
                end = Some((v[0], line, args[0]));
                continue;
            }
        };
        if segments.len() == MAX_SEGMENTS {
            return Err(err(Some(line), format!("more than {MAX_SEGMENTS} segments")));
        }
        let start = seg.start_s();
        match segments.last() {
            None if start != 0.0 => {
                return Err(err(Some(line), format!("the first segment must start at 0, not {}", num(start))))
            }
            Some((prev, _)) if start <= prev.start_s() => {
                return Err(err(
                    Some(line),
                    format!(
                        "start time {} s does not come after the previous segment's {} s",
                        num(start),
                        num(prev.start_s())
                    ),
                ))
            }
            _ => {}
        }
        if let Segment::Sine { frequency_hz, .. } = seg {
            if frequency_hz < 0.0 {
                return Err(err(Some(line), format!("FREQUENCY {} Hz is negative", num(frequency_hz))));
            }
        }
        segments.push((seg, line));
    }
    let Some((duration, end_line, duration_text)) = end else {
        return Err(err(None, "no 'end DURATION' line".into()));
    };
    let Some((last, _)) = segments.last() else {
        return Err(err(Some(end_line), "no segment before 'end'".into()));
    };
    if duration <= last.start_s() {
        return Err(err(
            Some(end_line),
            format!(
                "duration {} s does not come after the last segment's start {} s",
                num(duration),
                num(last.start_s())
            ),
        ));
    }
    if duration > MAX_DURATION_S {
        return Err(err(
            Some(end_line),
            format!("DURATION '{duration_text}' is longer than the {MAX_DURATION_S} s a profile may last"),
        ));
    }
    let segs: Vec<Segment> = segments.iter().map(|s| s.0).collect();
    match Profile::new(&segs, duration, end_stop_rad) {
        Ok(p) => Ok(p),
        Err(e) => {
            // Find the first segment that the shared validation refuses, to name its line.
            for i in 0..segs.len() {
                let stop = segs.get(i + 1).map_or(duration, Segment::start_s);
                if Profile::new(&segs[..=i], stop, end_stop_rad).is_err() {
                    let message = match e {
                        ProfileError::SinePhase => format!("FREQUENCY: {e}"),
                        _ => format!("{e} (end stops ±{} rad, the value must stay strictly inside)", num(end_stop_rad)),
                    };
                    return Err(err(Some(segments[i].1), message));
                }
            }
            Err(err(None, e.to_string()))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Profile, ProfileFileError> {
        parse_profile(text, Path::new("p.txt"), 0.6)
    }

    #[test]
    fn the_standard_profile_in_text_form() {
        let text = "# standard\nhold 0 0\nhold 0.01 0.05\nhold 0.15 -0.05\n\nramp 0.30 -0.05 0.2\nsine 0.60 0.01 0.01 4 # 4 Hz\nend 0.85\n";
        assert_eq!(parse(text), Ok(Profile::STANDARD));
    }

    #[test]
    fn errors_name_the_line() {
        let cases = [
            ("hold 0 0\nstep 1 2\nend 1", 2, "unknown keyword 'step'"),
            ("hold 0 0\nramp 0.1 0\nend 1", 2, "takes 3 values"),
            ("hold 0 abc\nend 1", 1, "VALUE 'abc' is not a number"),
            ("hold 0 inf\nend 1", 1, "not a finite number"),
            ("hold 0.1 0\nend 1", 1, "must start at 0"),
            ("hold 0 0\nhold 0.5 0.1\nhold 0.4 0\nend 1", 3, "does not come after"),
            ("hold 0 0\nend 1\nhold 2 0", 3, "after 'end'"),
            ("hold 0 0\nhold 0.5 0.7\nend 1", 2, "beyond the end stops"),
            ("hold 0 0\nramp 0.1 0 10\nend 1", 2, "beyond the end stops"),
            ("hold 0 0\nend 0", 2, "duration 0 s"),
            ("end 1", 1, "no segment"),
            // a duration that would size the reference model's recording beyond its limit
            ("hold 0 0\nend 1e30", 2, "DURATION '1e30' is longer than the 60 s a profile may last"),
            ("hold 0 0\n\nend 60.01", 3, "DURATION '60.01' is longer"),
            // a sine the f32 sine cannot follow (the `profile` fuzz target's find: it commanded −∞)
            (
                "# t)\nhold 0  0.01\nsine 0.86888888860  0.01 0.04  10000000000000 # 4$Hz\nend  1.80\n",
                3,
                "FREQUENCY: a sine segment sweeps more than 1000 rad of phase",
            ),
        ];
        for (text, line, msg) in cases {
            let e = parse(text).expect_err(text);
            assert_eq!(e.line, Some(line), "{text}: {e}");
            assert!(e.to_string().contains(msg) && e.to_string().contains("p.txt"), "{text}: {e}");
        }
        assert!(parse("hold 0 0").expect_err("no end").to_string().contains("no 'end DURATION'"));
        assert!(parse("hold 0 0\nend 60").is_ok());
    }

    #[test]
    fn the_file_is_bounded_text() {
        let from = |bytes: &[u8]| read_profile_from(bytes, Path::new("p.txt"));
        assert_eq!(from(b"hold 0 0\nend 0.5\n").map(|p| p.duration_s()), Ok(0.5));
        let e = from(b"hold 0 0\nend 0.5\xff\n").unwrap_err();
        assert_eq!(e.line, Some(2));
        assert!(e.to_string().contains("line 2: not UTF-8 text"), "{e}");
        let big = format!("hold 0 0\nend 0.5\n{}", "#\n".repeat(MAX_FILE_BYTES));
        let e = from(big.as_bytes()).unwrap_err();
        assert!(e.to_string().ends_with("larger than 65536 bytes, the most this file may hold"), "{e}");
        let e = read_profile_from(std::io::repeat(b' '), Path::new("/dev/zero")).unwrap_err();
        assert!(e.to_string().contains("larger than"), "{e}");
    }
}
