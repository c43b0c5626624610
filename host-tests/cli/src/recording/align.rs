//! Where the manoeuvre starts in a recording, and the check that the recorded command is the
//! profile's.
//!
//! A bench starts logging before the manoeuvre (a pre-trigger) and stops after it (trailing
//! idle). The monitor model is driven by the profile from its time 0, so the reader needs the
//! file time `τ` of the profile's time 0: the recorded command `c_i` at grid time `t_i` should be
//! `p(t_i − τ)`. The standard profile opens with a hold at zero, which any `τ` matches, so only its
//! first change fixes `τ` ([`find_start`]):
//! 1. the first change of the profile, `t_c`: the first time it leaves its opening value by more
//!    than [`CHANGE_THRESHOLD_RAD`] (1 µs scan, then bisection to 1 ns);
//! 2. the first row `r` whose command leaves the same value by the same threshold: `τ` lies in
//!    `(t_{r−1} − t_c, t_r − t_c]`, one input period wide;
//! 3. within it, least squares: `τ` minimises `Σ (c_i − p(t_i − τ))²` over the rows of the
//!    manoeuvre away from the profile's steps (golden-section search; the ramps and sines of the profile fix `τ` to a fraction
//!    of a sample, a profile of steps alone leaves it anywhere in the interval). A file at the
//!    monitor's rate is cut, not interpolated: `τ` is the time of the row, around that interval,
//!    of least cost.
//!
//! [`check_command`] then compares every row of the manoeuvre with the profile within
//! [`COMMAND_TOLERANCE_RAD`]. The actuator's controller updates its command once per control
//! period, so a log faster than that sees each value held: on a continuous part of the profile a
//! row may carry any value the profile took during the preceding `max(control period, input
//! period)`; within that span of a step, the value before or the value after the step.

use std::path::Path;

use ema_monitor::Profile;

use super::data::Recording;
use super::error::{RecordingError, RecordingErrorKind};
use super::grid::Grid;
use crate::error::{num, Num};

/// A time in a message, to the nanosecond (a start found by least squares at `-1.7e-17` s is 0).
fn seconds(t: f64) -> Num {
    num((t * 1e9).round() / 1e9)
}

/// Largest difference between the recorded command and the profile: 2e-5 rad, twice the step of
/// a command exported with five decimals (1e-5 rad), so a rounded or truncated export passes,
/// with the rest for the start's sub-sample error on the profile's ramps (0.25 rad/s at most on
/// the standard profile: 1 µs costs 2.5e-7 rad). It is 0.04 % of the standard profile's
/// 0.05 rad step, far below any other manoeuvre's difference.
pub const COMMAND_TOLERANCE_RAD: f64 = 2e-5;

/// Change of the command from its opening value that marks the manoeuvre's first change:
/// fifty times [`COMMAND_TOLERANCE_RAD`], so quantisation never triggers it.
pub const CHANGE_THRESHOLD_RAD: f64 = 1e-3;

/// The profile at `t` seconds into the manoeuvre, as the monitor evaluates it (`f32` time).
fn command(profile: &Profile, t: f64) -> f64 {
    f64::from(profile.command_rad(t as f32))
}

