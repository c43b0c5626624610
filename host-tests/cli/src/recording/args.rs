//! The flags of every command that reads a recording, and the pipeline from a file to the
//! monitor's 10 kHz recording of one manoeuvre.

use std::path::Path;

use clap::Args;
use ema_monitor::conditioning::DECIMATION;
use ema_monitor::{EmaParams, Profile};
use serde::Serialize;

use super::data::{Recording, MAX_REST_ROWS};
use super::error::{RecordingError, RecordingErrorKind};
use super::read::{read_file, Columns, ReadOptions};
use super::{align, resample};
use crate::error::{num, CliError};

/// How to read a recording file (flattened into `identify`, `discover` and
/// `firmware-trace --from`).
#[derive(Args, Debug, Clone, Default, PartialEq)]
pub struct RecordingArgs {
    /// The file's header of a channel, as KEY=HEADER (repeatable; keys time, command, position,
    /// ia, ib, ic, temperature) [default: time_s, command_rad, position_rad, ia_A, ib_A, ic_A;
    /// temperature_C when the file has it].
    #[arg(long = "column", value_name = "KEY=HEADER")]
    pub columns: Vec<String>,
    /// Field delimiter: comma, semicolon, tab or one ASCII character [default: detected from the
    /// header line].
    #[arg(long, value_name = "DELIMITER")]
    pub delimiter: Option<String>,
    /// Time (in the file's time column, seconds) at which the manoeuvre starts [default: found
    /// by aligning the recorded command with the profile].
    #[arg(long, value_name = "SECONDS", allow_hyphen_values = true)]
    pub start: Option<f64>,
}

/// A recording made ready for the monitor, and what was done to it.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// The manoeuvre on the monitor's grid: time 0 at its start, the control period's step.
    pub recording: Recording,
    /// The rows before the manoeuvre on the same grid (negative times; under a profile the
    /// command is its opening value), as many as [`RecordingArgs::load_with_pre_trigger`] was
    /// asked for and the file holds; [`RecordingArgs::load`] asks for [`MAX_REST_ROWS`].
    pub pre_trigger: Recording,
    /// What was done.
    pub summary: LoadSummary,
}

/// What [`RecordingArgs::load`] did to a file, for the report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LoadSummary {
    /// The file's mean sample rate.
    pub source_rate_hz: f64,
    /// The rate it was brought to.
    pub rate_hz: f64,
    /// `true` when interpolated (band-limited), `false` when the rows were taken as they are.
    pub resampled: bool,
    /// File time of the manoeuvre's start.
    pub start_s: f64,
    /// How the start was found: `aligned` (command against the profile), `given` (`--start`) or
    /// `first row`.
    pub start_from: &'static str,
    /// Seconds of the file before the start (pre-trigger) that were left out.
    pub trimmed_before_s: f64,
    /// Seconds of the file after the manoeuvre's end (trailing idle) that were left out.
    pub trimmed_after_s: f64,
    /// Rows of the result.
    pub rows: usize,
}

impl LoadSummary {
    /// Independent frames in a block of [`DECIMATION`] frames at the monitor's rate, for the fit
    /// test's noise model ([`ema_monitor::diagnosis::IdentifyConfig::independent_frames_per_block`]):
    /// [`DECIMATION`] for a file at the monitor's rate or faster, `DECIMATION · f_file / f_monitor`
    /// for a slower one, whose frames in between are interpolated.
    pub fn independent_frames_per_block(&self) -> f32 {
        let share = if self.rate_hz > 0.0 { (self.source_rate_hz / self.rate_hz).min(1.0) } else { 1.0 };
        (DECIMATION as f64 * share) as f32
    }

    /// One line: `recording: 20000 Hz resampled to 10000 Hz; manoeuvre starts at 0.010000 s
    /// (aligned); trimmed 0.010000 s before, 0.050000 s after`.
    pub fn line(&self) -> String {
        let rate = if self.resampled {
            format!("{:.0} Hz resampled to {:.0} Hz", self.source_rate_hz, self.rate_hz)
        } else {
            format!("{:.0} Hz", self.source_rate_hz)
        };
        format!(
            "recording: {rate}; manoeuvre starts at {:.6} s ({}); trimmed {:.6} s before, {:.6} s after",
            self.start_s, self.start_from, self.trimmed_before_s, self.trimmed_after_s
        )
    }
}

