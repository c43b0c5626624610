//! Current conditioning: three phase currents → the equivalent current `I_3eq`, block-averaged to
//! the fitness rate, plus the paper's derivative weights.
//!
//! **Definition of `I_3eq`** (the "envelope of the three phase currents" of the paper):
//! `I_3eq = ½·(|i_a| + |i_b| + |i_c|)`. With an isolated star (`Σ i_j = 0`) it equals the sum of
//! the positive phase currents, i.e. the current through the conducting pair during six-step
//! commutation; it is unsigned, so the monitor model's equivalent current is compared through its
//! magnitude `|I|`. It needs no rotor angle, so it is computable from the ADC alone.
//!
//! **Filtering and decimation**: `DECIMATION` consecutive frames (at the control rate) are averaged
//! into one window sample (a boxcar filter that also removes most of the hysteresis ripple). The
//! monitor model's output goes through the *same* block mean, so the comparison is like for like.
//!
//! **Weights** (paper §VI): `w_i = 1 / (1 + (İ_i / C)²)` where `İ_i` is the central-difference
//! derivative of the measured window and `C` its RMS over the window. Samples where the measured
//! current changes fast count less: a small phase lag there would otherwise dominate the error.

use heapless::Vec;

use crate::params::EmaParams;

pub use crate::envelope::{folded_normal_mean_a, MeasuredEnvelope, SensorErrorEnvelope};

/// Frames averaged into one window sample (10 kHz control rate → 2.5 kHz fitness rate).
pub const DECIMATION: usize = 4;

/// Window capacity of the on-board identification: the standard 0.85 s manoeuvre is 2125 window
/// samples at 2.5 kHz; 2200 leaves room for a slightly longer recording.
pub const ONBOARD_WINDOW: usize = 2200;

/// Fewest window samples an identification accepts (20 ms at 2.5 kHz).
pub const MIN_SAMPLES: usize = 50;

/// The step of an empty window's codes (A), 2⁻¹⁶: it doubles as larger samples come
/// ([`ConditionedWindow`]).
pub const FIRST_STEP_A: f32 = 1.0 / 65536.0;

/// Largest window sample (A) a window stores: a larger (or negative) one is refused
/// ([`ConditioningError::OutOfRange`]).
pub const MAX_SAMPLE_A: f32 = 1.0e6;

/// Largest code of a window sample.
const MAX_CODE: f32 = u16::MAX as f32;

/// Equivalent single-phase current `I_3eq = ½(|i_a| + |i_b| + |i_c|)`.
pub fn equivalent_current_a(ia_a: f32, ib_a: f32, ic_a: f32) -> f32 {
    0.5 * (libm::fabsf(ia_a) + libm::fabsf(ib_a) + libm::fabsf(ic_a))
}

/// Why conditioning refused its input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConditioningError {
    /// A phase current was NaN or infinite.
    NonFinite,
    /// More frames than the window can hold.
    WindowFull,
    /// Fewer than [`MIN_SAMPLES`] window samples.
    TooShort,
    /// The measured current never changes: nothing to identify from.
    NoExcitation,
    /// A frame came after the window was closed, or the window is used before it was closed.
    Finished,
    /// A window sample is negative or above [`MAX_SAMPLE_A`] (a rebuilt window's sample, or a
    /// frame of currents beyond any actuator's).
    OutOfRange,
}

impl core::fmt::Display for ConditioningError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ConditioningError::NonFinite => "a phase current is NaN or infinite",
            ConditioningError::WindowFull => "the trace is longer than the conditioning window",
            ConditioningError::TooShort => "the trace is too short to identify from",
            ConditioningError::NoExcitation => "the measured current never changes: no excitation",
            ConditioningError::Finished => "the window is closed (frames after finish) or not closed yet",
            ConditioningError::OutOfRange => "a window sample is negative or above 1e6 A",
        })
    }
}

impl core::error::Error for ConditioningError {}

