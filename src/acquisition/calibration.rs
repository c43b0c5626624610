//! Per-phase offset/gain calibration, counts → amperes, in fixed point (the `fixed` crate).
//!
//! `i = (code − offset_counts) · gain_a_per_count`, computed exactly in fixed point, then rounded
//! once to `f32`:
//!
//! | quantity | type | Q format | resolution | range |
//! |----------|------|----------|------------|-------|
//! | `offset_counts` | [`OffsetCounts`] = `I16F16` | signed Q16.16 | 2⁻¹⁶ count ≈ 1.5·10⁻⁵ count | validated to `(0, ADC_MAX)` |
//! | `gain_a_per_count` | [`GainAmpsPerCount`] = `U0F32` | unsigned Q0.32 | 2⁻³² A/count ≈ 2.3·10⁻¹⁰ A/count | validated to `(0, 1)` A/count |
//! | `code − offset` | `I16F16` | signed Q16.16 | exact | ±4095 counts |
//! | current | [`AmpsFixed`] = `I16F48` | signed Q16.48 | exact product (2⁻⁴⁸ A) | ±4095 A |
//!
//! The product of a Q16.16 and a Q0.32 number is exact in Q16.48 (`wide_mul_unsigned`: one
//! 32×32→64-bit multiply, no rounding, no overflow possible for valid inputs), so the only errors
//! are the quantization of the calibration constants themselves and the final rounding to `f32`.
//! Against an exact (real-number) calibration with the same `f32`-given constants, the result is
//! off by at most
//!
//! `|code − offset|·2⁻³³ + gain·2⁻¹⁷  (≤ 4095·1.2·10⁻¹⁰ + 1·7.6·10⁻⁶ A; ≤ 5.5·10⁻⁷ A at the nominal gain)`
//!
//! plus half an `f32` ulp of the result (≤ 1.9·10⁻⁶ A at 40 A): well below one ADC count
//! (9.8·10⁻³ A). The nominal constants (`offset = ADC_MIDSCALE = 2048`, `gain = 40/4096 = 5·2⁻⁹`) are
//! exact in these formats, so the nominal conversion equals [`crate::trace::counts_to_amps`].

use fixed::types::{I16F16, I16F48, U0F32};

use super::{ConfigError, Phase};
use crate::trace::{ADC_MAX, ADC_MIDSCALE, AMPS_PER_COUNT};

/// ADC code of zero current, signed Q16.16 (resolution 2⁻¹⁶ count).
pub type OffsetCounts = I16F16;
/// Amperes per ADC count, unsigned Q0.32 (resolution 2⁻³² A/count, range `[0, 1)`).
pub type GainAmpsPerCount = U0F32;
/// A phase current in amperes, signed Q16.48: the exact product `(code − offset)·gain`.
pub type AmpsFixed = I16F48;

/// Offset and gain of one phase-current channel, validated at construction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PhaseCalibration {
    offset: OffsetCounts,
    gain: GainAmpsPerCount,
}

/// `AMPS_PER_COUNT` (5·2⁻⁹) in Q0.32, computed at compile time and exact.
const NOMINAL_GAIN_BITS: u32 = (AMPS_PER_COUNT as f64 * 4_294_967_296.0) as u32;

impl PhaseCalibration {
    /// The nominal sensor: offset [`ADC_MIDSCALE`], gain [`AMPS_PER_COUNT`] (both exact).
    pub const NOMINAL: Self = Self {
        offset: OffsetCounts::from_bits((ADC_MIDSCALE as i32) << 16),
        gain: GainAmpsPerCount::from_bits(NOMINAL_GAIN_BITS),
    };

