//! The campaign's results grouped into cells of (algorithm, mode, level) and their means.

use std::collections::BTreeMap;

use serde::Serialize;

use super::execute::RunResult;

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
}

/// `(algorithm, mode, level)` of a summary cell.
pub type CellKey = (String, String, String);

/// Running sums of a cell: runs, Err%, seconds, evaluations, floor Err%, coverage counted and
/// covered.
type CellSums = (usize, f64, f64, f64, f64, u32, u32);

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
            e.0 += 1;
            e.1 += r.err_percent;
            e.2 += r.seconds;
            e.3 += f64::from(r.evaluations);
            e.4 += r.floor_err_percent;
            e.5 += r.coverage.0;
            e.6 += r.coverage.1;
        }
    }
    sums.into_iter()
        .map(|(k, (n, err, s, ev, floor, counted, covered))| {
            let n_f = n as f64;
            let cell = Cell {
                runs: n,
                mean_err_percent: err / n_f,
                mean_identification_s: s / n_f,
                mean_evaluations: ev / n_f,
                mean_floor_err_percent: floor / n_f,
                coverage_2sigma: if counted == 0 { f64::NAN } else { f64::from(covered) / f64::from(counted) },
                coverage_parameters: counted,
            };
            (k, cell)
        })
        .collect()
}
