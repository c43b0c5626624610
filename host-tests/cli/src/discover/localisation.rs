//! Step 2, where: the windows holding most of the structural residual, its share per operating
//! regime against the regime's share of time, the share of the raw residual carried by
//! rotor-angle orders, and the "unexplained residual" note when the gap stays above the floor.

use super::residual::{rms, Series, CLEAN_FLOOR_A};

/// Length of the "where" windows (s).
pub const WINDOW_S: f64 = 0.025;

/// A structural residual above this multiple of [`CLEAN_FLOOR_A`] after the named effects is
/// reported as unexplained.
pub const UNEXPLAINED_FACTOR: f64 = 1.5;

/// A time window of the recording and its residual.
#[derive(Clone, Debug)]
pub struct Window {
    /// Start (s).
    pub start_s: f64,
    /// End (s).
    pub end_s: f64,
    /// Share of the structural residual energy before (fraction).
    pub share: f64,
    /// Structural residual RMS before (A).
    pub rms_before_a: f64,
    /// Structural residual RMS after (A), filled at the end.
    pub rms_after_a: f64,
}

/// The windows holding most of the structural residual energy: [`WINDOW_S`] windows in
/// decreasing energy until half the energy is covered (at most 5), adjacent ones merged.
pub fn hot_windows(s: &Series) -> Vec<Window> {
    let dt = s.time_s.get(1).copied().unwrap_or(0.0) - s.time_s.first().copied().unwrap_or(0.0);
    let per = ((WINDOW_S / dt.max(1e-9)).round() as usize).max(1);
    let energy: Vec<f64> = s.structural_a.chunks(per).map(|c| c.iter().map(|v| v * v).sum()).collect();
    let total: f64 = energy.iter().sum::<f64>().max(1e-30);
    let mut order: Vec<usize> = (0..energy.len()).collect();
    order.sort_by(|a, b| energy[*b].total_cmp(&energy[*a]));
    let mut picked = Vec::new();
    let mut covered = 0.0;
    for &w in &order {
        if covered >= 0.5 || picked.len() >= 5 {
            break;
        }
        picked.push(w);
        covered += energy[w] / total;
    }
    picked.sort_unstable();
    let mut out: Vec<Window> = Vec::new();
    for w in picked {
        let (start, end) = (w as f64 * per as f64 * dt, ((w + 1) * per).min(s.time_s.len()) as f64 * dt);
        match out.last_mut() {
            Some(last) if (last.end_s - start).abs() < 1e-9 => {
                last.end_s = end;
                last.share += energy[w] / total;
            }
            _ => out.push(Window {
                start_s: start,
                end_s: end,
                share: energy[w] / total,
                rms_before_a: 0.0,
                rms_after_a: 0.0,
            }),
        }
    }
    for w in &mut out {
        w.rms_before_a = window_rms(s, w.start_s, w.end_s);
    }
    out
}

/// Structural residual RMS of `s` over `[start, end)` (s).
pub(super) fn window_rms(s: &Series, start: f64, end: f64) -> f64 {
    rms(s.time_s.iter().zip(&s.structural_a).filter(|(t, _)| **t >= start && **t < end).map(|(_, r)| *r))
}

/// An operating regime and the residual energy in it.
#[derive(Clone, Debug)]
pub struct Regime {
    /// Family (`direction`, `speed`, `reversal`, `current`).
    pub family: &'static str,
    /// Regime name.
    pub name: &'static str,
    /// Share of the recording's time (fraction).
    pub time_share: f64,
    /// Share of the structural residual energy (fraction).
    pub energy_share: f64,
}

/// Motor speed under which the actuator counts as at rest (rad/s).
const REST_RAD_S: f64 = 5.0;
/// Blocks on each side of a speed sign change counted as the reversal (10 ms).
const REVERSAL_BLOCKS: usize = 25;

