//! The host runtime: the `no_std` core's on-board path, run on the host over recordings and
//! packed traces, for every subcommand that identifies (`ema identify`, `campaign`, `history`,
//! `discover`, `compare`, `detectability`, the flights and the investigations).
//!
//! - [`source`]: a recording as the core's [`PhaseCurrents`](ema_monitor::acquisition::PhaseCurrents)
//!   source, read by the core's own [`acquire`](ema_monitor::diagnosis::acquire) into the measured
//!   trace (the frame checks and the hold-last-good-frame rule are the firmware's code);
//! - [`recording`]: the checks a recording passes before it drives the monitor model (rate,
//!   command), then its acquisition into a host-sized window ([`HOST_WINDOW`]);
//! - [`command`]: what drives the monitor model (a profile or the recording's command column);
//! - [`identification`]: the core's identification run to its end (the PSO sweeps in parallel,
//!   bit for bit the firmware's), on one trace or pooled over several;
//! - [`flight`]: the core's flight API ([`HealthMonitor`](ema_monitor::flight::HealthMonitor)) on
//!   the host: a recording acquired as a flight, the identification's sweeps in parallel;
//! - [`firmware`]: the firmware's path on a packed trace, its flights and their one-line
//!   summaries, which `scripts/parity` compares with the firmware's in QEMU;
//! - [`model_config`]: model configuration files (`--model-config`), read by the core's parser;
//! - [`temperature`]: the parameters the monitor model takes for a recording at its temperature
//!   (every command applies them once, right after reading its recordings);
//! - [`unit_check`]: whether an ordinary unit within its tolerances explains a diagnosis.
//!
//! Each file uses the others by their own paths (`super::source::…`), never through this module,
//! so the runtime's files form no import cycle.

pub mod command;
pub mod firmware;
pub mod flight;
pub mod identification;
pub mod model_config;
pub mod position_check;
pub mod recording;
pub mod source;
pub mod temperature;
pub mod unit_check;

pub use command::{CommandArg, CommandJson, ModelCommand, HOST_COMMAND_SAMPLES};
pub use firmware::{firmware_trace_outcome, firmware_trace_outcome_for, summary_line, Refusal};
pub use identification::{identify_pooled, identify_recording, identify_trace, run_to_end, Outcome, WarmStart};
pub use recording::{condition_recording, condition_recording_checked};
pub use source::HOST_WINDOW;
pub use temperature::{model_params, pooled_model_params, ModelParams, POOLED_TEMPERATURE_SPREAD_K};