    /// Checks and builds a calibration from fixed-point constants: the offset must lie strictly
    /// inside `(0, ADC_MAX)` ([`ConfigError::Offset`]) and the gain must be non-zero
    /// ([`ConfigError::Gain`]).
    pub fn new(offset_counts: OffsetCounts, gain_a_per_count: GainAmpsPerCount) -> Result<Self, ConfigError> {
        if offset_counts <= OffsetCounts::ZERO || offset_counts >= OffsetCounts::from_bits(i32::from(ADC_MAX) << 16) {
            return Err(ConfigError::Offset);
        }
        if gain_a_per_count == GainAmpsPerCount::ZERO {
            return Err(ConfigError::Gain);
        }
        Ok(Self { offset: offset_counts, gain: gain_a_per_count })
    }

    /// As [`PhaseCalibration::new`] from `f32` constants (e.g. from a calibration table), each
    /// rounded to the nearest fixed-point value. Non-finite values, a gain outside `(0, 1)` A/count
    /// or one below the Q0.32 resolution are refused.
    pub fn from_f32(offset_counts: f32, gain_a_per_count: f32) -> Result<Self, ConfigError> {
        if !offset_counts.is_finite() {
            return Err(ConfigError::Offset);
        }
        let offset = OffsetCounts::checked_from_num(offset_counts).ok_or(ConfigError::Offset)?;
        if !gain_a_per_count.is_finite() || gain_a_per_count <= 0.0 || gain_a_per_count >= 1.0 {
            return Err(ConfigError::Gain);
        }
        let gain = GainAmpsPerCount::checked_from_num(gain_a_per_count).ok_or(ConfigError::Gain)?;
        Self::new(offset, gain)
    }

    /// The zero-current code.
    pub const fn offset_counts(&self) -> OffsetCounts {
        self.offset
    }

    /// The amperes per count.
    pub const fn gain_a_per_count(&self) -> GainAmpsPerCount {
        self.gain
    }

    /// `(code − offset)·gain`, exact in Q16.48. Codes above `ADC_MAX` are clamped to it (the reader
    /// rejects them before converting).
    pub fn to_amps_fixed(&self, code: u16) -> AmpsFixed {
        let code = I16F16::from_bits(i32::from(code.min(ADC_MAX)) << 16);
        // |code − offset| < 4096: no wrap can occur; `wrapping_sub` only documents that it cannot panic.
        code.wrapping_sub(self.offset).wide_mul_unsigned(self.gain)
    }

    /// [`PhaseCalibration::to_amps_fixed`] rounded to the nearest `f32`.
    pub fn to_amps(&self, code: u16) -> f32 {
        self.to_amps_fixed(code).to_num::<f32>()
    }

    /// The code nearest to the offset (the code of zero current), for the stuck-channel rule.
    pub(crate) fn zero_code(&self) -> u16 {
        // offset > 0 (validated): adding one half and truncating rounds to nearest
        let c = self.offset.to_bits().saturating_add(1 << 15) >> 16;
        u16::try_from(c).unwrap_or(ADC_MIDSCALE)
    }
}

impl Default for PhaseCalibration {
    fn default() -> Self {
        Self::NOMINAL
    }
}

/// The calibrations of phases A, B, C.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Calibration {
    phases: [PhaseCalibration; 3],
}

impl Calibration {
    /// All three phases nominal.
    pub const NOMINAL: Self = Self { phases: [PhaseCalibration::NOMINAL; 3] };

    /// The three (already validated) phase calibrations, in order A, B, C.
    pub const fn new(a: PhaseCalibration, b: PhaseCalibration, c: PhaseCalibration) -> Self {
        Self { phases: [a, b, c] }
    }

