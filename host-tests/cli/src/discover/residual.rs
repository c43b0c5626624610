//! Step 1's residual: the monitor model run along a recording, the raw residual of the 0.4 ms
//! block means and the structural residual (its 2 ms means), with the floors that judge it.

use ema_monitor::command::CommandSource;
use ema_monitor::conditioning::{ConditionedWindow, DECIMATION};
use ema_monitor::fitness::simulate_window_with_effects;
use ema_monitor::{EmaParams, FaultVector, ModelEffects};

/// Blocks averaged into the structural residual (5 × 0.4 ms = 2 ms).
pub const SMOOTH_BLOCKS: usize = 5;

/// Structural residual RMS of the monitor model on clean reference-model recordings of the
/// standard manoeuvre: the known floor. Median 0.048 A, range 0.0447–0.0493 A over 20 clean
/// recordings (seeds 1–8, 11 and 12, healthy and with friction 0.3; `scripts/discover-seeds`);
/// `docs/results/mismatch-floor.md` splits it into sensor noise and model mismatch.
pub const CLEAN_FLOOR_A: f64 = 0.048;

/// The sensor noise's part of the structural residual (RMS of the 2 ms means): what no model can
/// remove from a recording of the standard manoeuvre with the nominal sensors. 0.0449 A on a
/// healthy actuator, 0.044–0.049 A with any fault or library effect (the `floor_split`
/// investigation, 16 noise seeds: each seed's 2 ms means about the seeds' mean): 90 % of
/// [`CLEAN_FLOOR_A`]'s energy; the rest is the model's mismatch. Other sensors or another
/// manoeuvre need it measured again (two recordings of the same manoeuvre suffice).
pub const NOISE_FLOOR_A: f64 = 0.045;

/// The part of a structural residual RMS above the sensor noise, `√max(0, RMS² − σ_n²)` with
/// `σ_n` = [`NOISE_FLOOR_A`]: the gap a model could close.
pub fn above_noise_a(rms_a: f64) -> f64 {
    (rms_a * rms_a - NOISE_FLOOR_A * NOISE_FLOOR_A).max(0.0).sqrt()
}

/// The monitor model's output and state along a recording, and the residual.
#[derive(Clone, Debug, Default)]
pub struct Series {
    /// Block centre times (s).
    pub time_s: Vec<f64>,
    /// Measured `I_3eq` block means (A).
    pub measured_a: Vec<f64>,
    /// Model's expected measured `I_3eq` (A).
    pub model_a: Vec<f64>,
    /// Raw residual `measured − model` (A).
    pub residual_a: Vec<f64>,
    /// Structural residual: `residual` averaged over [`SMOOTH_BLOCKS`] (A).
    pub structural_a: Vec<f64>,
    /// Model motor speed (rad/s).
    pub speed_rad_s: Vec<f64>,
    /// Model equivalent current (A).
    pub current_a: Vec<f64>,
    /// Model electrical angle `θ_e` (rad).
    pub electrical_angle_rad: Vec<f64>,
}

/// Runs the model with `k` and `effects` along `trace`, driven by `profile` (a profile or a
/// sampled command).
pub fn series<'c, const W: usize>(
    trace: &ConditionedWindow<W>,
    params: &EmaParams,
    profile: impl CommandSource<'c>,
    k: &FaultVector,
    effects: &ModelEffects,
) -> Series {
    let n = trace.len();
    let dt = f64::from(params.control_period_s) * DECIMATION as f64;
    let mut s = Series::default();
    let measured: Vec<f32> = trace.current_a().collect();
    simulate_window_with_effects(params, profile, k, effects, n, |i, model_a, state| {
        let y = f64::from(measured[i]);
        s.time_s.push((i as f64 + 0.5) * dt);
        s.measured_a.push(y);
        s.model_a.push(f64::from(model_a));
        s.residual_a.push(y - f64::from(model_a));
        s.speed_rad_s.push(f64::from(state.motor_speed_rad_s));
        s.current_a.push(f64::from(state.output_current_a));
        s.electrical_angle_rad.push(f64::from(state.hall_angle_rad) + std::f64::consts::FRAC_PI_6);
        true
    });
    s.structural_a = moving_mean(&s.residual_a, SMOOTH_BLOCKS);
    s
}

/// Centred moving mean over `m` samples (shorter at the ends).
pub fn moving_mean(x: &[f64], m: usize) -> Vec<f64> {
    let half = m / 2;
    (0..x.len())
        .map(|i| {
            let lo = i.saturating_sub(half);
            let hi = (i + m - half).min(x.len());
            x[lo..hi].iter().sum::<f64>() / (hi - lo) as f64
        })
        .collect()
}

/// Root mean square of `x` (0 when empty).
pub(super) fn rms(x: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for v in x {
        s += v * v;
        n += 1;
    }
    if n == 0 {
        0.0
    } else {
        (s / n as f64).sqrt()
    }
}

/// Energy `Σ r_i²` of the structural residual.
pub(super) fn structural_energy(s: &Series) -> f64 {
    s.structural_a.iter().map(|r| r * r).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_noise_comes_off_in_quadrature() {
        assert_eq!(above_noise_a(NOISE_FLOOR_A), 0.0);
        assert_eq!(above_noise_a(0.01), 0.0, "below the noise: nothing a model could remove");
        // 0.075² − 0.045² = 0.060²
        assert!((above_noise_a(0.075) - 0.060).abs() < 1e-12);
    }
}
