//! # ema-cli: the host command line of ema-monitor (`ema`)
//!
//! One module per subcommand (`simulate`, …) on top of the host runtime ([`runtime`]: the core's
//! own acquisition and identification run over recordings and packed traces), plus the shared
//! recording reader/writer ([`recording`]), profile files ([`profile_file`]), the bounded reading
//! of every input file ([`input`]), the plots ([`plots`], plotters' SVG backend), the JSON
//! envelope ([`schema`]), the progress bars ([`progress`]), the error type ([`error`]) and the
//! exit statuses ([`exit`]). No
//! file imports itself back through another (no import cycle). Every input file is read within a
//! stated size, so no file drives an allocation. Every output file goes
//! through [`output`]: checked before the work (and after the inputs), an existing regular file
//! replaced only with `--force` and no other node ever (a symlink, FIFO or device), written to a
//! temporary file and renamed into place.
//! The binary (`src/main.rs`) parses the command line with clap and prints every error as a
//! single `error: …` line on stderr; its exit status is the contract of [`exit`] (2 for a usage or
//! input error, 1 when writing failed, 3 and 4 for a report that is no diagnosis).
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod campaign;
pub mod commission;
pub mod compare;
pub mod detectability;
pub mod discover;
pub mod error;
pub mod exit;
pub mod firmware_trace;
pub mod fleet;
pub mod flights;
pub mod history;
pub mod identify;
pub mod input;
pub mod output;
pub mod params;
pub mod parity_traces;
pub mod plots;
pub mod pod;
pub mod pooled;
pub mod profile_file;
pub mod progress;
pub mod recording;
pub mod runtime;
pub mod schema;
pub mod sensors_file;
pub mod simulate;
pub mod tolerances_file;
pub mod unit_draw;

/// Actuator parameter files (`--params`, `ema params`): the crate `ema-params-file`, which the
/// firmware's build script uses too for `EMA_PARAMS`.
pub use ema_params_file as params_file;