    /// Calibration of one phase.
    pub const fn phase(&self, phase: Phase) -> &PhaseCalibration {
        &self.phases[phase.index()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::counts_to_amps;

    #[test]
    fn nominal_constants_are_exact() {
        let n = PhaseCalibration::NOMINAL;
        assert_eq!(n.offset_counts(), 2048);
        assert_eq!(n.gain_a_per_count().to_num::<f64>(), f64::from(AMPS_PER_COUNT));
        assert_eq!(n.zero_code(), ADC_MIDSCALE);
        assert_eq!(PhaseCalibration::from_f32(2048.0, AMPS_PER_COUNT), Ok(n));
    }

    #[test]
    fn nominal_conversion_is_analytic() {
        let n = PhaseCalibration::NOMINAL;
        assert_eq!(n.to_amps(2048), 0.0);
        assert_eq!(n.to_amps(2049), 40.0 / 4096.0);
        assert_eq!(n.to_amps(0), -20.0);
        assert_eq!(n.to_amps(ADC_MAX), 20.0 - 40.0 / 4096.0);
        assert_eq!(n.to_amps(u16::MAX), n.to_amps(ADC_MAX));
        for c in 0..=ADC_MAX {
            assert_eq!(n.to_amps(c), counts_to_amps(c), "code {c}");
        }
    }

    #[test]
    fn offset_and_gain_shift_and_scale() {
        // offset 2000.5 counts, gain 0.01 A/count: analytic values
        let cal = PhaseCalibration::from_f32(2000.5, 0.01).unwrap();
        assert!((cal.to_amps(2000) + 0.005).abs() < 1e-7);
        assert!((cal.to_amps(3000) - 9.995).abs() < 2e-6);
        assert_eq!(cal.zero_code(), 2001);
        assert_eq!(PhaseCalibration::from_f32(2000.49, 0.01).unwrap().zero_code(), 2000);
    }

    #[test]
    fn fixed_point_matches_float_within_stated_resolution() {
        // deterministic pseudo-random offsets, gains and codes (xorshift32)
        let mut s = 0x1234_5678u32;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            s
        };
        for _ in 0..20_000 {
            let offset = 1900.0 + (next() % 200_000) as f32 / 1000.0;
            let gain = 0.005 + (next() % 1_000_000) as f32 * 1e-8;
            let code = (next() % 4096) as u16;
            let cal = PhaseCalibration::from_f32(offset, gain).unwrap();
            let exact = (f64::from(code) - f64::from(offset)) * f64::from(gain);
            let got = f64::from(cal.to_amps(code));
            let bound = (f64::from(code) - f64::from(offset)).abs() * 2f64.powi(-33)
                + f64::from(gain) * 2f64.powi(-17)
                + exact.abs() * 2f64.powi(-24)
                + 1e-12;
            assert!((got - exact).abs() <= bound, "code {code} offset {offset} gain {gain}: {got} vs {exact}");
        }
    }

    #[test]
    fn invalid_constants_are_refused() {
        assert_eq!(PhaseCalibration::from_f32(f32::NAN, 0.01), Err(ConfigError::Offset));
        assert_eq!(PhaseCalibration::from_f32(0.0, 0.01), Err(ConfigError::Offset));
        assert_eq!(PhaseCalibration::from_f32(4095.0, 0.01), Err(ConfigError::Offset));
        assert_eq!(PhaseCalibration::from_f32(-3.0, 0.01), Err(ConfigError::Offset));
        assert_eq!(PhaseCalibration::from_f32(1e9, 0.01), Err(ConfigError::Offset));
        assert_eq!(PhaseCalibration::from_f32(2048.0, 0.0), Err(ConfigError::Gain));
        assert_eq!(PhaseCalibration::from_f32(2048.0, -0.01), Err(ConfigError::Gain));
        assert_eq!(PhaseCalibration::from_f32(2048.0, 1.0), Err(ConfigError::Gain));
        assert_eq!(PhaseCalibration::from_f32(2048.0, f32::INFINITY), Err(ConfigError::Gain));
        assert_eq!(PhaseCalibration::from_f32(2048.0, 1e-11), Err(ConfigError::Gain));
        assert_eq!(PhaseCalibration::new(OffsetCounts::ZERO, GainAmpsPerCount::MAX), Err(ConfigError::Offset));
        assert_eq!(PhaseCalibration::new(OffsetCounts::from_num(10), GainAmpsPerCount::ZERO), Err(ConfigError::Gain));
    }
}
