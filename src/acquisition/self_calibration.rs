//! Self-calibration of the current sensors: each phase's zero point measured on the frames before
//! the trigger, with the actuator at rest, and the gains checked against each other by the sum rule
//! over the manoeuvre.
//!
//! **Zero points** ([`RestEstimator`]). A Hall sensor's zero error and its supply's tolerance move
//! the code of zero current by tens of millivolts, more than the sum rule's 0.3 A tolerance
//! leaves each phase (about 8 mV at 82.5 mV/A): a declared mid-scale zero would refuse every
//! frame. Before the trigger the actuator is at rest and its drive idle, so every phase carries
//! zero current and its code is its zero point plus noise. The estimator keeps integer sums of
//! the codes and of their squares over the last [`REST_BLOCK_FRAMES`] to `2·REST_BLOCK_FRAMES`
//! frames before the trigger (two alternating blocks), so the mean is exact, the same on every
//! target, and older frames (the actuator may have been moving) drop out. At the trigger
//! ([`RestEstimator::zero_points`]) each phase's zero is the mean code, in Q16.16, rounded to
//! nearest. It is refused, naming the phase, when
//! - fewer than [`SelfCalibrationConfig::min_rest_frames`] frames came before the trigger;
//! - a phase's codes spread by more than [`SelfCalibrationConfig::max_rest_sd_counts`] (standard
//!   deviation): the actuator was not at rest, or the sensor is noisy beyond its declaration;
//! - a zero lies more than [`SelfCalibrationConfig::max_zero_shift_counts`] from the declared one:
//!   beyond what a sensor's zero error explains, the channel is broken or miswired, and the
//!   shifted zero would also eat that much of the measuring range on one side.
//!
//! **Gains** ([`GainCheck`]). The true currents sum to zero; measured through gains `g_j` they
//! read `m_j = g_j·i_j` and sum to `s = m_a + m_b + m_c`. With `i_c = −i_a − i_b`,
//! `s = (1 − g_c/g_a)·m_a + (1 − g_c/g_b)·m_b` exactly: a least-squares fit of two coefficients
//! `c_j` over the manoeuvre's good frames gives the gain ratios `g_j/g_c = 1/(1 − c_j)`. Each
//! phase's mismatch is then its gain against the median of the three, minus 1. A mismatch beyond [`MAX_GAIN_MISMATCH`] names
//! the phase; a manoeuvre whose currents do not span both regressors (a 2×2 system whose
//! determinant is below [`MIN_GAIN_CONDITION`] of its diagonal's product) leaves the gains
//! unchecked (NaN), which is not a fault. A common gain error of all three phases does not show in
//! the sum rule and is not checked.
//!
//! A refused calibration makes the flight a sensor fault ([`SensorCheck::fault`]): its frames are
//! still read, through the declared calibration, and counted, so the report says how the
//! recording looked as well as why it is not diagnosed.

use core::fmt;

use super::{Calibration, Phase, PhaseCalibration};
use crate::trace::ADC_MAX;

/// Frames in each of the estimator's two blocks (51.2 ms at 10 kHz): the zero points are the mean
/// of the last 512 to 1023 frames before the trigger.
pub const REST_BLOCK_FRAMES: u32 = 512;

/// Largest gain mismatch of a phase against the median of the three: 3 %, the sum rule's 0.3 A
/// tolerance at 10 A. The gain check runs on every recording, whatever its zero points.
pub const MAX_GAIN_MISMATCH: f32 = 0.03;

/// Smallest determinant of the gain check's normal equations, as a fraction of the product of
/// their diagonal: below it, the manoeuvre's currents leave the two gain differences unresolved.
pub const MIN_GAIN_CONDITION: f32 = 0.05;

/// Limits of the self-calibration (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SelfCalibrationConfig {
    /// Rest frames needed before the trigger (default 256: 25.6 ms at 10 kHz, which puts the
    /// mean's standard error below 0.2 count at the nominal 2-count noise).
    pub min_rest_frames: u32,
    /// Largest shift of a zero from the declared one (default 100 counts: 81 mV of a 3.3 V
    /// 12-bit ADC, 0.98 A at the nominal gain, above the tens of millivolts of a Hall sensor's
    /// zero error and its supply's tolerance).
    pub max_zero_shift_counts: u16,
    /// Largest standard deviation of a phase's codes at rest (default 8 counts, 0.08 A: four
    /// times the nominal sensor noise).
    pub max_rest_sd_counts: f32,
}

