//! The flags of `ema campaign` and what they fix for every run: the master seed of the draws
//! and the identification settings.

use clap::Args;
use ema_monitor::diagnosis::IdentifyConfig;
use ema_monitor::fitness::MAX_POOLED_RECORDINGS;

use crate::identify::args::{method_flags, AlgorithmArg};
use crate::output::OutputArgs;
use crate::params::ParamsArgs;
use crate::progress::ProgressArgs;
use crate::simulate::Noise;

/// Master seed of `--audit`: no test and no committed campaign draws with it.
pub const AUDIT_SEED: u64 = 0x00A0_D17C_A3BA_1601;

/// Arguments of `ema campaign`.
#[derive(Args, Debug, Clone)]
#[command(mut_arg("out", |a| a.value_name("DIR").help("Write runs.csv, summary.csv, summary.json, \
    error.svg and time.svg here (created if needed; checked before the first run)")))]
pub struct CampaignArgs {
    /// Runs per fault mode, level and algorithm (the paper: 10).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..))]
    pub runs: u32,
    /// Algorithms, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "pso,ga")]
    pub algorithms: Vec<AlgorithmArg>,
    /// Extra multi-fault runs (2–3 simultaneous faults) per algorithm, reported separately.
    #[arg(long, default_value_t = 0)]
    pub multi: u32,
    /// Extra multi-fault runs with every fault mode at once at low severity (0.05–0.15) per
    /// algorithm, reported separately (`multi-low`).
    #[arg(long, default_value_t = 0)]
    pub multi_low: u32,
    /// Sensor noise of the reference model's recordings (`off`: the paper's conditions; the
    /// monitor then identifies with its sensor noise set to 0, as for sensors calibrated noiseless).
    #[arg(long, value_enum, default_value_t = Noise::On)]
    pub noise: Noise,
    /// Recordings per run (flights of the same actuator with the same fault vector), identified
    /// together by the pooled identification; 1 is the paper's protocol.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=MAX_POOLED_RECORDINGS as i64))]
    pub flights: u32,
    /// Iteration limit of each identification (the paper: 200).
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..))]
    pub max_iterations: u32,
    /// The paper's method alone: its fitness (fast-regime weight 1), the global search, no model
    /// selection, no polish.
    #[arg(long)]
    pub paper_only: bool,
    /// Weight of the fast-regime samples (step and reversal transients) in the fitness, in (0, 1]
    /// [default: the monitor's, 0.1; 1 with --paper-only].
    #[arg(long, value_name = "RHO")]
    pub fast_regime_weight: Option<f32>,
    /// Command profile of every run (the manoeuvre the reference model flies and the monitor
    /// model is driven by): `standard`, `pbit` or a profile file (`ema simulate --help` has the
    /// format).
    #[arg(long, value_name = "NAME|FILE", default_value = "standard")]
    pub profile: String,
    /// Master seed of every draw.
    #[arg(long, default_value_t = 2018)]
    pub seed: u64,
    /// Audit draws: the master seed is `AUDIT_SEED`, which no test uses (replaces `--seed`).
    #[arg(long, conflicts_with = "seed")]
    pub audit: bool,
    /// Worker threads (default: the available cores). The results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Only these modes (comma-separated), e.g. for a quick look.
    #[arg(long, value_delimiter = ',')]
    pub modes: Vec<String>,
    /// Print the summary as JSON instead of the Markdown table.
    #[arg(long)]
    pub json: bool,
    /// `--out DIR` and `--force`.
    #[command(flatten)]
    pub output: OutputArgs,
    /// `--quiet`.
    #[command(flatten)]
    pub progress: ProgressArgs,
    /// The actuator's parameters: the reference model simulates it, the monitor model identifies it.
    #[command(flatten)]
    pub params: ParamsArgs,
}

/// The master seed of the draws: [`AUDIT_SEED`] with `--audit`, else `--seed`.
pub fn master_seed(args: &CampaignArgs) -> u64 {
    if args.audit {
        AUDIT_SEED
    } else {
        args.seed
    }
}

/// The identification settings of `ema campaign`'s flags (algorithm and seed are per run).
pub fn identify_config(args: &CampaignArgs) -> IdentifyConfig {
    let base = IdentifyConfig { max_iterations: args.max_iterations, ..IdentifyConfig::default() };
    method_flags(base, args.paper_only, args.fast_regime_weight)
}