/// The conditioned measurement: window samples of `I_3eq` and their fitness weights.
///
/// Filled in place (no copy of the window ever exists): [`ConditionedWindow::push`] frames in, then
/// [`ConditionedWindow::finish`] closes the window and takes the derivative's mean square `C²`. Only
/// a finished trace is identified from.
///
/// **Storage**: 2 bytes a sample (4.4 KB for [`ONBOARD_WINDOW`]), the half of an `f32`'s. Each
/// sample is a 16-bit code of the window's scale, `y_i = c_i·Δ`, where the step `Δ` is a power of
/// two: it starts at [`FIRST_STEP_A`] and doubles whenever a sample would need a code above
/// 65 535, every code stored so far halved (rounded half up). So the step ends as the smallest
/// power of two the window's largest sample fits under: 16 bits relative to the window's range
/// whatever the actuator's current (0.49 mA for the nominal actuator's 16–32 A range), with no
/// setting. The rounding adds a uniform error of `Δ/√12` (0.14 mA nominal) to each sample, far
/// below the sensors' noise (20 mA a frame, 10 mA a window sample). `c_i·Δ` is exact in `f32`, so
/// every read gives the same bits on every target, and a window rebuilt from its samples
/// ([`ConditionedWindow::from_samples`]) has the same codes and step. (A `fixed` type would put
/// the binary point at compile time, for one range of currents; the step here follows the
/// recording.)
///
/// The weights are not stored: [`ConditionedWindow::sample`] computes `w_i` from the two neighbours
/// of sample `i` and `C²` each time it is read, for two divisions a sample in each model run.
/// The arithmetic is the same whenever it runs, so the weights are the same bit for bit on every
/// read and on every target.
#[derive(Clone, Debug, PartialEq)]
pub struct ConditionedWindow<const W: usize> {
    /// Sample `i` is `codes[i]·step_a`.
    codes: Vec<u16, W>,
    /// The codes' step `Δ` (A), a power of two.
    step_a: f32,
    /// `C²`, the mean square of the central-difference derivative; 0 until [`ConditionedWindow::finish`].
    derivative_mean_sq: f32,
    block_sum_a: f32,
    block_len: usize,
}

impl<const W: usize> Default for ConditionedWindow<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> ConditionedWindow<W> {
    /// An empty window.
    pub const fn new() -> Self {
        const { assert!(W >= MIN_SAMPLES, "the window must hold at least MIN_SAMPLES samples") };
        Self { codes: Vec::new(), step_a: FIRST_STEP_A, derivative_mean_sq: 0.0, block_sum_a: 0.0, block_len: 0 }
    }

    /// Window sample `i` in amperes.
    #[inline(always)]
    fn current_at(&self, i: usize) -> Option<f32> {
        self.codes.get(i).map(|&c| self.amperes(c))
    }

    /// The sample a code stands for (A), exact in `f32`.
    #[inline(always)]
    fn amperes(&self, code: u16) -> f32 {
        code as f32 * self.step_a
    }

    /// Stores the window sample `y_a` (A) as a code of the window's step, the step doubled (and
    /// the stored codes halved) until its code fits in 16 bits.
    fn store(&mut self, y_a: f32) -> Result<(), ConditioningError> {
        if !(0.0..=MAX_SAMPLE_A).contains(&y_a) {
            return Err(ConditioningError::OutOfRange);
        }
        if self.codes.is_full() {
            return Err(ConditioningError::WindowFull);
        }
        // y/Δ is exact (Δ a power of two); a code rounds to at most 65 535 below 65 535.5
        while y_a / self.step_a >= MAX_CODE + 0.5 {
            self.step_a *= 2.0;
            for c in self.codes.iter_mut() {
                *c = ((u32::from(*c) + 1) >> 1) as u16;
            }
        }
        let code = libm::roundf(y_a / self.step_a) as u16;
        self.codes.push(code).map_err(|_| ConditioningError::WindowFull)
    }

    /// Adds one frame of phase currents (amperes). Refused after [`ConditionedWindow::finish`].
    pub fn push(&mut self, ia_a: f32, ib_a: f32, ic_a: f32) -> Result<(), ConditioningError> {
        if self.is_finished() {
            return Err(ConditioningError::Finished);
        }
        if !(ia_a.is_finite() && ib_a.is_finite() && ic_a.is_finite()) {
            return Err(ConditioningError::NonFinite);
        }
        self.block_sum_a += equivalent_current_a(ia_a, ib_a, ic_a);
        self.block_len += 1;
        if self.block_len == DECIMATION {
            let mean = self.block_sum_a / DECIMATION as f32;
            self.block_sum_a = 0.0;
            self.block_len = 0;
            self.store(mean)?;
        }
        Ok(())
    }

