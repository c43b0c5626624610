//! The flags of `ema history`.

use std::path::PathBuf;

use clap::Args;

use crate::exit::FailOn;
use crate::output::OutputArgs;
use crate::params::ParamsArgs;
use crate::progress::ProgressArgs;
use crate::recording::RecordingArgs;

/// Arguments of `ema history`.
#[derive(Args, Debug, Clone)]
#[command(mut_arg("out", |a| a.value_name("DIR").help("Write history.json and severity.svg here \
    (created if needed, once every recording is checked; checked before the first flight)")))]
pub struct HistoryArgs {
    /// Recordings of successive flights of one actuator, oldest first.
    #[arg(required_unless_present = "simulate", conflicts_with = "simulate")]
    pub files: Vec<PathBuf>,
    /// Degradation laws `MODE=START[+RATE][@ONSET]` (repeatable): simulate the flights with the
    /// reference model instead of reading files.
    #[arg(long, value_name = "LAW", num_args = 1..)]
    pub simulate: Vec<String>,
    /// Flights simulated under --simulate.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=200))]
    pub flights: u32,
    /// Master seed of the simulated flights' sensor noise and of the optimizer.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Command profile the recordings were made with (and the simulated flights fly).
    #[arg(long, default_value = "standard")]
    pub profile: String,
    /// Print JSON instead of the tables.
    #[arg(long)]
    pub json: bool,
    /// Exit with status 5 when the last flight's diagnosis is at or above LEVEL (`degraded`:
    /// DEGRADED or FAILING; `failing`: FAILING), for a CI pipeline (docs/cli.md).
    #[arg(long, value_enum, value_name = "LEVEL", conflicts_with = "simulate")]
    pub fail_on: Option<FailOn>,
    /// How to read the recordings.
    #[command(flatten)]
    pub recording: RecordingArgs,
    /// `--out DIR` and `--force`.
    #[command(flatten)]
    pub output: OutputArgs,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
    /// The actuator's parameters.
    #[command(flatten)]
    pub params: ParamsArgs,
}