impl SelfCalibrationConfig {
    /// The defaults (their reasons on each field).
    pub const DEFAULT: Self = Self { min_rest_frames: 256, max_zero_shift_counts: 100, max_rest_sd_counts: 8.0 };

    /// `true` when every limit is positive (finite where it is a float).
    pub fn is_valid(&self) -> bool {
        self.min_rest_frames > 0
            && self.max_zero_shift_counts > 0
            && self.max_rest_sd_counts.is_finite()
            && self.max_rest_sd_counts > 0.0
    }
}

impl Default for SelfCalibrationConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Why the sensors' calibration is not trusted.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SensorFault {
    /// Fewer rest frames came before the trigger than the zero points need.
    TooFewRestFrames {
        /// Rest frames seen.
        frames: u32,
        /// Rest frames needed ([`SelfCalibrationConfig::min_rest_frames`]).
        needed: u32,
    },
    /// A phase's codes spread too much before the trigger: not at rest, or too noisy.
    NotAtRest {
        /// The phase.
        phase: Phase,
        /// Its codes' standard deviation at rest.
        sd_counts: f32,
    },
    /// A phase's zero lies beyond what self-calibration corrects.
    ZeroBeyondRange {
        /// The phase.
        phase: Phase,
        /// Its measured zero minus the declared one.
        shift_counts: f32,
    },
    /// A phase's gain differs from the others' by more than the sum rule allows.
    GainMismatch {
        /// The phase.
        phase: Phase,
        /// Its gain against the median of the three, minus 1.
        mismatch: f32,
    },
}

impl SensorFault {
    /// The phase the fault names (`None` for too few rest frames, which concerns all three).
    pub const fn phase(&self) -> Option<Phase> {
        match self {
            SensorFault::TooFewRestFrames { .. } => None,
            SensorFault::NotAtRest { phase, .. }
            | SensorFault::ZeroBeyondRange { phase, .. }
            | SensorFault::GainMismatch { phase, .. } => Some(*phase),
        }
    }
}

impl fmt::Display for SensorFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SensorFault::TooFewRestFrames { frames, needed } => {
                write!(f, "{frames} rest frames before the trigger, {needed} needed for the zero points")
            }
            SensorFault::NotAtRest { phase, sd_counts } => {
                write!(f, "phase {phase} not at rest before the trigger (sd {sd_counts:.1} counts)")
            }
            SensorFault::ZeroBeyondRange { phase, shift_counts } => {
                write!(f, "phase {phase} zero {shift_counts:+.1} counts from the declared one, beyond self-calibration")
            }
            SensorFault::GainMismatch { phase, mismatch } => {
                write!(f, "phase {phase} gain {:+.1} % off the other phases (sum rule)", mismatch * 100.0)
            }
        }
    }
}

/// Where the zero points of a recording come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ZeroSource {
    /// The declared calibration: no self-calibration configured (a replay without rest frames).
    #[default]
    Declared,
    /// Measured on the rest frames before the trigger.
    Rest,
}

/// What the sensors' self-calibration found: the zero points in use, the gain check, and the
/// fault that makes the flight a sensor fault, if any.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorCheck {
    /// Where the zero points come from.
    pub source: ZeroSource,
    /// Each phase's zero in use minus the declared one (counts; 0 when declared).
    pub zero_shift_counts: [f32; 3],
    /// Each phase's codes' standard deviation at rest (counts; NaN when declared).
    pub rest_sd_counts: [f32; 3],
    /// Rest frames the zero points were measured on (0 when declared).
    pub rest_frames: u32,
    /// Each phase's gain against the median of the three, minus 1 (NaN when the manoeuvre does
    /// not resolve them).
    pub gain_mismatch: [f32; 3],
    /// Why the calibration is not trusted.
    pub fault: Option<SensorFault>,
}

impl SensorCheck {
    /// The declared calibration, gains not checked, no fault.
    pub const DECLARED: Self = Self {
        source: ZeroSource::Declared,
        zero_shift_counts: [0.0; 3],
        rest_sd_counts: [f32::NAN; 3],
        rest_frames: 0,
        gain_mismatch: [f32::NAN; 3],
        fault: None,
    };

