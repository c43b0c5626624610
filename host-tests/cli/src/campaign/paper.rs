//! The paper's Table II (Dalla Vedova, Berri, Re, ICSRS 2018), printed beside the campaign's.

use serde::Serialize;

/// One row of the paper's Table II.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PaperRow {
    /// `pso` or `ga` (the paper has no DE).
    pub algorithm: &'static str,
    /// `low` or `high`.
    pub level: &'static str,
    /// Mean Err% per mode, in [`MODES`](super::plan::MODES) order.
    pub err_percent: [f64; 5],
    /// The row's total Err%.
    pub total_err_percent: f64,
    /// Mean identification time per mode (s).
    pub identification_s: [f64; 5],
}

const fn row(algorithm: &'static str, level: &'static str, err: [f64; 5], total: f64, seconds: [f64; 5]) -> PaperRow {
    PaperRow { algorithm, level, err_percent: err, total_err_percent: total, identification_s: seconds }
}

/// The paper's Table II. Source: Dalla Vedova, Berri, Re, ICSRS 2018, Table II (Matlab r2016a,
/// Core i5-6200U, 2 cores).
pub const PAPER_TABLE_II: [PaperRow; 4] = [
    row("ga", "low", [2.093, 1.678, 5.042, 3.323, 1.928], 2.813, [2633.0, 2336.0, 1644.0, 2502.0, 2492.0]),
    row("ga", "high", [4.491, 2.247, 6.253, 1.778, 0.950], 3.144, [2501.0, 2524.0, 2559.0, 2453.0, 2527.0]),
    row("pso", "low", [0.930, 0.294, 0.863, 1.013, 0.452], 0.711, [1662.0, 1242.0, 2152.0, 2099.0, 1395.0]),
    row("pso", "high", [2.773, 1.629, 2.734, 1.465, 0.205], 1.761, [1875.0, 1634.0, 1474.0, 1506.0, 1078.0]),
];
