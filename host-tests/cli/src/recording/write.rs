//! Writing a recording: a plain CSV, header and rows, that pandas, polars and a spreadsheet load
//! with their default options; its metadata goes beside it ([`super::sidecar`]).

use std::io::Write;
use std::path::Path;

use super::data::{Recording, HEADER, TEMPERATURE_HEADER};
use crate::error::CliError;
use crate::output::{self, Overwrite};

/// Writes a recording (header, then rows in shortest round-trip form) through
/// [`output::write_with`]: to a temporary file renamed into place once complete, so a failed
/// write never leaves a truncated recording; an existing file is replaced only with
/// [`Overwrite::Replace`].
pub fn write_recording(path: impl AsRef<Path>, rec: &Recording, overwrite: Overwrite) -> Result<(), CliError> {
    output::write_with(path.as_ref(), overwrite, |mut w| write_csv(&mut w, rec))
}

/// Writes a recording as CSV to any writer: the header [`HEADER`] (and [`TEMPERATURE_HEADER`] last
/// when the recording has a temperature), then one row per sample, numbers in Rust's shortest
/// round-trip form (a read gives back exactly the values written).
/// The `#` comment lines of a recording read from an older file are written first, so such a
/// file writes back as it was; `ema simulate` writes none (its metadata is in the sidecar).
pub fn write_csv(w: &mut impl Write, rec: &Recording) -> std::io::Result<()> {
    for c in &rec.comments {
        writeln!(w, "# {c}")?;
    }
    let temperature = rec.temperature_c.as_deref();
    match temperature {
        Some(_) => writeln!(w, "{},{TEMPERATURE_HEADER}", HEADER.join(","))?,
        None => writeln!(w, "{}", HEADER.join(","))?,
    }
    for k in 0..rec.len() {
        write!(
            w,
            "{},{},{},{},{},{}",
            rec.time_s[k], rec.command_rad[k], rec.position_rad[k], rec.ia_a[k], rec.ib_a[k], rec.ic_a[k]
        )?;
        match temperature.and_then(|t| t.get(k)) {
            Some(t) => writeln!(w, ",{t}")?,
            None => writeln!(w)?,
        }
    }
    Ok(())
}

/// The CSV of [`write_csv`] in memory.
pub fn csv_bytes(rec: &Recording) -> Vec<u8> {
    let mut bytes = Vec::new();
    write_csv(&mut bytes, rec).expect("writing to memory does not fail");
    bytes
}