    /// The check with the gain check's result: its mismatches, and its fault when no earlier one
    /// was found.
    pub fn with_gains(self, mismatch: [f32; 3], limit: f32) -> Self {
        let fault = self.fault.or_else(|| {
            let worst = Phase::ALL
                .into_iter()
                .max_by(|a, b| libm::fabsf(mismatch[a.index()]).total_cmp(&libm::fabsf(mismatch[b.index()])))?;
            let m = mismatch[worst.index()];
            (libm::fabsf(m) > limit).then_some(SensorFault::GainMismatch { phase: worst, mismatch: m })
        });
        Self { gain_mismatch: mismatch, fault, ..self }
    }
}

impl Default for SensorCheck {
    fn default() -> Self {
        Self::DECLARED
    }
}

/// Integer sums of one block of rest frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct RestBlock {
    frames: u32,
    sum: [u64; 3],
    sum_sq: [u64; 3],
}

impl RestBlock {
    const EMPTY: Self = Self { frames: 0, sum: [0; 3], sum_sq: [0; 3] };
}

/// The zero points' estimator: integer sums of the last rest frames' codes (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RestEstimator {
    blocks: [RestBlock; 2],
    current: usize,
}

impl RestEstimator {
    /// No frame yet.
    pub const fn new() -> Self {
        Self { blocks: [RestBlock::EMPTY; 2], current: 0 }
    }

    /// Adds one rest frame's codes (codes above `ADC_MAX` are left out: a broken driver's).
    pub fn add(&mut self, codes: [u16; 3]) {
        if codes.iter().any(|&c| c > ADC_MAX) {
            return;
        }
        if self.blocks[self.current & 1].frames >= REST_BLOCK_FRAMES {
            self.current = (self.current + 1) & 1;
            self.blocks[self.current & 1] = RestBlock::EMPTY;
        }
        let block = &mut self.blocks[self.current & 1];
        block.frames += 1;
        for (j, &c) in codes.iter().enumerate() {
            let c = u64::from(c);
            block.sum[j] += c;
            block.sum_sq[j] += c * c;
        }
    }

    /// Rest frames the estimate covers (at most `2·REST_BLOCK_FRAMES`).
    pub fn frames(&self) -> u32 {
        self.blocks[0].frames + self.blocks[1].frames
    }

    /// The calibration with the measured zero points (the declared gains kept), and what was
    /// found; or the declared calibration and the fault that refuses the zero points.
    pub fn zero_points(&self, declared: &Calibration, config: &SelfCalibrationConfig) -> (Calibration, SensorCheck) {
        let n = self.frames();
        let refused = |fault| (*declared, SensorCheck { fault: Some(fault), ..SensorCheck::DECLARED });
        if n < config.min_rest_frames || n == 0 {
            return refused(SensorFault::TooFewRestFrames { frames: n, needed: config.min_rest_frames });
        }
        let n64 = u64::from(n);
        let mut check = SensorCheck { source: ZeroSource::Rest, rest_frames: n, ..SensorCheck::DECLARED };
        let mut phases = [PhaseCalibration::NOMINAL; 3];
        for phase in Phase::ALL {
            let j = phase.index();
            let sum = self.blocks[0].sum[j] + self.blocks[1].sum[j];
            let sum_sq = self.blocks[0].sum_sq[j] + self.blocks[1].sum_sq[j];
            // n·Σx² − (Σx)² ≥ 0 exactly (Cauchy–Schwarz); both terms < 2^45 for n ≤ 1024
            let spread = (n64 * sum_sq).saturating_sub(sum * sum);
            let sd = libm::sqrtf(spread as f32) / n as f32;
            check.rest_sd_counts[j] = sd;
            if sd > config.max_rest_sd_counts {
                return refused(SensorFault::NotAtRest { phase, sd_counts: sd });
            }
            // the mean in Q16.16, rounded to nearest: (Σx·2^16 + n/2) / n < 4096·2^16
            let bits = ((sum << 16) + n64 / 2) / n64;
            let offset = super::OffsetCounts::from_bits(i32::try_from(bits).unwrap_or(i32::MAX));
            let declared_phase = declared.phase(phase);
            let shift = (offset - declared_phase.offset_counts()).to_num::<f32>();
            check.zero_shift_counts[j] = shift;
            if libm::fabsf(shift) > f32::from(config.max_zero_shift_counts) {
                return refused(SensorFault::ZeroBeyondRange { phase, shift_counts: shift });
            }
            match PhaseCalibration::new(offset, declared_phase.gain_a_per_count()) {
                Ok(p) => phases[j] = p,
                Err(_) => return refused(SensorFault::ZeroBeyondRange { phase, shift_counts: shift }),
            }
        }
        (Calibration::new(phases[0], phases[1], phases[2]), check)
    }
}

