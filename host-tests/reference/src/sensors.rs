//! Transducers (docs/model.md): first-order lags, white noise, quantization.
//!
//! | channel | model |
//! |---|---|
//! | surface position | lag `τ = EmaParams::position_lag_s` (0.2 ms), noise `σ = EmaParams::position_noise_rad` (1e-5 rad), 16-bit quantization over ±0.6 rad |
//! | phase currents | sensor error `(1 + g_j)·i_j + o_j` (effect `sensor_offset`), 20 kHz first-order bandwidth, noise `σ = EmaParams::current_noise_a` (0.02 A), 12-bit ADC [`ema_monitor::trace::amps_to_counts`] |
//!
//! The lags are integrated at every step of the model (exact discretization `y += (1 − e^{−dt/τ})·(x − y)`);
//! noise and quantization are applied when the ACE samples.

use ema_monitor::trace;

/// Position transducer resolution.
pub const POSITION_BITS: u32 = 16;
/// Position transducer range `±POSITION_RANGE_RAD`.
pub const POSITION_RANGE_RAD: f64 = 0.6;
/// Current sensor bandwidth.
pub const CURRENT_BANDWIDTH_HZ: f64 = 20.0e3;

/// One position code: `2·POSITION_RANGE_RAD / 2^16`.
pub fn position_lsb_rad() -> f64 {
    2.0 * POSITION_RANGE_RAD / f64::from(1u32 << POSITION_BITS)
}

/// Quantizes a position to the 16-bit transducer code grid (saturating at the range ends).
pub fn quantize_position(theta_rad: f64) -> f64 {
    PositionGrid::NOMINAL.quantize(theta_rad)
}

/// The code grid of a position transducer: `2·half_codes` codes of `lsb_rad` over
/// `±half_codes·lsb_rad`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionGrid {
    /// One code.
    pub lsb_rad: f64,
    /// Codes on each side of zero.
    pub half_codes: f64,
}

impl PositionGrid {
    /// The nominal transducer: 16 bits over ±[`POSITION_RANGE_RAD`].
    pub const NOMINAL: Self = Self {
        lsb_rad: 2.0 * POSITION_RANGE_RAD / (1u32 << POSITION_BITS) as f64,
        half_codes: (1u32 << (POSITION_BITS - 1)) as f64,
    };

    /// The transducer of an actuator: a whole number of codes spanning its travel `±end_stop_rad`,
    /// each as close as that allows to the resolution `resolution_rad` (the nominal table's
    /// `1.2/65536` in `f32` gives exactly [`PositionGrid::NOMINAL`]).
    pub fn of(resolution_rad: f64, end_stop_rad: f64) -> Self {
        let codes = (2.0 * end_stop_rad / resolution_rad).round().max(2.0);
        Self { lsb_rad: 2.0 * end_stop_rad / codes, half_codes: (codes / 2.0).floor() }
    }

    /// Quantizes a position to the grid (saturating at the range ends).
    pub fn quantize(&self, theta_rad: f64) -> f64 {
        let code = (theta_rad / self.lsb_rad).round().clamp(-self.half_codes, self.half_codes - 1.0);
        code * self.lsb_rad + 0.0 // + 0.0 turns −0 into +0
    }
}

/// Current ADC: `(counts, amps)` of a current through the shared 12-bit format.
pub fn adc_current(i_a: f64) -> (u16, f64) {
    let counts = trace::amps_to_counts(i_a as f32);
    (counts, f64::from(trace::counts_to_amps(counts)))
}

/// First-order lag `τ·dy/dt = x − y`, discretized exactly for a fixed step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lag {
    /// Output `y`.
    pub value: f64,
    alpha: f64,
}

impl Lag {
    /// Lag of time constant `tau_s` stepped every `dt_s`, starting at 0.
    pub fn new(tau_s: f64, dt_s: f64) -> Self {
        Self { value: 0.0, alpha: 1.0 - (-dt_s / tau_s).exp() }
    }

    /// Advances one step towards `x`.
    pub fn update(&mut self, x: f64) {
        self.value += self.alpha * (x - self.value);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantizers() {
        let lsb = position_lsb_rad();
        assert!((lsb - 1.2 / 65536.0).abs() < 1e-18);
        assert_eq!(quantize_position(0.4 * lsb), 0.0);
        assert_eq!(quantize_position(0.6 * lsb), lsb);
        assert_eq!(quantize_position(1.0), 32767.0 * lsb);
        let (c, a) = adc_current(1.0);
        assert_eq!(c, 2048 + 102);
        assert!((a - 102.0 * 40.0 / 4096.0).abs() < 1e-6);
    }

    #[test]
    fn lag_step_response() {
        let mut l = Lag::new(1e-3, 1e-6);
        for _ in 0..1000 {
            l.update(1.0);
        }
        assert!((l.value - (1.0 - (-1.0f64).exp())).abs() < 1e-9);
    }

    #[test]
    fn the_nominal_parameters_give_the_nominal_grid() {
        let p = ema_monitor::EmaParams::NOMINAL;
        let grid =
            PositionGrid::of(crate::params::widen(p.position_resolution_rad), crate::params::widen(p.end_stop_rad));
        assert_eq!(grid, PositionGrid::NOMINAL);
        // a coarser transducer over a shorter travel
        let coarse = PositionGrid::of(1.0e-4, 0.3);
        assert_eq!(coarse.half_codes, 3000.0);
        assert_eq!(coarse.quantize(1.0), 2999.0 * coarse.lsb_rad);
    }

    #[test]
    fn position_resolution_is_the_shared_parameter() {
        let shared = f64::from(ema_monitor::EmaParams::NOMINAL.position_resolution_rad);
        assert!((position_lsb_rad() - shared).abs() < 1e-12, "{} vs {shared}", position_lsb_rad());
    }
}
