//! The time base of a recording: a uniform grid `t_i = origin + i · period` fitted to its
//! timestamps.
//!
//! A bench logs its samples on a uniform clock, but the timestamps it writes may carry the
//! jitter of a software clock or of rounding. The reader takes the samples as uniform, on the
//! least-squares line through the timestamps (`period` = its slope, the mean period), and refuses:
//! - a step farther than [`STEP_TOLERANCE`] from the median step: a missing or repeated row, which
//!   no grid can absorb (the line of the step named);
//! - a mean rate outside [`MIN_RATE_HZ`]..=[`MAX_RATE_HZ`] (the message says which way to change it);
//! - a timestamp farther than [`JITTER_TOLERANCE_S`] from the grid (its line named).

use std::path::Path;

use super::data::Recording;
use super::error::{RecordingError, RecordingErrorKind};

/// The rate and timing bounds, with the other bounds of a recording file in [`super::data`].
pub use super::data::{JITTER_TOLERANCE_S, MAX_RATE_HZ, MIN_RATE_HZ, RATE_MARGIN, STEP_TOLERANCE};

/// A uniform time grid: sample `i` at `origin_s + i · period_s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Time of sample 0 on the grid.
    pub origin_s: f64,
    /// The mean sample period.
    pub period_s: f64,
}

impl Grid {
    /// Mean sample rate.
    pub fn rate_hz(&self) -> f64 {
        1.0 / self.period_s
    }

    /// Grid time of sample `i`.
    pub fn time_s(&self, i: usize) -> f64 {
        self.origin_s + i as f64 * self.period_s
    }
}

/// The least-squares grid of `rec`'s timestamps, checked as the module says; `header` and
/// `column` name the time column in errors.
pub fn check(rec: &Recording, path: &Path, header: &str, column: usize) -> Result<Grid, RecordingError> {
    let err = |line: Option<usize>, kind| RecordingError {
        line,
        field: Some(header.to_owned()),
        column: Some(column),
        ..RecordingError::file(path, kind)
    };
    let t = &rec.time_s;
    let n = t.len();
    if n < 2 {
        return Err(RecordingError::file(path, RecordingErrorKind::TooFewRows(n)));
    }
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let median = steps[(steps.len() - 1) / 2];
    for k in 1..n {
        let step = t[k] - t[k - 1];
        if (step - median).abs() > STEP_TOLERANCE * median {
            let kind = RecordingErrorKind::TimeNotUniform { step, expected: median };
            return Err(err(rec.row_line.get(k).copied(), kind));
        }
    }
    // least squares over (i, t_i), centred: slope = Σ(i − ī)(t_i − t̄) / Σ(i − ī)²
    let i_mean = (n - 1) as f64 / 2.0;
    let t_mean = t.iter().sum::<f64>() / n as f64;
    let sxx = n as f64 * ((n * n - 1) as f64) / 12.0;
    let sxy: f64 = t.iter().enumerate().map(|(i, &ti)| (i as f64 - i_mean) * (ti - t_mean)).sum();
    let period_s = sxy / sxx;
    let grid = Grid { origin_s: t_mean - i_mean * period_s, period_s };
    let rate_hz = grid.rate_hz();
    if !(MIN_RATE_HZ * (1.0 - RATE_MARGIN)..=MAX_RATE_HZ * (1.0 + RATE_MARGIN)).contains(&rate_hz) {
        return Err(err(None, RecordingErrorKind::Rate { rate_hz }));
    }
    for (i, &ti) in t.iter().enumerate() {
        let deviation_s = (ti - grid.time_s(i)).abs();
        if deviation_s > JITTER_TOLERANCE_S {
            return Err(err(rec.row_line.get(i).copied(), RecordingErrorKind::Jitter { deviation_s, period_s }));
        }
    }
    Ok(grid)
}
