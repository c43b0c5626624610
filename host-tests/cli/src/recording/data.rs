//! The recording in memory: its six channels as columns, the optional temperature column, the
//! line of each row in its file, and the bounds every recording file is read within.

/// Default column names, in the order of [`KEYS`].
pub const HEADER: [&str; 6] = ["time_s", "command_rad", "position_rad", "ia_A", "ib_A", "ic_A"];
/// The keys of `--column KEY=HEADER`, in the order of [`HEADER`].
pub const KEYS: [&str; 6] = ["time", "command", "position", "ia", "ib", "ic"];
/// The key of the optional temperature column in `--column KEY=HEADER`.
pub const TEMPERATURE_KEY: &str = "temperature";
/// Default header of the optional temperature column (the actuator's temperature, °C).
pub const TEMPERATURE_HEADER: &str = "temperature_C";
/// Lowest temperature a recording may hold, °C: the lower bound of the parameter table's declared
/// operating range (`temperature_min_c` in [`ema_monitor::params::FIELDS`]).
pub const MIN_TEMPERATURE_C: f64 = -100.0;
/// Highest temperature a recording may hold, °C: the upper bound of that range.
pub const MAX_TEMPERATURE_C: f64 = 200.0;
/// Fewest data rows a recording may have (a time step needs two).
pub const MIN_ROWS: usize = 2;
/// Longest line, in bytes (a row in shortest round-trip form takes at most about 150).
pub const MAX_LINE_BYTES: usize = 4096;
/// Most comment lines.
pub const MAX_COMMENT_LINES: usize = 1000;
/// Largest file, in bytes: [`MAX_ROWS`] rows of six numbers in a bench's usual precision.
pub const MAX_FILE_BYTES: usize = 128 * 1024 * 1024;
/// Longest time span of a recording, first to last row: the longest profile the reference model
/// simulates ([`ema_reference::MAX_DURATION_S`]).
pub const MAX_DURATION_S: f64 = ema_reference::MAX_DURATION_S;
/// Most data rows: 10 s at the highest accepted rate (100 kHz), [`MAX_DURATION_S`] at 10 kHz
/// with room to spare.
pub const MAX_ROWS: usize = 1_000_000;

/// Lowest sample rate accepted: half the monitor's 10 kHz. Below it the recording lacks the
/// 1.25–2.5 kHz band that the monitor's 0.4 ms block means still resolve.
pub const MIN_RATE_HZ: f64 = 5_000.0;
/// Highest sample rate accepted: ten times the monitor's rate, which bounds the anti-aliasing
/// filter's length in input samples ([`super::resample`]) and the file's rows per second.
pub const MAX_RATE_HZ: f64 = 100_000.0;
/// Relative margin on the rate range, for the rounding of a nominal rate's timestamps.
pub const RATE_MARGIN: f64 = 1e-3;
/// Largest relative difference of a step from the median step (a missing row doubles a step).
pub const STEP_TOLERANCE: f64 = 0.25;
/// Largest distance of a timestamp from the fitted grid: 2 µs, twice the ±1 µs (1 % of the
/// monitor's 100 µs period) of a jittered logging clock, the factor two a margin for the fitted
/// line's own error and the extreme values of the jitter. A sample taken within it of its grid
/// time moves the 0.4 ms block means the monitor fits by well under 1 % of a block.
pub const JITTER_TOLERANCE_S: f64 = 2e-6;

/// Rows before the manoeuvre kept for the sensors' zero points: twice the core's
/// `REST_BLOCK_FRAMES`, all its estimate can use.
pub const MAX_REST_ROWS: usize = 2 * ema_monitor::acquisition::REST_BLOCK_FRAMES as usize;

/// A recording as columns of equal length: as read from a file (any accepted rate), or on the
/// monitor's 10 kHz grid once [`RecordingArgs::load`](super::args::RecordingArgs::load) has aligned and resampled it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recording {
    /// Comment lines (`#` lines of files written before the sidecar; without the `#` and one space).
    pub comments: Vec<String>,
    /// Sample times.
    pub time_s: Vec<f64>,
    /// Commanded surface position.
    pub command_rad: Vec<f64>,
    /// Measured surface position.
    pub position_rad: Vec<f64>,
    /// Measured phase current a.
    pub ia_a: Vec<f64>,
    /// Measured phase current b.
    pub ib_a: Vec<f64>,
    /// Measured phase current c.
    pub ic_a: Vec<f64>,
    /// Line of each row in its file (1-based), for messages that name the line.
    pub row_line: Vec<usize>,
    /// The phase currents `[ia, ib, ic]` of the file's rows before the manoeuvre's start (at the
    /// file's rate, at most the last [`MAX_REST_ROWS`]): the pre-trigger, with the actuator at
    /// rest, on which the core measures the sensors' zero points. Empty when the manoeuvre starts
    /// at the first row.
    pub rest_currents_a: Vec<[f64; 3]>,
    /// The actuator's temperature at each row (°C, within [`MIN_TEMPERATURE_C`] and
    /// [`MAX_TEMPERATURE_C`]), when the file has a temperature column.
    pub temperature_c: Option<Vec<f64>>,
}

impl Recording {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// The file line of row `k` (its index + 1 when the recording was not read from a file).
    pub fn line_of(&self, k: usize) -> usize {
        self.row_line.get(k).copied().unwrap_or(k + 1)
    }

    /// `true` without rows.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// Sample period (mean step), 0 with fewer than two rows.
    pub fn sample_period_s(&self) -> f64 {
        match (self.time_s.first(), self.time_s.last()) {
            (Some(a), Some(b)) if self.len() > 1 => (b - a) / (self.len() - 1) as f64,
            _ => 0.0,
        }
    }

    /// The recorded channels of a reference-model run.
    pub fn from_reference(r: &ema_reference::Recording, comments: Vec<String>) -> Self {
        let comments_len = comments.len();
        let col = |f: &dyn Fn(&ema_reference::Sample) -> f64| r.samples.iter().map(f).collect::<Vec<f64>>();
        Self {
            time_s: col(&|s| s.time_s),
            command_rad: col(&|s| s.command_rad),
            position_rad: col(&|s| s.position_rad),
            ia_a: col(&|s| s.phase_current_a[0]),
            ib_a: col(&|s| s.phase_current_a[1]),
            ic_a: col(&|s| s.phase_current_a[2]),
            // as `write_csv` lays the file out: comments, header, then one line per row
            row_line: (0..r.samples.len()).map(|k| comments_len + 2 + k).collect(),
            comments,
            rest_currents_a: Vec::new(),
            temperature_c: None,
        }
    }

    /// The mean of the temperature column (°C); `None` without one (or without rows).
    pub fn mean_temperature_c(&self) -> Option<f64> {
        let t = self.temperature_c.as_ref().filter(|t| !t.is_empty())?;
        Some(t.iter().sum::<f64>() / t.len() as f64)
    }

    /// The six channels in the order of [`HEADER`].
    pub fn columns(&self) -> [&Vec<f64>; 6] {
        [&self.time_s, &self.command_rad, &self.position_rad, &self.ia_a, &self.ib_a, &self.ic_a]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_temperature_range_is_the_parameter_tables() {
        for name in ["temperature_min_c", "temperature_max_c"] {
            let field = ema_monitor::params::ParamField::find(name).expect("a field");
            assert_eq!((f64::from(field.min), f64::from(field.max)), (MIN_TEMPERATURE_C, MAX_TEMPERATURE_C), "{name}");
        }
    }
}