    /// Closes the window (a trailing partial block is dropped) and takes the derivative's mean
    /// square `C²` that the weights are scaled by.
    pub fn finish(&mut self) -> Result<(), ConditioningError> {
        if self.is_finished() {
            return Ok(());
        }
        let n = self.codes.len();
        if n < MIN_SAMPLES {
            return Err(ConditioningError::TooShort);
        }
        let mut sum_sq = 0.0f32;
        for i in 0..n {
            let d = self.derivative(i);
            sum_sq += d * d;
        }
        let c_sq = sum_sq / n as f32;
        if c_sq.is_nan() || c_sq <= 0.0 || c_sq.is_infinite() {
            return Err(ConditioningError::NoExcitation);
        }
        self.derivative_mean_sq = c_sq;
        Ok(())
    }

    /// Central difference of the window at `i` (one-sided at the ends; the sample period
    /// cancels in `İ/C`). The window holds at least [`MIN_SAMPLES`] ≥ 2 samples once finished,
    /// so every index read is in range; a read past the end gives 0 only so that no panic path
    /// exists.
    #[inline(always)]
    fn derivative(&self, i: usize) -> f32 {
        let n = self.codes.len();
        let at = |j: usize| self.current_at(j).unwrap_or(0.0);
        let (a, b, span) = if i == 0 {
            (at(0), at(1), 1.0)
        } else if i + 1 == n {
            (at(n - 2), at(n - 1), 1.0)
        } else {
            (at(i - 1), at(i + 1), 2.0)
        };
        (b - a) / span
    }

    /// Window sample `i`: its `I_3eq` (A) and its fitness weight `w_i = 1/(1 + (İ_i/C)²)`, in
    /// `(0, 1]`. `None` past the end or before [`ConditionedWindow::finish`].
    #[inline(always)]
    pub fn sample(&self, i: usize) -> Option<(f32, f32)> {
        let y_i = self.current_at(i)?;
        if !self.is_finished() {
            return None;
        }
        let d = self.derivative(i);
        Some((y_i, 1.0 / (1.0 + d * d / self.derivative_mean_sq)))
    }

