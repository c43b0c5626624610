//! The campaign's results grouped into cells of (algorithm, mode, level) and their means.

use std::collections::BTreeMap;

use serde::Serialize;

use super::execute::RunResult;
use super::scoring::BoundsVsTruth;

/// Mean error and time per (algorithm, mode, level).
#[derive(Clone, Debug, Default, Serialize)]
pub struct Cell {
    /// Runs in the cell.
    pub runs: usize,
    /// Mean Err%.
    pub mean_err_percent: f64,
    /// Mean identification time (s).
    pub mean_identification_s: f64,
    /// Mean evaluations.
    pub mean_evaluations: f64,
    /// Mean Err% of the detectability floor ([`detectability_floor`](super::scoring::detectability_floor)).
    pub mean_floor_err_percent: f64,
    /// Share of the true values within ±2σ of the estimate
    /// ([`coverage`](super::scoring::coverage); NaN, `null` in JSON, when no parameter was
    /// counted).
    pub coverage_2sigma: f64,
    /// Parameters counted for `coverage_2sigma`.
    pub coverage_parameters: u32,
    /// Mean Err% over the runs whose faults all lie at or above the recording's smallest
    /// detectable severity ([`BoundsVsTruth::detectable`]; NaN, `null` in JSON, when none does).
    pub mean_err_percent_detectable: f64,
    /// Runs counted for `mean_err_percent_detectable`.
    pub detectable_runs: usize,
    /// Share of the faulted modes reported not found whose "not detectable below" bound lies
    /// above the truth ([`BoundsVsTruth`]; NaN, `null` in JSON, when no faulted mode was
    /// reported not found).
    pub bound_covers_truth_fraction: f64,
    /// Faulted modes reported not found, counted for `bound_covers_truth_fraction`.
    pub faults_not_found: u32,
}

/// `(algorithm, mode, level)` of a summary cell.
pub type CellKey = (String, String, String);

/// Running sums of a cell.
#[derive(Default)]
struct CellSums {
    runs: usize,
    err: f64,
    seconds: f64,
    evaluations: f64,
    floor_err: f64,
    counted: u32,
    covered: u32,
    detectable_runs: usize,
    detectable_err: f64,
    bounds: BoundsVsTruth,
}

/// Groups results by `(algorithm, mode, level)` (mode `total` pools the single-fault modes).
pub fn summarize(results: &[RunResult]) -> BTreeMap<CellKey, Cell> {
    let mut sums: BTreeMap<CellKey, CellSums> = BTreeMap::new();
    for r in results {
        let alg = r.plan.algorithm.name().to_string();
        let mut keys = vec![(alg.clone(), r.plan.mode.clone(), r.plan.level.to_string())];
        match r.plan.level {
            "multi" | "multi-low" => keys = vec![(alg.clone(), r.plan.level.to_string(), r.plan.level.to_string())],
            level => keys.push((alg.clone(), "total".to_string(), level.to_string())),
        }
        for key in keys {
            let e = sums.entry(key).or_default();
            e.runs += 1;
            e.err += r.err_percent;
            e.seconds += r.seconds;
            e.evaluations += f64::from(r.evaluations);
            e.floor_err += r.floor_err_percent;
            e.counted += r.coverage.0;
            e.covered += r.coverage.1;
            if r.bounds.detectable() {
                e.detectable_runs += 1;
                e.detectable_err += r.err_percent;
            }
            e.bounds.covered += r.bounds.covered;
            e.bounds.missed += r.bounds.missed;
        }
    }
    sums.into_iter()
        .map(|(k, e)| {
            let n_f = e.runs as f64;
            let not_found = e.bounds.covered + e.bounds.missed;
            let cell = Cell {
                runs: e.runs,
                mean_err_percent: e.err / n_f,
                mean_identification_s: e.seconds / n_f,
                mean_evaluations: e.evaluations / n_f,
                mean_floor_err_percent: e.floor_err / n_f,
                coverage_2sigma: ratio(f64::from(e.covered), f64::from(e.counted)),
                coverage_parameters: e.counted,
                mean_err_percent_detectable: ratio(e.detectable_err, e.detectable_runs as f64),
                detectable_runs: e.detectable_runs,
                bound_covers_truth_fraction: ratio(f64::from(e.bounds.covered), f64::from(not_found)),
                faults_not_found: not_found,
            };
            (k, cell)
        })
        .collect()
}

/// `num / den`, NaN when `den` is 0.
fn ratio(num: f64, den: f64) -> f64 {
    if den == 0.0 {
        f64::NAN
    } else {
        num / den
    }
}