impl Default for RestEstimator {
    fn default() -> Self {
        Self::new()
    }
}

/// The gain check's sums over the manoeuvre's good frames (module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GainCheck {
    aa: f32,
    bb: f32,
    ab: f32,
    sa: f32,
    sb: f32,
}

impl GainCheck {
    /// No frame yet.
    pub const fn new() -> Self {
        Self { aa: 0.0, bb: 0.0, ab: 0.0, sa: 0.0, sb: 0.0 }
    }

    /// Adds one good frame's currents.
    pub fn add(&mut self, [ia, ib, ic]: [f32; 3]) {
        let s = ia + ib + ic;
        self.aa += ia * ia;
        self.bb += ib * ib;
        self.ab += ia * ib;
        self.sa += s * ia;
        self.sb += s * ib;
    }

    /// Each phase's gain against the median of the three, minus 1; NaN for all three when the
    /// frames do not resolve the two gain differences.
    pub fn mismatch(&self) -> [f32; 3] {
        let det = self.aa * self.bb - self.ab * self.ab;
        // also NaN sums (a non-finite frame) and no frames at all
        let resolved = det > MIN_GAIN_CONDITION * self.aa * self.bb;
        if !resolved {
            return [f32::NAN; 3];
        }
        // the coefficients (c_a, c_b) by Cramer's rule; c_j = 1 − g_c/g_j, so g_j/g_c = 1/(1 − c_j)
        let ca = (self.sa * self.bb - self.sb * self.ab) / det;
        let cb = (self.aa * self.sb - self.ab * self.sa) / det;
        let ratios = [1.0 / (1.0 - ca), 1.0 / (1.0 - cb), 1.0];
        let median = median3(ratios[0], ratios[1], ratios[2]);
        ratios.map(|r| r / median - 1.0)
    }
}

