//! Bounded reading of input files: no file, however large or hostile, sizes an allocation beyond
//! the limit its reader states.
//!
//! [`read_bounded`] reads at most `limit + 1` bytes (whatever the file's size claims: a pipe or
//! `/dev/zero` has none) and refuses a file longer than `limit`; [`read_text`] adds the UTF-8
//! check of the text formats. [`BoundedLines`] hands out the lines of a text file one by one, each
//! refused beyond [`BoundedLines::max_line_bytes`] before it is stored.
//!
//! [`check_distinct`] refuses a file given twice to a command that takes each file as one flight
//! (`ema identify A B …`, `ema history`, `ema commission`): the same file under two names, or two
//! files of identical content.

use std::collections::hash_map::DefaultHasher;
use std::fmt;
use std::fs::File;
use std::hash::Hasher;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

use crate::error::{CliError, Place};

/// Why a bounded read failed.
#[derive(Debug)]
pub enum ReadError {
    /// The reader failed (the operating system's reason).
    Io(std::io::Error),
    /// More bytes than the limit.
    TooLarge {
        /// The limit, in bytes.
        limit: usize,
    },
    /// Not UTF-8 text; `line` is the 1-based line of the first invalid byte.
    NotUtf8 {
        /// Line of the first invalid byte.
        line: usize,
    },
    /// A line longer than the limit (its 1-based number).
    LineTooLong {
        /// The line.
        line: usize,
        /// The limit, in bytes, without the line end.
        limit: usize,
    },
}

impl fmt::Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReadError::Io(e) => write!(f, "cannot read: {e}"),
            ReadError::TooLarge { limit } => write!(f, "larger than {limit} bytes, the most this file may hold"),
            ReadError::NotUtf8 { line } => write!(f, "line {line}: not UTF-8 text"),
            ReadError::LineTooLong { line, limit } => write!(f, "line {line}: longer than {limit} bytes"),
        }
    }
}

impl std::error::Error for ReadError {}

impl ReadError {
    /// The 1-based line at fault, when one is.
    pub fn line(&self) -> Option<usize> {
        match self {
            ReadError::NotUtf8 { line } | ReadError::LineTooLong { line, .. } => Some(*line),
            ReadError::Io(_) | ReadError::TooLarge { .. } => None,
        }
    }

    /// What is wrong, without the line.
    pub fn message(&self) -> String {
        match self {
            ReadError::NotUtf8 { .. } => "not UTF-8 text".to_owned(),
            ReadError::LineTooLong { limit, .. } => format!("longer than {limit} bytes"),
            other => other.to_string(),
        }
    }

    /// The error about the file `path`, at its line ([`CliError::Input`]).
    pub fn at(&self, path: &Path) -> CliError {
        CliError::input_at(Place::at(path, self.line(), None), self.message())
    }
}

/// What identifies a file's content: its canonical path, and for a regular file its length and a
/// hash of its first `limit + 1` bytes (a pipe or a device is not read: reading would consume it).
struct Identity {
    canonical: PathBuf,
    content: Option<(u64, u64)>,
}

/// The [`Identity`] of `path`; an error names the file when it cannot be opened or read.
fn identity(path: &Path, limit: usize) -> Result<Identity, CliError> {
    let canonical = std::fs::canonicalize(path).map_err(|e| CliError::input(path, format!("cannot read: {e}")))?;
    let meta = std::fs::metadata(&canonical).map_err(|e| CliError::input(path, format!("cannot read: {e}")))?;
    if !meta.is_file() {
        return Ok(Identity { canonical, content: None });
    }
    let file = File::open(&canonical).map_err(|e| CliError::input(path, format!("cannot read: {e}")))?;
    let cap = u64::try_from(limit).unwrap_or(u64::MAX).saturating_add(1);
    let mut reader = BufReader::new(file.take(cap));
    let mut hasher = DefaultHasher::new();
    let mut length = 0u64;
    loop {
        let chunk = reader.fill_buf().map_err(|e| CliError::input(path, format!("cannot read: {e}")))?;
        if chunk.is_empty() {
            break;
        }
        hasher.write(chunk);
        let n = chunk.len();
        length += n as u64;
        reader.consume(n);
    }
    Ok(Identity { canonical, content: Some((length, hasher.finish())) })
}

/// `true` when the regular files `a` and `b` hold the same first `limit + 1` bytes (the check
/// behind equal hashes).
fn same_bytes(a: &Path, b: &Path, limit: usize) -> bool {
    let read = |p: &Path| File::open(p).ok().and_then(|f| read_bounded(f, limit).ok());
    matches!((read(a), read(b)), (Some(x), Some(y)) if x == y)
}

/// Refuses a file given twice among `paths` (the inputs of one command, each one flight): the
/// same file under two names (one canonical path) or two regular files of identical content (the
/// first `limit + 1` bytes, `limit` the most the command reads of one). The error names both
/// arguments and their places on the command line; an unreadable file is an error naming it.
pub fn check_distinct(paths: &[PathBuf], limit: usize) -> Result<(), CliError> {
    let mut seen: Vec<Identity> = Vec::with_capacity(paths.len());
    for (j, path) in paths.iter().enumerate() {
        let id = identity(path, limit)?;
        for (i, other) in seen.iter().enumerate() {
            let same_file = other.canonical == id.canonical;
            let same_content = id.content.is_some()
                && other.content == id.content
                && same_bytes(&other.canonical, &id.canonical, limit);
            if same_file || same_content {
                return Err(CliError::usage(format!(
                    "recordings {} ('{}') and {} ('{}') are {}: each recording is one flight; give each once",
                    i + 1,
                    paths[i].display(),
                    j + 1,
                    path.display(),
                    if same_file { "the same file" } else { "identical (the same bytes)" }
                )));
            }
        }
        seen.push(id);
    }
    Ok(())
}