/// `comma`, `semicolon`, `tab` or one ASCII character (not a quote, `#`, a digit, a letter or a line end).
pub fn parse_delimiter(text: &str) -> Result<u8, String> {
    match text {
        "comma" | "," => Ok(b','),
        "semicolon" | ";" => Ok(b';'),
        "tab" | "\t" | "\\t" => Ok(b'\t'),
        t if t.len() == 1 && t.is_ascii() => {
            let b = t.as_bytes()[0];
            if b.is_ascii_alphanumeric() || matches!(b, b'"' | b'#' | b'\n' | b'\r' | b'.' | b'-' | b'+') {
                Err(format!("--delimiter: '{t}' cannot separate numbers; give comma, semicolon, tab or a symbol"))
            } else {
                Ok(b)
            }
        }
        t => Err(format!("--delimiter: '{t}' is not comma, semicolon, tab or one character")),
    }
}

impl RecordingArgs {
    /// The read options the flags give.
    pub fn options(&self) -> Result<ReadOptions, String> {
        Ok(ReadOptions {
            columns: Columns::parse(&self.columns)?,
            delimiter: self.delimiter.as_deref().map(parse_delimiter).transpose()?,
        })
    }

    /// Reads `path` and makes it the monitor's recording of one manoeuvre: read ([`super::read`],
    /// with its time base), the start found ([`align::find_start`] against `profile`, or
    /// `--start`, or the first row without a profile), the command checked against `profile`
    /// ([`align::check_command`]), then the rows from the start to the manoeuvre's end (the file's
    /// end without a profile) on the grid of `params.control_period_s`: taken as they are from a
    /// file at that rate (the start rounded to the nearest row), band-limited
    /// ([`resample::resample`]) from any other. Under a profile the command column is the
    /// profile's at the monitor's sample times (the recorded one matched it within
    /// [`align::COMMAND_TOLERANCE_RAD`]); without one, the recorded command linearly interpolated.
    /// A temperature column comes along: cut with the rows, or linearly interpolated.
    pub fn load(&self, path: &Path, profile: Option<&Profile>, params: &EmaParams) -> Result<Loaded, CliError> {
        self.load_with_pre_trigger(path, profile, params, MAX_REST_ROWS)
    }

