//! What `--out DIR` receives and `--json` prints: `runs.csv`, `summary.csv`, `summary.json` and
//! the two bar charts.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Serialize;

use super::args::{identify_config, master_seed, CampaignArgs};
use super::execute::RunResult;
use super::paper::{PaperRow, PAPER_TABLE_II};
use super::plan::MODES;
use super::summary::{Cell, CellKey};
use crate::plots;
use crate::schema::Document;
use crate::simulate::Noise;

/// The files `--out DIR` receives, checked before the first run and written together at the end.
pub const OUTPUT_FILES: [&str; 5] = ["runs.csv", "summary.csv", "summary.json", "error.svg", "time.svg"];

/// One summary cell in `summary.json`: its key and its means (the columns of `summary.csv`).
#[derive(Clone, Debug, Serialize)]
pub struct CellJson<'a> {
    /// `pso`, `ga` or `de`.
    pub algorithm: &'a str,
    /// A fault mode ([`MODES`]), `total` (the single-fault modes pooled), `multi` or `multi-low`.
    pub mode: &'a str,
    /// `low`, `high`, `multi` or `multi-low`.
    pub level: &'a str,
    /// The means.
    #[serde(flatten)]
    pub cell: &'a Cell,
}

/// `summary.json` and `ema campaign --json`: the settings, the cells and the paper's Table II.
#[derive(Clone, Debug, Serialize)]
pub struct SummaryJson<'a> {
    /// `--runs`.
    pub runs_per_cell: u32,
    /// `--profile`.
    pub profile: &'a str,
    /// `--max-iterations`.
    pub max_iterations: u32,
    /// The master seed (`--seed`, or [`AUDIT_SEED`](super::args::AUDIT_SEED) with `--audit`).
    pub seed: u64,
    /// `--noise`: whether the recordings carry sensor noise.
    pub noise: bool,
    /// `--flights`: recordings per run, identified together.
    pub flights: u32,
    /// False with `--paper-only`.
    pub model_selection_and_polish: bool,
    /// The fitness's fast-regime weight.
    pub fast_regime_weight: f32,
    /// One entry per (algorithm, mode, level), sorted.
    pub cells: Vec<CellJson<'a>>,
    /// [`PAPER_TABLE_II`].
    pub paper_table_ii: &'static [PaperRow],
}

/// The summary as a JSON document ([`SummaryJson`] in a [`Document`]).
pub fn summary_json(summary: &BTreeMap<CellKey, Cell>, args: &CampaignArgs) -> String {
    let cells =
        summary.iter().map(|((algorithm, mode, level), cell)| CellJson { algorithm, mode, level, cell }).collect();
    Document::new(
        None,
        SummaryJson {
            runs_per_cell: args.runs,
            profile: &args.profile,
            max_iterations: args.max_iterations,
            seed: master_seed(args),
            noise: args.noise == Noise::On,
            flights: args.flights,
            model_selection_and_polish: !args.paper_only,
            fast_regime_weight: identify_config(args).fast_regime_weight,
            cells,
            paper_table_ii: &PAPER_TABLE_II,
        },
    )
    .to_json()
}

/// `summary.csv`'s header: the keys of a [`CellJson`], in its order.
pub const SUMMARY_CSV_HEADER: &str = "algorithm,mode,level,runs,mean_err_percent,mean_identification_s,\
mean_evaluations,mean_floor_err_percent,coverage_2sigma,coverage_parameters,mean_err_percent_detectable,\
detectable_runs,bound_covers_truth_fraction,faults_not_found";

/// `summary.csv`: one row per (algorithm, mode, level), the columns of [`SUMMARY_CSV_HEADER`].
pub fn summary_csv(summary: &BTreeMap<CellKey, Cell>) -> String {
    let mut csv = format!("{SUMMARY_CSV_HEADER}\n");
    for ((alg, mode, level), c) in summary {
        let _ = writeln!(
            csv,
            "{alg},{mode},{level},{},{},{},{},{},{},{},{},{},{},{}",
            c.runs,
            c.mean_err_percent,
            c.mean_identification_s,
            c.mean_evaluations,
            c.mean_floor_err_percent,
            c.coverage_2sigma,
            c.coverage_parameters,
            c.mean_err_percent_detectable,
            c.detectable_runs,
            c.bound_covers_truth_fraction,
            c.faults_not_found
        );
    }
    csv
}

/// `runs.csv`: one row per run, units in the header.
pub fn runs_csv(results: &[RunResult]) -> String {
    let mut out = String::from("algorithm,mode,level,run,seed");
    for prefix in ["true", "est"] {
        for i in 1..=8 {
            let _ = write!(out, ",k{i}_{prefix}");
        }
    }
    out.push_str(",err_percent,identification_s,evaluations,floor_err_percent");
    for i in 1..=8 {
        let _ = write!(out, ",k{i}_sigma");
    }
    out.push_str(",coverage_counted,coverage_covered,bound_covers_truth,bound_at_or_below_truth,flights\n");
    for r in results {
        let p = &r.plan;
        let _ = write!(out, "{},{},{},{},{}", p.algorithm.name(), p.mode, p.level, p.run, p.seed);
        for k in p.truth.0.iter().chain(r.estimate.0.iter()) {
            let _ = write!(out, ",{k}");
        }
        let _ = write!(out, ",{},{},{},{}", r.err_percent, r.seconds, r.evaluations, r.floor_err_percent);
        for s in &r.sigma {
            let _ = write!(out, ",{s}");
        }
        let _ =
            writeln!(out, ",{},{},{},{},{}", r.coverage.0, r.coverage.1, r.bounds.covered, r.bounds.missed, p.flights);
    }
    out
}

/// Grouped bar chart (SVG, [`plots::grouped_bars`]): one group per fault mode, one bar per
/// (algorithm, level); the value axis reaches the largest value of any cell, totals and
/// multi-fault cells included.
pub fn bar_chart(
    title: &str,
    unit: &str,
    summary: &BTreeMap<CellKey, Cell>,
    value: fn(&Cell) -> f64,
) -> std::io::Result<String> {
    let series: Vec<(String, String)> = summary
        .keys()
        .filter(|(_, mode, level)| mode != "total" && !level.starts_with("multi"))
        .map(|(a, _, l)| (a.clone(), l.clone()))
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    let names: Vec<String> = series.iter().map(|(alg, level)| format!("{alg} {level}")).collect();
    let max = summary.values().map(value).fold(0.0f64, f64::max).max(1e-9);
    plots::grouped_bars(title, unit, &MODES, &names, max, |g, s| {
        let (alg, level) = &series[s];
        summary.get(&(alg.clone(), MODES[g].to_string(), level.clone())).map(value)
    })
}