/// First time the profile leaves its opening value by more than [`CHANGE_THRESHOLD_RAD`], to 1 ns.
pub fn first_change_s(profile: &Profile) -> Option<f64> {
    let p0 = command(profile, 0.0);
    let duration = f64::from(profile.duration_s());
    let moved = |t: f64| (command(profile, t) - p0).abs() > CHANGE_THRESHOLD_RAD;
    let step = 1e-6;
    let k = (1..=(duration / step) as usize).find(|&k| moved(k as f64 * step))?;
    let (mut lo, mut hi) = ((k - 1) as f64 * step, k as f64 * step);
    while hi - lo > 1e-9 {
        let mid = 0.5 * (lo + hi);
        if moved(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi)
}

/// A manoeuvre error about the command column, at a line.
fn command_error(path: &Path, line: Option<usize>, header: &str, column: usize, message: String) -> RecordingError {
    RecordingError {
        line,
        field: Some(header.to_owned()),
        column: Some(column),
        ..RecordingError::file(path, RecordingErrorKind::Manoeuvre(message))
    }
}

/// The file time of the profile's time 0 in `rec` (sampled on `grid`), as the module describes;
/// `at_monitor_rate` skips the sub-sample refinement. `header` and `column` name the command
/// column in errors.
pub fn find_start(
    rec: &Recording,
    grid: &Grid,
    profile: &Profile,
    at_monitor_rate: bool,
    path: &Path,
    (header, column): (&str, usize),
) -> Result<f64, RecordingError> {
    let t0 = grid.origin_s;
    let t_last = grid.time_s(rec.len() - 1);
    let Some(t_c) = first_change_s(profile) else {
        return Ok(t0); // a profile that never moves: the manoeuvre starts with the file
    };
    let p0 = command(profile, 0.0);
    let Some(r) = rec.command_rad.iter().position(|c| (c - p0).abs() > CHANGE_THRESHOLD_RAD) else {
        if t_last - t0 < t_c {
            return Ok(t0); // the whole file lies in the profile's opening hold
        }
        return Err(command_error(
            path,
            None,
            header,
            column,
            format!(
                "the command never leaves {} rad, but the profile does {} s into the manoeuvre; pass the profile \
                 the recording was made with (--profile), or check the command column (--column command=HEADER)",
                num(p0),
                seconds(t_c)
            ),
        ));
    };
    let hi = grid.time_s(r) - t_c;
    let lo = if r == 0 { hi - grid.period_s } else { grid.time_s(r - 1) - t_c }.max(t0 - 0.5 * grid.period_s);
    if hi < t0 - 0.5 * grid.period_s || r == 0 {
        return Err(command_error(
            path,
            rec.row_line.get(r).copied(),
            header,
            column,
            format!(
                "the command already leaves {} rad here, {} s into the file, but the profile holds it for {} s: \
                 the recording starts after the manoeuvre; record from before it starts, or give its start (--start SECONDS)",
                num(p0),
                seconds(grid.time_s(r) - t0),
                seconds(t_c)
            ),
        ));
    }
    // least squares over the rows of the manoeuvre (a fixed set: those of the latest start) away
    // from the profile's steps, whose row is uncertain by one sample in the f32 time of a log
    let duration = f64::from(profile.duration_s());
    let near = 2.0 * grid.period_s.max(f64::from(ema_monitor::EmaParams::NOMINAL.control_period_s));
    let smooth =
        |s: f64| (command(profile, s + near) - command(profile, (s - near).max(0.0))).abs() <= CHANGE_THRESHOLD_RAD;
    let rows: Vec<usize> = (r..rec.len())
        .take_while(|&i| grid.time_s(i) - hi <= duration - 2.0 * grid.period_s)
        .filter(|&i| smooth(grid.time_s(i) - hi))
        .collect();
    let cost = |tau: f64| -> f64 {
        rows.iter().map(|&i| (rec.command_rad[i] - command(profile, grid.time_s(i) - tau)).powi(2)).sum()
    };
    if at_monitor_rate {
        // the rows around the interval: the one of least cost (ties to the one nearest the first change)
        let row = |t: f64| ((t - t0) / grid.period_s).round().max(0.0) as usize;
        let best = (row(lo).saturating_sub(1)..=row(hi) + 1)
            .map(|k| grid.time_s(k))
            .map(|tau| (cost(tau), (tau - hi).abs(), tau))
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)))
            .map_or(hi, |b| b.2);
        return Ok(best);
    }
    let margin = 1e-3 * grid.period_s;
    let (mut a, mut b) = (lo + margin, hi - margin);
    if b <= a {
        return Ok(hi);
    }
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut x1, mut x2) = (b - g * (b - a), a + g * (b - a));
    let (mut f1, mut f2) = (cost(x1), cost(x2));
    while b - a > 1e-9 * grid.period_s.max(1e-9) && b - a > 1e-12 {
        if f1 < f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - g * (b - a);
            f1 = cost(x1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + g * (b - a);
            f2 = cost(x2);
        }
    }
    // ties (a flat cost: steps alone) go to the latest start, the one a synchronous log gives
    let best = 0.5 * (a + b);
    Ok(if cost(hi - margin) <= cost(best) { hi - margin } else { best })
}

/// Checks that every row of `rec` between `start_s` and the end of the manoeuvre commands what
/// `profile` does, within [`COMMAND_TOLERANCE_RAD`]; the first row that does not is named, with
/// what to change.
pub fn check_command(
    rec: &Recording,
    grid: &Grid,
    profile: &Profile,
    start_s: f64,
    control_period_s: f64,
    path: &Path,
    (header, column): (&str, usize),
) -> Result<(), RecordingError> {
    let duration = f64::from(profile.duration_s());
    let tol = COMMAND_TOLERANCE_RAD;
    for i in 0..rec.len() {
        let s = grid.time_s(i) - start_s;
        if s < 0.0 {
            continue;
        }
        if s >= duration {
            break;
        }
        let c = rec.command_rad[i];
        let expected = command(profile, s);
        if (c - expected).abs() <= tol {
            continue;
        }
        // a value held since the last control update, or either side of a step
        let lag = control_period_s.max(grid.period_s);
        let (before, after) = (command(profile, (s - lag).max(0.0)), command(profile, s + grid.period_s));
        let step = (after - before).abs() > CHANGE_THRESHOLD_RAD;
        let held = !step && c >= before.min(expected) - tol && c <= before.max(expected) + tol;
        if held || (step && ((c - before).abs() <= tol || (c - after).abs() <= tol)) {
            continue;
        }
        return Err(command_error(
            path,
            rec.row_line.get(i).copied(),
            header,
            column,
            format!(
                "{} but the profile commands {} ({} s into the manoeuvre, which starts at {} s in the file; \
                 tolerance {} rad); pass the profile the recording was made with (--profile), or where the manoeuvre \
                 starts (--start SECONDS)",
                num(c),
                num(expected),
                seconds(s),
                seconds(start_s),
                num(tol)
            ),
        ));
    }
    Ok(())
}