    /// [`RecordingArgs::load`], and up to `pre_rows` rows of the file before the manoeuvre's start
    /// on the same grid ([`Loaded::pre_trigger`]): cut from a file at the monitor's rate,
    /// resampled from any other, each grid time `start − k·T`, so that the manoeuvre's rows are
    /// those `load` gives, bit for bit.
    pub fn load_with_pre_trigger(
        &self,
        path: &Path,
        profile: Option<&Profile>,
        params: &EmaParams,
        pre_rows: usize,
    ) -> Result<Loaded, CliError> {
        let flag = |m: String| CliError::from(RecordingError::file(path, RecordingErrorKind::Flag(m)));
        let options = self.options().map_err(flag)?;
        let parsed = read_file(path, &options)?;
        let (raw, grid) = (&parsed.recording, parsed.grid);
        let command_column = (parsed.headers[1].0.as_str(), parsed.headers[1].1);
        let period_f32 = params.control_period_s;
        let out_period = f64::from(period_f32);
        let at_rate = (grid.period_s / out_period - 1.0).abs() < 1e-6;
        let t_first = grid.origin_s;
        let t_last = grid.time_s(raw.len() - 1);
        let (start, start_from) = match (self.start, profile) {
            (Some(s), _) => {
                if !(s.is_finite() && s >= t_first - 0.5 * grid.period_s && s < t_last) {
                    return Err(flag(format!(
                        "--start {}: outside the file's times, {} to {} s ({} column)",
                        num(s),
                        num(t_first),
                        num(t_last),
                        parsed.headers[0].0
                    )));
                }
                (s, "given")
            }
            (None, Some(p)) => (align::find_start(raw, &grid, p, at_rate, path, command_column)?, "aligned"),
            (None, None) => (t_first, "first row"),
        };
        let (recording, mut pre_trigger, start) = if at_rate {
            let i0 = ((start - t_first) / grid.period_s).round().max(0.0) as usize;
            let start = grid.time_s(i0);
            let mut n = raw.len() - i0;
            if let Some(p) = profile {
                n = n.min((f64::from(p.duration_s()) / out_period).round() as usize);
            }
            let t0 = raw.time_s[i0];
            let rows = |from: usize, to: usize| {
                let cut = |x: &Vec<f64>| x[from..to].to_vec();
                Recording {
                    comments: raw.comments.clone(),
                    time_s: raw.time_s[from..to].iter().map(|t| t - t0).collect(),
                    command_rad: cut(&raw.command_rad),
                    position_rad: cut(&raw.position_rad),
                    ia_a: cut(&raw.ia_a),
                    ib_a: cut(&raw.ib_a),
                    ic_a: cut(&raw.ic_a),
                    row_line: raw.row_line[from..to].to_vec(),
                    rest_currents_a: Vec::new(),
                    temperature_c: raw.temperature_c.as_ref().map(cut),
                }
            };
            (rows(i0, i0 + n), rows(i0 - pre_rows.min(i0), i0), start)
        } else {
            let available = ((t_last + 0.5 * grid.period_s - start) / out_period + 1e-9).floor() as usize + 1;
            let n = match profile {
                Some(p) => available.min((f64::from(p.duration_s()) / out_period).round() as usize),
                None => available,
            };
            // rows at start + k·T, k from `first` (negative before the start) for n rows
            let rows = |first: isize, n: usize| {
                let at = |k: usize| (first + k as isize) as f64 * out_period;
                let channels = [&raw.position_rad[..], &raw.ia_a[..], &raw.ib_a[..], &raw.ic_a[..]];
                let mut out = resample::resample(&channels, &grid, start + at(0), out_period, n).into_iter();
                let mut next = || out.next().unwrap_or_default();
                let times: Vec<f64> = (0..n).map(|k| start + at(k)).collect();
                let nearest =
                    |u: f64| ((u - t_first) / grid.period_s).round().clamp(0.0, (raw.len() - 1) as f64) as usize;
                Recording {
                    comments: raw.comments.clone(),
                    time_s: (0..n).map(at).collect(),
                    command_rad: times.iter().map(|&u| resample::linear(&raw.command_rad, &grid, u)).collect(),
                    position_rad: next(),
                    ia_a: next(),
                    ib_a: next(),
                    ic_a: next(),
                    row_line: times.iter().map(|&u| raw.row_line[nearest(u)]).collect(),
                    rest_currents_a: Vec::new(),
                    // a slow quantity: linear between neighbours, which stays within the file's values
                    temperature_c: raw
                        .temperature_c
                        .as_ref()
                        .map(|t| times.iter().map(|&u| resample::linear(t, &grid, u)).collect()),
                }
            };
            // grid times before the start that lie within the file (to half an input period)
            let before = ((start - t_first + 0.5 * grid.period_s) / out_period + 1e-9).floor().max(0.0) as usize;
            let pre = pre_rows.min(before);
            (rows(0, n), rows(-(pre as isize), pre), start)
        };
        let mut recording = recording;
        // the sensors' zero points come from the last rows before the start (`RecordingSource`)
        let skip = pre_trigger.len().saturating_sub(MAX_REST_ROWS);
        recording.rest_currents_a = (skip..pre_trigger.len())
            .map(|k| [pre_trigger.ia_a[k], pre_trigger.ib_a[k], pre_trigger.ic_a[k]])
            .collect();
        if let Some(p) = profile {
            align::check_command(raw, &grid, p, start, out_period, path, command_column)?;
            for (k, c) in recording.command_rad.iter_mut().enumerate() {
                *c = f64::from(p.command_rad(k as f32 * period_f32));
            }
            pre_trigger.command_rad.fill(f64::from(p.command_rad(0.0)));
        }
        let end = start + recording.len() as f64 * out_period;
        let summary = LoadSummary {
            source_rate_hz: grid.rate_hz(),
            rate_hz: 1.0 / out_period,
            resampled: !at_rate,
            start_s: start,
            start_from,
            trimmed_before_s: (start - t_first).max(0.0),
            trimmed_after_s: (t_last + grid.period_s - end).max(0.0),
            rows: recording.len(),
        };
        Ok(Loaded { recording, pre_trigger, summary })
    }
}