    /// The fitness weight of every window sample in turn (none before [`ConditionedWindow::finish`]).
    pub fn weights(&self) -> impl Iterator<Item = f32> + '_ {
        (0..self.len()).map_while(|i| self.sample(i).map(|(_, w)| w))
    }

    /// The closed window of the block means `samples` (as [`ConditionedWindow::current_a`] gives
    /// them), each stored as [`ConditionedWindow::push`] stores a block mean, its weights computed
    /// by [`ConditionedWindow::finish`]: the window a flight acquired, rebuilt bit for bit from its
    /// samples alone (a commissioning flight's window kept in flash; the type's doc says why the
    /// codes and step come out the same).
    pub fn from_samples(samples: impl IntoIterator<Item = f32>) -> Result<Self, ConditioningError> {
        let mut trace = Self::new();
        trace.rebuild(samples)?;
        Ok(trace)
    }

    /// [`ConditionedWindow::from_samples`] in place: whatever the window held is dropped first.
    pub fn rebuild(&mut self, samples: impl IntoIterator<Item = f32>) -> Result<(), ConditioningError> {
        self.codes.clear();
        (self.step_a, self.derivative_mean_sq, self.block_sum_a, self.block_len) = (FIRST_STEP_A, 0.0, 0.0, 0);
        for y in samples {
            if !y.is_finite() {
                return Err(ConditioningError::NonFinite);
            }
            self.store(y)?;
        }
        self.finish()
    }

    /// `true` once [`ConditionedWindow::finish`] succeeded.
    pub fn is_finished(&self) -> bool {
        self.derivative_mean_sq > 0.0
    }

    /// Block-averaged equivalent current (A), one value per complete window sample, in order.
    pub fn current_a(&self) -> impl ExactSizeIterator<Item = f32> + Clone + '_ {
        self.codes.iter().map(move |&c| self.amperes(c))
    }

    /// The step of the stored samples (A), a power of two: each is within half of it of the
    /// block mean it stores.
    pub fn step_a(&self) -> f32 {
        self.step_a
    }

    /// Number of complete window samples.
    pub fn len(&self) -> usize {
        self.codes.len()
    }

    /// `true` before the first complete window sample.
    pub fn is_empty(&self) -> bool {
        self.codes.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f32::consts::PI;

    #[test]
    fn each_sample_is_stored_within_half_a_step_on_a_scale_its_largest_sample_sets() {
        // windows of very different ranges: a quiet one, the nominal actuator's, a large actuator's
        let mut steps = [0.0f32; 3];
        for (n, scale_a) in [0.01f32, 12.0, 700.0].into_iter().enumerate() {
            let mut t = ConditionedWindow::<600>::new();
            let (mut means, mut block) = (std::vec::Vec::new(), 0.0f32);
            for j in 0..2000 {
                // rising: each larger sample coarsens the step over the codes stored before it
                let i = scale_a * (j as f32 / 2000.0) * (1.2 + libm::sinf(j as f32 * 0.05));
                t.push(i, -i, 0.0).unwrap();
                block += i; // I_3eq = ½(|i| + |−i| + 0)
                if j % DECIMATION == DECIMATION - 1 {
                    means.push(block / DECIMATION as f32);
                    block = 0.0;
                }
            }
            let step_a = t.step_a();
            steps[n] = step_a;
            assert_eq!(step_a, 2f32.powi(step_a.log2() as i32), "a power of two");
            // the smallest step the largest sample fits under, or the first one
            let max = means.iter().fold(0.0f32, |m, &y| m.max(y));
            assert!(max < 65535.5 * step_a, "{max} A at step {step_a}");
            assert!(step_a == FIRST_STEP_A || max >= 32767.75 * step_a, "{max} A at step {step_a}");
            for (y, mean) in t.current_a().zip(&means) {
                // a code rounded once, or rounded and then halved, is within one step; direct
                // rounding (no coarsening after it) within half of it
                assert!((y - mean).abs() <= step_a, "{y} for {mean} at step {step_a}");
            }
            let last = t.current_a().last().unwrap();
            assert!((last - means[means.len() - 1]).abs() <= 0.5 * step_a);
        }
        assert!(steps[0] == FIRST_STEP_A && steps[0] < steps[1] && steps[1] < steps[2], "{steps:?}");
    }

    #[test]
    fn samples_out_of_range_are_refused_and_the_window_left_as_it_was() {
        let mut t = ConditionedWindow::<100>::from_samples((0..60).map(|j| 1.0 + 0.1 * j as f32)).unwrap();
        let before = t.clone();
        for bad in [-0.001f32, MAX_SAMPLE_A * 1.01, f32::MAX] {
            assert_eq!(ConditionedWindow::<100>::from_samples([1.0, bad]).err(), Some(ConditioningError::OutOfRange));
            assert_eq!(t.rebuild((0..60).map(|j| if j == 30 { bad } else { 1.0 })), Err(ConditioningError::OutOfRange));
        }
        assert!(t.rebuild(before.current_a()).is_ok());
        assert_eq!(t, before);
        // the largest sample a window takes stores, on the coarsest step
        let big = ConditionedWindow::<100>::from_samples((0..60).map(|j| MAX_SAMPLE_A * j as f32 / 59.0)).unwrap();
        assert_eq!(big.current_a().last(), Some(MAX_SAMPLE_A));
    }

    #[test]
    fn a_window_rebuilt_from_its_samples_is_the_same_bit_for_bit() {
        let mut t = ConditionedWindow::<600>::new();
        for j in 0..2000 {
            let i = 2.0 * libm::sinf(j as f32 * 0.01) + 0.3 * libm::cosf(j as f32 * 0.37);
            t.push(i, -i, 0.01 * (j % 7) as f32).unwrap();
        }
        t.finish().unwrap();
        let back = ConditionedWindow::<600>::from_samples(t.current_a()).unwrap();
        assert_eq!(back.current_a().len(), 500);
        assert!(back.current_a().zip(t.current_a()).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(back.weights().zip(t.weights()).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert_eq!(ConditionedWindow::<600>::from_samples([1.0, f32::NAN]).err(), Some(ConditioningError::NonFinite));
        assert_eq!(ConditionedWindow::<60>::from_samples([1.0; 61]).err(), Some(ConditioningError::WindowFull));
        assert_eq!(ConditionedWindow::<600>::from_samples([1.0; 3]).err(), Some(ConditioningError::TooShort));
    }

    #[test]
    fn equivalent_current_of_ideal_six_step_currents_is_the_pair_current() {
        // Ideal 120° block currents: in every sector one phase carries +I, one −I, one 0.
        let i = 3.5;
        let sectors = [(i, -i, 0.0), (i, 0.0, -i), (0.0, i, -i), (-i, i, 0.0), (-i, 0.0, i), (0.0, -i, i)];
        for (a, b, c) in sectors {
            assert_eq!(equivalent_current_a(a, b, c), i);
        }
    }

    #[test]
    fn equivalent_current_of_balanced_sinusoids_is_bounded_by_peak() {
        // For balanced sinusoids of amplitude A, ½Σ|i| = the largest |i_j| … ranges in [√3/2·A, A].
        let a = 2.0;
        for k in 0..360 {
            let th = k as f32 * PI / 180.0;
            let (ia, ib, ic) =
                (a * libm::cosf(th), a * libm::cosf(th - 2.0 * PI / 3.0), a * libm::cosf(th + 2.0 * PI / 3.0));
            let e = equivalent_current_a(ia, ib, ic);
            assert!(e <= a + 1e-5 && e >= 0.866 * a - 1e-5, "{e} at {k}°");
        }
    }

    #[test]
    fn block_mean_and_weights() {
        let mut c: ConditionedWindow<100> = ConditionedWindow::new();
        for k in 0..(60 * DECIMATION) {
            // a ramp, constant within each block, of steps exact in binary: stored exactly
            let i = (k / DECIMATION) as f32 * 0.125;
            c.push(i, -i, 0.0).unwrap();
        }
        c.push(1.0, -1.0, 0.0).unwrap(); // partial block: dropped
        c.finish().unwrap();
        let t = c;
        assert_eq!(t.clone().push(1.0, 1.0, 1.0), Err(ConditioningError::Finished));
        assert_eq!(t.len(), 60);
        assert_eq!(t.current_a().nth(10), Some(1.25));
        // A constant slope: İ = C everywhere, so every weight is exactly 1/2.
        assert_eq!(t.weights().count(), 60);
        assert!(t.weights().all(|w| w == 0.5));
    }

    #[test]
    fn weights_drop_where_the_current_jumps() {
        let mut c: ConditionedWindow<200> = ConditionedWindow::new();
        for k in 0..(100 * DECIMATION) {
            let i = if k < 50 * DECIMATION { 1.0 } else { 5.0 };
            c.push(i, -i, 0.0).unwrap();
        }
        c.finish().unwrap();
        let w: std::vec::Vec<f32> = c.weights().collect();
        assert!(w[49] < 0.2 && w[50] < 0.2, "{} {}", w[49], w[50]);
        assert_eq!(w[10], 1.0);
    }

    #[test]
    fn bad_input_gives_errors() {
        let mut c: ConditionedWindow<60> = ConditionedWindow::new();
        assert_eq!(c.push(f32::NAN, 0.0, 0.0), Err(ConditioningError::NonFinite));
        assert_eq!(c.push(0.0, f32::INFINITY, 0.0), Err(ConditioningError::NonFinite));
        assert_eq!(ConditionedWindow::<60>::new().finish(), Err(ConditioningError::TooShort));
        let mut flat: ConditionedWindow<60> = ConditionedWindow::new();
        for _ in 0..(60 * DECIMATION) {
            flat.push(1.0, -1.0, 0.0).unwrap();
        }
        assert_eq!(flat.finish(), Err(ConditioningError::NoExcitation));
        let mut full: ConditionedWindow<60> = ConditionedWindow::new();
        let mut last = Ok(());
        for k in 0..(61 * DECIMATION) {
            last = full.push(k as f32, 0.0, -(k as f32));
        }
        assert_eq!(last, Err(ConditioningError::WindowFull));
    }
}

/// `true` when `samples` window samples cover a manoeuvre of `duration_s` at the control period of
/// `params`, up to one window sample (the partial block conditioning drops) and half a sample
/// for the rounding of the product.
pub fn covers(samples: usize, duration_s: f32, params: &EmaParams) -> bool {
    let sample_s = DECIMATION as f32 * params.control_period_s;
    (samples as f32 + 1.5) * sample_s >= duration_s
}
