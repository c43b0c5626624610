//! The Markdown table `ema campaign` prints: ours beside the paper's Table II (with the mean Err%
//! over the detectable runs and how the "not detectable below" bounds read against the truth),
//! the detectability floor, the multi-fault rows and the ±2σ coverage.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use super::args::{identify_config, master_seed, CampaignArgs};
use super::paper::PAPER_TABLE_II;
use super::plan::MODES;
use super::summary::{Cell, CellKey};
use crate::simulate::Noise;

/// Order of the algorithms in the table: the paper's two, then differential evolution (not in the paper).
const ALGORITHM_ORDER: [&str; 3] = ["pso", "ga", "de"];

/// The Markdown report of `summary` under the flags `args`: our Err% and time per cell beside the
/// paper's Table II, the detectability floor, the multi-fault rows, the ±2σ coverage and the
/// settings.
pub fn table(summary: &BTreeMap<CellKey, Cell>, args: &CampaignArgs) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| algorithm | level | {} | total | detectable | bound covers truth | mean time (s) | paper total | paper time (s) |",
        MODES.join(" | ")
    );
    let _ = writeln!(out, "|{}", "---|".repeat(MODES.len() + 8));
    // The paper has no DE rows: its columns show "–" there.
    let order = ALGORITHM_ORDER.into_iter().flat_map(|a| ["low", "high"].map(move |l| (a, l)));
    for (alg, level) in order {
        if !args.algorithms.iter().any(|a| a.name() == alg) {
            continue;
        }
        let paper = PAPER_TABLE_II.iter().find(|r| r.algorithm == alg && r.level == level);
        let cell = |mode: &str| summary.get(&(alg.to_string(), mode.to_string(), level.to_string()));
        let errs: Vec<String> =
            MODES.iter().map(|m| cell(m).map_or("–".into(), |c| format!("{:.2}", c.mean_err_percent))).collect();
        let total = cell("total");
        let _ = writeln!(
            out,
            "| {alg} | {level} | {} | {} | {} | {} | {} | {} | {} |",
            errs.join(" | "),
            total.map_or("–".into(), |c| format!("{:.2}", c.mean_err_percent)),
            total.map_or("–".into(), detectable),
            total.map_or("–".into(), covers),
            total.map_or("–".into(), |c| format!("{:.2}", c.mean_identification_s)),
            paper.map_or("–".into(), |p| format!("{:.3}", p.total_err_percent)),
            paper.map_or("–".into(), |p| format!("{:.0}", p.identification_s.iter().sum::<f64>() / 5.0)),
        );
    }
    let _ = writeln!(
        out,
        "\nDetectability floor: mean Err% of the truth without the faults model selection's criterion refuses even at the truth (`detectability_floor`)\n\n| algorithm | level | {} | total |",
        MODES.join(" | ")
    );
    let _ = writeln!(out, "|{}", "---|".repeat(MODES.len() + 3));
    let order = ALGORITHM_ORDER.into_iter().flat_map(|a| ["low", "high"].map(move |l| (a, l)));
    for (alg, level) in order {
        let cell = |mode: &str| summary.get(&(alg.to_string(), mode.to_string(), level.to_string()));
        let floor = |mode: &str| cell(mode).map_or("–".into(), |c| format!("{:.2}", c.mean_floor_err_percent));
        if cell("total").is_some() {
            let floors: Vec<String> = MODES.iter().map(|m| floor(m)).collect();
            let _ = writeln!(out, "| {alg} | {level} | {} | {} |", floors.join(" | "), floor("total"));
        }
    }
    for (level, what) in [("multi", "multi-fault"), ("multi-low", "small simultaneous faults (every mode low)")] {
        for alg in ALGORITHM_ORDER {
            if let Some(c) = summary.get(&(alg.to_string(), level.to_string(), level.to_string())) {
                let _ = writeln!(
                    out,
                    "\n{what} ({alg}): {} runs, mean Err% {:.2} (floor {:.2}; detectable {}; bound covers truth {}), mean time {:.2} s, ±2σ coverage {}",
                    c.runs,
                    c.mean_err_percent,
                    c.mean_floor_err_percent,
                    detectable(c),
                    covers(c),
                    c.mean_identification_s,
                    percent(c.coverage_2sigma)
                );
            }
        }
    }
    out.push_str(&coverage_table(summary));
    let _ = write!(
        out,
        "\nErr% by the paper's formula; ours: {} runs per cell, {} flight{} per run{}, reference model with sensor noise {}, profile {}, max {} iterations, {}, fast-regime weight {}, seed {}{}.",
        args.runs,
        args.flights,
        if args.flights == 1 { "" } else { "s" },
        if args.flights == 1 { "" } else { " (pooled identification)" },
        if args.noise == Noise::On { "on" } else { "off (monitor told: sensor noise 0)" },
        args.profile,
        args.max_iterations,
        if args.paper_only { "global search only" } else { "then model selection and polish" },
        identify_config(args).fast_regime_weight,
        master_seed(args),
        if args.audit { " (--audit)" } else { "" }
    );
    out
}

/// The cell's mean Err% over its detectable runs, with their count: `0.41 (9 runs)`.
fn detectable(c: &Cell) -> String {
    if c.detectable_runs == 0 {
        "– (0 runs)".into()
    } else {
        format!("{:.2} ({} runs)", c.mean_err_percent_detectable, c.detectable_runs)
    }
}

/// The share of the faults reported not found whose bound lies above the truth, with their
/// count: `100.0 % of 3`.
fn covers(c: &Cell) -> String {
    format!("{} of {}", percent(c.bound_covers_truth_fraction), c.faults_not_found)
}

/// A share as a percentage with one decimal (`–` for NaN).
fn percent(share: f64) -> String {
    if share.is_nan() {
        "–".into()
    } else {
        format!("{:.1} %", 100.0 * share)
    }
}

/// The ±2σ coverage of the true values per (algorithm, level) and mode, then over every run.
fn coverage_table(summary: &BTreeMap<CellKey, Cell>) -> String {
    let mut out = format!(
        "\n±2σ coverage: share of the true values within ±2σ of the estimate ([`coverage`], calibrated near 95 %)\n\n| algorithm | level | {} | total |\n|{}\n",
        MODES.join(" | "),
        "---|".repeat(MODES.len() + 3)
    );
    let (mut counted, mut covered) = (0u32, 0.0f64);
    for alg in ALGORITHM_ORDER {
        for level in ["low", "high", "multi"] {
            let cell = |mode: &str| summary.get(&(alg.to_string(), mode.to_string(), level.to_string()));
            let total = if level == "multi" { cell("multi") } else { cell("total") };
            let Some(total) = total else { continue };
            if !total.coverage_2sigma.is_nan() {
                counted += total.coverage_parameters;
                covered += total.coverage_2sigma * f64::from(total.coverage_parameters);
            }
            let modes: Vec<String> =
                MODES.iter().map(|m| cell(m).map_or("–".into(), |c| percent(c.coverage_2sigma))).collect();
            let _ = writeln!(out, "| {alg} | {level} | {} | {} |", modes.join(" | "), percent(total.coverage_2sigma));
        }
    }
    let overall = if counted == 0 { f64::NAN } else { covered / f64::from(counted) };
    let _ = writeln!(out, "\noverall ±2σ coverage: {} of {counted} parameters", percent(overall));
    out
}