/// The median of three finite numbers.
fn median3(a: f32, b: f32, c: f32) -> f32 {
    a.max(b).min(a.min(b).max(c))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acquisition::calibration::OffsetCounts;
    use crate::optimizer::rng::Rng;

    fn rest(zero: [f32; 3], sd: f32, frames: u32, seed: u64) -> RestEstimator {
        let mut rng = Rng::new(seed);
        let mut est = RestEstimator::new();
        for _ in 0..frames {
            est.add(zero.map(|z| libm::roundf(z + sd * rng.normal()).clamp(0.0, 4095.0) as u16));
        }
        est
    }

    #[test]
    fn zero_points_are_the_rest_means_over_several_seeds() {
        let zero = [2066.3, 2035.6, 2060.2];
        for seed in 1..=8 {
            let (cal, check) =
                rest(zero, 2.0, 700, seed).zero_points(&Calibration::NOMINAL, &SelfCalibrationConfig::DEFAULT);
            assert_eq!((check.source, check.fault, check.rest_frames), (ZeroSource::Rest, None, 700));
            for phase in Phase::ALL {
                let j = phase.index();
                let offset = cal.phase(phase).offset_counts().to_num::<f32>();
                // standard error 2/√700 = 0.076 count: 5 of them
                assert!((offset - zero[j]).abs() < 0.4, "seed {seed} phase {phase}: {offset} vs {}", zero[j]);
                assert!((check.zero_shift_counts[j] - (offset - 2048.0)).abs() < 1e-3);
                assert!((check.rest_sd_counts[j] - 2.0).abs() < 0.3, "{:?}", check.rest_sd_counts);
            }
        }
    }

    #[test]
    fn the_mean_is_exact_and_rounded_to_nearest() {
        let mut est = RestEstimator::new();
        for c in [2050u16, 2051, 2051] {
            est.add([c, 2048, 100]);
        }
        let config =
            SelfCalibrationConfig { min_rest_frames: 3, max_zero_shift_counts: 2000, ..SelfCalibrationConfig::DEFAULT };
        let (cal, check) = est.zero_points(&Calibration::NOMINAL, &config);
        assert_eq!(check.fault, None);
        // 6152/3 = 2050.666…: 2050 + round(0.666…·65536)/65536
        assert_eq!(cal.phase(Phase::A).offset_counts(), OffsetCounts::from_bits((2050 << 16) + 43691));
        assert_eq!(cal.phase(Phase::B).offset_counts(), 2048);
        assert_eq!(cal.phase(Phase::C).offset_counts(), 100);
        assert_eq!(cal.phase(Phase::A).gain_a_per_count(), PhaseCalibration::NOMINAL.gain_a_per_count());
    }

    #[test]
    fn only_the_last_blocks_count() {
        // a moving actuator long before the trigger, then 600 frames at rest
        let mut est = rest([1500.0, 2600.0, 2048.0], 40.0, 3000, 3);
        let mut rng = Rng::new(4);
        for _ in 0..600 {
            est.add([2040.0, 2050.0, 2048.0].map(|z: f32| libm::roundf(z + rng.normal()) as u16));
        }
        assert!(est.frames() >= REST_BLOCK_FRAMES && est.frames() < 2 * REST_BLOCK_FRAMES);
        let (cal, check) = est.zero_points(&Calibration::NOMINAL, &SelfCalibrationConfig::DEFAULT);
        assert_eq!(check.fault, None, "{check:?}");
        assert!((cal.phase(Phase::A).offset_counts().to_num::<f32>() - 2040.0).abs() < 0.3);
    }

    #[test]
    fn a_calibration_that_cannot_be_trusted_names_the_phase() {
        let c = SelfCalibrationConfig::DEFAULT;
        let declared = Calibration::NOMINAL;
        let fault = |est: RestEstimator| est.zero_points(&declared, &c).1.fault;
        // ten times the correctable shift on phase B
        let far = 2048.0 - 10.0 * f32::from(c.max_zero_shift_counts);
        assert!(matches!(
            fault(rest([2050.0, far, 2047.0], 2.0, 600, 5)),
            Some(SensorFault::ZeroBeyondRange { phase: Phase::B, shift_counts }) if (shift_counts + 1000.0).abs() < 1.0
        ));
        assert!(matches!(fault(rest([2050.0, 2040.0, 2047.0], 30.0, 600, 6)).map(|f| f.phase()), Some(Some(_))));
        assert!(matches!(
            fault(rest([2050.0, 2040.0, 2047.0], 2.0, 100, 7)),
            Some(SensorFault::TooFewRestFrames { frames: 100, needed: 256 })
        ));
        // the refused calibration is the declared one
        let (cal, check) = rest([2050.0, far, 2047.0], 2.0, 600, 5).zero_points(&declared, &c);
        assert_eq!((cal, check.source), (declared, ZeroSource::Declared));
    }

    #[test]
    fn the_sum_rule_resolves_gain_differences_and_names_the_outlier() {
        // three-phase currents of a rotating field with gain errors; each seed a different phase
        for (seed, gains) in [(1u64, [0.01f32, -0.008, 0.005]), (2, [0.0, 0.06, 0.0]), (3, [-0.05, 0.0, 0.004])] {
            let mut rng = Rng::new(seed);
            let mut check = GainCheck::new();
            for k in 0..8000 {
                let th = k as f32 * 0.01;
                let amp = 6.0;
                let true_i = [0.0f32, -2.094_395, 2.094_395].map(|p| amp * libm::sinf(th + p));
                let measured: [f32; 3] = core::array::from_fn(|j| (1.0 + gains[j]) * true_i[j] + 0.02 * rng.normal());
                check.add(measured);
            }
            let m = check.mismatch();
            let median = median3(gains[0], gains[1], gains[2]);
            for j in 0..3 {
                assert!(
                    (m[j] - ((1.0 + gains[j]) / (1.0 + median) - 1.0)).abs() < 1e-3,
                    "seed {seed}: {m:?} vs {gains:?}"
                );
            }
            let out = SensorCheck::DECLARED.with_gains(m, MAX_GAIN_MISMATCH);
            match seed {
                1 => assert_eq!(out.fault, None),
                2 => assert!(matches!(out.fault, Some(SensorFault::GainMismatch { phase: Phase::B, .. }))),
                _ => assert!(matches!(out.fault, Some(SensorFault::GainMismatch { phase: Phase::A, .. }))),
            }
        }
    }

    #[test]
    fn currents_that_do_not_resolve_the_gains_leave_them_unchecked() {
        let mut check = GainCheck::new();
        for k in 0..1000 {
            let i = (k % 7) as f32 - 3.0;
            check.add([i, -i, 0.0]); // phase C never conducts: i_b = −i_a, collinear
        }
        assert!(check.mismatch().iter().all(|m| m.is_nan()));
        assert!(GainCheck::new().mismatch().iter().all(|m| m.is_nan()));
        let out = SensorCheck::DECLARED.with_gains([f32::NAN; 3], 0.03);
        assert_eq!(out.fault, None);
    }
}
