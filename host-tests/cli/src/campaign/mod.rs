//! `ema campaign`: the paper's Table II protocol with our reference model and the on-board core.
//!
//! Protocol (Dalla Vedova, Berri, Re, ICSRS 2018, §VII): 5 single-fault modes × {low, high} ×
//! `--runs` runs × algorithms. Each run draws a fault with a seeded generator, lets the reference
//! model record the manoeuvre (`--profile`: standard, pbit or a file) with sensor noise on
//! (`--noise off`: the paper's conditions, no sensor noise), identifies it with the `no_std` core
//! (the firmware's code, built for the host) and scores it with the paper's error
//! `Err% = 100·sqrt(Σ_{i≤6}(k_i − k̂_i)² + k̂6 (k7 − k̂7)² + (k8 − k̂8)²)`.
//!
//! Draws (all from `SplitMix64(seed ⊕ run-key)`, so a run does not depend on the thread count):
//! - low severity uniform in [0.05, 0.25], high in [0.70, 0.95] (the paper: k̂ ≤ 0.25, k̂ ≥ 0.7);
//! - short circuit: the phase uniformly among A, B, C; eccentricity: the phase k7 uniform in [0, 1);
//!   gain drift: `k8 = 0.5 ± severity/2`, the sign drawn;
//! - `--multi N`: N extra runs with 2 or 3 distinct modes at severities uniform in [0.05, 0.95];
//! - `--multi-low N`: N extra runs with every mode at once, each at a low severity uniform in
//!   [0.05, 0.15] (small simultaneous faults), reported as their own row (`multi-low`);
//! - `--audit`: the master seed is [`AUDIT_SEED`], which no test uses, so its draws are fault
//!   vectors the method was never tuned on;
//! - the sensor-noise seed of the reference model and the optimizer's seed come from the same draw;
//! - `--flights N`: each run records the same fault vector N times (same manoeuvre, the sensor
//!   noise of flight `f > 0` seeded by [`flight_seed`]) and identifies the N recordings together
//!   with the pooled fitness (`EquivalentCurrentFit::pooled_with`, as `ema identify A.csv B.csv …` does),
//!   so the cell measures what pooling evidence over flights buys.
//!
//! **Noise off.** `--noise off` is the paper's conditions: the recordings carry no sensor noise,
//! and the monitor is told so, as a user who calibrated the sensors as noiseless would: its
//! parameters' `current_noise_a` and `position_noise_rad` are 0 ([`monitor_params`]), so the
//! measured envelope, the verdict's noise model and the 1σ assume only the controller's
//! resolution jitter and the sensed hysteresis ripple that a noiseless recording still has.
//!
//! **Coverage.** Each report carries the 1σ of every parameter (`src/diagnosis/uncertainty.rs`);
//! a run counts how many of its true values lie within ±2σ of the estimate ([`coverage`]), and
//! each cell reports the share (near 95 % when the σ are calibrated).
//!
//! Outputs: a Markdown table with the paper's Table II beside ours; `--out DIR` writes `runs.csv`,
//! `summary.csv`, `summary.json`, `error.svg` and `time.svg` (grouped bars like the paper's
//! Figures 4–5; [`OUTPUT_FILES`]); `--json` prints the summary JSON. `--out DIR` is checked before
//! the first run (an existing file there is replaced only with `--force`) and its files are
//! written whole or not at all ([`crate::output`]).
//!
//! One concept per file: [`args`] (the flags, the master seed, the identification settings),
//! [`paper`] (the paper's Table II), [`mod@plan`] (the runs and their seeded draws), [`mod@execute`]
//! (simulating and identifying a run), [`scoring`] (coverage and the detectability floor),
//! [`summary`] (the cells), [`mod@table`] (the Markdown report) and [`files`] (the CSV, JSON and SVG
//! outputs).

pub mod args;
pub mod execute;
pub mod files;
pub mod paper;
pub mod plan;
pub mod scoring;
pub mod summary;
pub mod table;

use std::path::Path;

use crate::error::CliError;
use crate::identify::args::check_fast_regime_weight;
use crate::output::{prepare_dir, write_files};
use crate::simulate::{resolve_profile, Noise};

pub use args::{identify_config, master_seed, CampaignArgs, AUDIT_SEED};
pub use execute::{execute, monitor_params, run_all, RunResult};
pub use files::{
    bar_chart, runs_csv, summary_csv, summary_json, CellJson, SummaryJson, OUTPUT_FILES, SUMMARY_CSV_HEADER,
};
pub use paper::{PaperRow, PAPER_TABLE_II};
pub use plan::{flight_seed, plan, Plan, SplitMix, MODES};
pub use scoring::{bounds_vs_truth, coverage, detectability_floor, detectability_floor_pooled, BoundsVsTruth};
pub use summary::{summarize, Cell, CellKey};
pub use table::table;

/// Runs `ema campaign`.
pub fn run(args: &CampaignArgs) -> Result<String, CliError> {
    if args.algorithms.is_empty() {
        return Err(CliError::flag("--algorithms", "give at least one of pso, ga, de"));
    }
    check_fast_regime_weight(args.fast_regime_weight)?;
    let profile = resolve_profile(&args.profile)?;
    let params = args.params.load()?;
    let plans = plan(args)?;
    let threads = args.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if threads == 0 {
        return Err(CliError::flag("--threads", "must be at least 1"));
    }
    let overwrite = args.output.overwrite();
    if let Some(dir) = &args.output.out {
        prepare_dir(dir, &OUTPUT_FILES, overwrite)?;
    }
    let noise = args.noise == Noise::On;
    let results = run_all(&plans, &identify_config(args), &params, &profile, noise, threads, args.progress.visible())?;
    let summary = summarize(&results);
    if let Some(dir) = &args.output.out {
        let contents = [
            runs_csv(&results),
            summary_csv(&summary),
            summary_json(&summary, args),
            bar_chart("Mean identification error per fault mode", "Err (%)", &summary, |c| c.mean_err_percent)
                .map_err(|source| CliError::Io { path: dir.join("error.svg"), source })?,
            bar_chart("Mean identification time per fault mode", "identification time (s)", &summary, |c| {
                c.mean_identification_s
            })
            .map_err(|source| CliError::Io { path: dir.join("time.svg"), source })?,
        ];
        let paths = OUTPUT_FILES.map(|name| dir.join(name));
        let files: Vec<(&Path, &[u8])> =
            paths.iter().zip(&contents).map(|(p, c)| (p.as_path(), c.as_bytes())).collect();
        write_files(&files, overwrite)?;
    }
    Ok(if args.json { summary_json(&summary, args) } else { table(&summary, args) })
}