/// Shares of the structural residual energy per regime of the model's state.
pub fn regimes(s: &Series) -> Vec<Regime> {
    let n = s.time_s.len();
    let mut reversal = vec![false; n];
    let mut last_sign = 0.0;
    for i in 0..n {
        let w = s.speed_rad_s[i];
        if w.abs() > REST_RAD_S {
            let sign = w.signum();
            if last_sign != 0.0 && sign != last_sign {
                for r in &mut reversal[i.saturating_sub(REVERSAL_BLOCKS)..(i + REVERSAL_BLOCKS).min(n)] {
                    *r = true;
                }
            }
            last_sign = sign;
        }
    }
    type Classifier = fn(f64, f64, bool) -> bool;
    let table: [(&str, &str, Classifier); 11] = [
        ("direction", "forward", |w, _, _| w > REST_RAD_S),
        ("direction", "backward", |w, _, _| w < -REST_RAD_S),
        ("direction", "at rest", |w, _, _| w.abs() <= REST_RAD_S),
        ("speed", "low (< 100 rad/s)", |w, _, _| w.abs() > REST_RAD_S && w.abs() < 100.0),
        ("speed", "medium (100-500 rad/s)", |w, _, _| (100.0..500.0).contains(&w.abs())),
        ("speed", "high (>= 500 rad/s)", |w, _, _| w.abs() >= 500.0),
        ("reversal", "within 10 ms of a reversal", |_, _, r| r),
        ("reversal", "away from reversals", |_, _, r| !r),
        ("current", "low (< 2 A)", |_, i, _| i.abs() < 2.0),
        ("current", "medium (2-8 A)", |_, i, _| (2.0..8.0).contains(&i.abs())),
        ("current", "high (>= 8 A)", |_, i, _| i.abs() >= 8.0),
    ];
    let total: f64 = s.structural_a.iter().map(|r| r * r).sum::<f64>().max(1e-30);
    table
        .iter()
        .map(|(family, name, f)| {
            let (mut t, mut e) = (0usize, 0.0);
            for (((w, i), r), x) in s.speed_rad_s.iter().zip(&s.current_a).zip(&reversal).zip(&s.structural_a) {
                if f(*w, *i, *r) {
                    t += 1;
                    e += x * x;
                }
            }
            Regime { family, name, time_share: t as f64 / n.max(1) as f64, energy_share: e / total }
        })
        .collect()
}

/// Share of the raw residual energy explained by `a·sin(n·θ) + b·cos(n·θ)` (least squares).
pub fn order_share(residual: &[f64], angle: &[f64], order: f64) -> f64 {
    let (mut ss, mut cc, mut sc, mut rs, mut rc, mut rr) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (r, a) in residual.iter().zip(angle) {
        let (sn, cs) = (order * a).sin_cos();
        ss += sn * sn;
        cc += cs * cs;
        sc += sn * cs;
        rs += r * sn;
        rc += r * cs;
        rr += r * r;
    }
    let det = ss * cc - sc * sc;
    if det <= 0.0 || rr <= 0.0 {
        return 0.0;
    }
    let a = (rs * cc - rc * sc) / det;
    let b = (rc * ss - rs * sc) / det;
    (a * rs + b * rc) / rr
}

/// The rotor-angle orders reported: `(name, share of the raw residual energy)`.
pub fn orders(s: &Series) -> Vec<(&'static str, f64)> {
    let r = &s.residual_a;
    vec![
        ("1 x electrical", order_share(r, &s.electrical_angle_rad, 1.0)),
        ("2 x electrical", order_share(r, &s.electrical_angle_rad, 2.0)),
        // 24 per mechanical turn (cogging, 12 slots / 8 poles) is 6 per electrical turn: one row
        ("6 x electrical = 24 x mechanical", order_share(r, &s.electrical_angle_rad, 6.0)),
    ]
}

/// "unexplained residual at …" when the structural residual left is above
/// [`UNEXPLAINED_FACTOR`]·[`CLEAN_FLOOR_A`]: its hot windows and the regimes where it is
/// concentrated (at least 30 % of the energy in at most half that share of the time).
pub fn unexplained(after: &Series) -> Option<String> {
    let left = rms(after.structural_a.iter().copied());
    if left <= UNEXPLAINED_FACTOR * CLEAN_FLOOR_A {
        return None;
    }
    let windows: Vec<String> = hot_windows(after)
        .iter()
        .map(|w| format!("{:.3}-{:.3} s ({:.0} %)", w.start_s, w.end_s, 100.0 * w.share))
        .collect();
    let regimes: Vec<String> = regimes(after)
        .iter()
        .filter(|r| r.energy_share >= 0.3 && r.energy_share >= 2.0 * r.time_share)
        .map(|r| format!("{} {}", r.family, r.name))
        .collect();
    Some(format!(
        "unexplained residual at {} (RMS {left:.3} A, {:.1}x the clean floor){}",
        windows.join(", "),
        left / CLEAN_FLOOR_A,
        if regimes.is_empty() { String::new() } else { format!("; concentrated in: {}", regimes.join(", ")) }
    ))
}