/// All bytes of `reader`, at most `limit` of them: a longer input is [`ReadError::TooLarge`]
/// after reading `limit + 1` bytes, never more.
pub fn read_bounded(reader: impl Read, limit: usize) -> Result<Vec<u8>, ReadError> {
    let mut bytes = Vec::new();
    let cap = u64::try_from(limit).unwrap_or(u64::MAX).saturating_add(1);
    reader.take(cap).read_to_end(&mut bytes).map_err(ReadError::Io)?;
    if bytes.len() > limit {
        return Err(ReadError::TooLarge { limit });
    }
    Ok(bytes)
}

/// [`read_bounded`], then UTF-8 text (the error names the line of the first invalid byte).
pub fn read_text(reader: impl Read, limit: usize) -> Result<String, ReadError> {
    text(read_bounded(reader, limit)?)
}

/// `bytes` as UTF-8 text (the error names the line of the first invalid byte).
pub fn text(bytes: Vec<u8>) -> Result<String, ReadError> {
    String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..valid].iter().filter(|&&b| b == b'\n').count();
        ReadError::NotUtf8 { line }
    })
}

/// The lines of a text reader, each at most `max_line_bytes` long (without its `\n` or `\r\n`),
/// numbered from 1; a longer line is refused after reading `max_line_bytes + 1` of its bytes.
pub struct BoundedLines<R> {
    reader: R,
    max_line_bytes: usize,
    line: usize,
    buf: Vec<u8>,
    done: bool,
}

impl<R: BufRead> BoundedLines<R> {
    /// Lines of `reader`, each at most `max_line_bytes` long.
    pub fn new(reader: R, max_line_bytes: usize) -> Self {
        Self { reader, max_line_bytes, line: 0, buf: Vec::new(), done: false }
    }

    /// The longest line accepted, in bytes.
    pub fn max_line_bytes(&self) -> usize {
        self.max_line_bytes
    }

    /// The next line and its 1-based number, `None` at the end; after an error, `None`.
    pub fn next_line(&mut self) -> Option<Result<(usize, &str), ReadError>> {
        if self.done {
            return None;
        }
        self.buf.clear();
        self.line += 1;
        // the line, its `\n` and one byte more at most: enough to tell a line that is too long
        let cap = u64::try_from(self.max_line_bytes).unwrap_or(u64::MAX).saturating_add(2);
        let read = match (&mut self.reader).take(cap).read_until(b'\n', &mut self.buf) {
            Ok(n) => n,
            Err(e) => {
                self.done = true;
                return Some(Err(ReadError::Io(e)));
            }
        };
        if read == 0 {
            self.done = true;
            return None;
        }
        if self.buf.last() == Some(&b'\n') {
            self.buf.pop();
            if self.buf.last() == Some(&b'\r') {
                self.buf.pop();
            }
        }
        if self.buf.len() > self.max_line_bytes {
            self.done = true;
            return Some(Err(ReadError::LineTooLong { line: self.line, limit: self.max_line_bytes }));
        }
        match std::str::from_utf8(&self.buf) {
            Ok(s) => Some(Ok((self.line, s))),
            Err(_) => {
                self.done = true;
                Some(Err(ReadError::NotUtf8 { line: self.line }))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounded_read_stops_at_the_limit() {
        assert_eq!(read_bounded(&b"abc"[..], 3).unwrap(), b"abc");
        assert!(matches!(read_bounded(&b"abcd"[..], 3), Err(ReadError::TooLarge { limit: 3 })));
        // an endless input is refused after limit + 1 bytes
        assert!(matches!(read_bounded(std::io::repeat(0), 1000), Err(ReadError::TooLarge { limit: 1000 })));
        assert!(matches!(read_text(&b"ok\n\xff"[..], 10), Err(ReadError::NotUtf8 { line: 2 })));
        assert_eq!(read_text(&b"ok\n"[..], 10).unwrap(), "ok\n");
    }

    fn lines(input: &[u8], max: usize) -> Vec<Result<(usize, String), String>> {
        let mut it = BoundedLines::new(input, max);
        let mut out = Vec::new();
        while let Some(r) = it.next_line() {
            out.push(r.map(|(n, s)| (n, s.to_owned())).map_err(|e| e.to_string()));
        }
        out
    }

    #[test]
    fn lines_are_numbered_split_and_bounded() {
        let ok = |n: usize, s: &str| Ok((n, s.to_owned()));
        assert_eq!(lines(b"a\r\nbb\n\nccc", 3), [ok(1, "a"), ok(2, "bb"), ok(3, ""), ok(4, "ccc")]);
        assert_eq!(lines(b"abc\n", 3), [ok(1, "abc")]);
        assert_eq!(lines(b"abc\r\n", 3), [ok(1, "abc")]);
        assert_eq!(lines(b"a\nabcd\nb", 3), [ok(1, "a"), Err("line 2: longer than 3 bytes".into())]);
        assert_eq!(lines(b"abcd", 3), [Err("line 1: longer than 3 bytes".into())]);
        assert_eq!(lines(b"a\n\xc3\n", 3), [ok(1, "a"), Err("line 2: not UTF-8 text".into())]);
        assert!(lines(b"", 3).is_empty());
        // an endless line is refused after max + 2 bytes
        let mut endless = BoundedLines::new(std::io::BufReader::new(std::io::repeat(b'x')), 100);
        assert!(matches!(endless.next_line(), Some(Err(ReadError::LineTooLong { line: 1, limit: 100 }))));
        assert!(endless.next_line().is_none());
    }
}
