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
//!    (`--column KEY=HEADER`), extra columns ignored, an optional temperature column, the
//!    delimiter detected (comma, semicolon, tab) or given (`--delimiter`), a UTF-8 BOM, `#`
//!    comment lines and blank lines accepted;
//! 2. [`grid`]: the time base — a mean sample rate from 5 to 100 kHz, timestamps within
//!    [`grid::JITTER_TOLERANCE_S`] of the uniform grid;
//! 3. [`align`]: where the manoeuvre starts in the file (least squares of the recorded command
//!    against the profile, or `--start SECONDS`), and the command check;
//! 4. [`resample`]: the channels on the monitor's 10 kHz grid from that start, band-limited (the
//!    temperature, a slow quantity, linearly interpolated);
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
//!
//! [`data`] holds the recording itself ([`Recording`]) and the bounds; [`error`] what is wrong
//! with a file. Every file here uses the others by their own paths (`super::data::…`), never
//! through this module, so they form no import cycle.

pub mod align;
pub mod args;
pub mod data;
pub mod error;
pub mod grid;
pub mod read;
pub mod resample;
pub mod sidecar;
pub mod write;

pub use args::{LoadSummary, Loaded, RecordingArgs};
pub use data::{
    Recording, HEADER, KEYS, MAX_COMMENT_LINES, MAX_DURATION_S, MAX_FILE_BYTES, MAX_LINE_BYTES, MAX_ROWS,
    MAX_TEMPERATURE_C, MIN_ROWS, MIN_TEMPERATURE_C, TEMPERATURE_HEADER, TEMPERATURE_KEY,
};
pub use error::{MissingColumn, RecordingError, RecordingErrorKind};
pub use read::{parse_recording, parse_recording_with, read_recording, Columns, ReadOptions};
pub use write::{write_csv, write_recording};
