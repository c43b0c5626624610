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

/// Frames averaged into one window sample (10 kHz control rate → 2.5 kHz fitness rate).
pub const DECIMATION: usize = 4;

/// Fewest window samples an identification accepts (20 ms at 2.5 kHz).
pub const MIN_SAMPLES: usize = 50;

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
}

impl core::fmt::Display for ConditioningError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ConditioningError::NonFinite => "a phase current is NaN or infinite",
            ConditioningError::WindowFull => "the trace is longer than the conditioning window",
            ConditioningError::TooShort => "the trace is too short to identify from",
            ConditioningError::NoExcitation => "the measured current never changes: no excitation",
            ConditioningError::Finished => "the window is closed (frames after finish) or not closed yet",
        })
    }
}

impl core::error::Error for ConditioningError {}

/// The conditioned measurement: window samples of `I_3eq` and their fitness weights.
///
/// Filled in place (no copy of the window ever exists): [`MeasuredTrace::push`] frames in, then
/// [`MeasuredTrace::finish`] closes the window and computes the weights. Only a finished trace is
/// identified from.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredTrace<const W: usize> {
    current_a: Vec<f32, W>,
    weight: Vec<f32, W>,
    block_sum_a: f32,
    block_len: usize,
}

impl<const W: usize> Default for MeasuredTrace<W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const W: usize> MeasuredTrace<W> {
    /// An empty window.
    pub const fn new() -> Self {
        const { assert!(W >= MIN_SAMPLES, "the window must hold at least MIN_SAMPLES samples") };
        Self { current_a: Vec::new(), weight: Vec::new(), block_sum_a: 0.0, block_len: 0 }
    }

    /// Adds one frame of phase currents (amperes). Refused after [`MeasuredTrace::finish`].
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
            self.current_a.push(mean).map_err(|_| ConditioningError::WindowFull)?;
        }
        Ok(())
    }

    /// Closes the window (a trailing partial block is dropped) and computes the weights.
    pub fn finish(&mut self) -> Result<(), ConditioningError> {
        if self.is_finished() {
            return Ok(());
        }
        let y = &self.current_a;
        let n = y.len();
        if n < MIN_SAMPLES {
            return Err(ConditioningError::TooShort);
        }
        // Central differences (one-sided at the ends); the sample period cancels in İ/C.
        let derivative = |i: usize| -> f32 {
            let (a, b, span) = if i == 0 {
                (y[0], y[1], 1.0)
            } else if i + 1 == n {
                (y[n - 2], y[n - 1], 1.0)
            } else {
                (y[i - 1], y[i + 1], 2.0)
            };
            (b - a) / span
        };
        let mut sum_sq = 0.0f32;
        for i in 0..n {
            let d = derivative(i);
            sum_sq += d * d;
        }
        let c_sq = sum_sq / n as f32;
        if c_sq.is_nan() || c_sq <= 0.0 || c_sq.is_infinite() {
            return Err(ConditioningError::NoExcitation);
        }
        for i in 0..n {
            let d = derivative(i);
            // Same capacity as `current_a`, so this push cannot fail; map it anyway (no panics).
            self.weight.push(1.0 / (1.0 + d * d / c_sq)).map_err(|_| ConditioningError::WindowFull)?;
        }
        Ok(())
    }

    /// `true` once [`MeasuredTrace::finish`] succeeded.
    pub fn is_finished(&self) -> bool {
        !self.weight.is_empty()
    }

    /// Block-averaged equivalent current, one value per complete window sample.
    pub fn current_a(&self) -> &[f32] {
        &self.current_a
    }

    /// Fitness weight of each window sample, in `(0, 1]` (empty before `finish`).
    pub fn weight(&self) -> &[f32] {
        &self.weight
    }

    /// Number of complete window samples.
    pub fn len(&self) -> usize {
        self.current_a.len()
    }

    /// `true` before the first complete window sample.
    pub fn is_empty(&self) -> bool {
        self.current_a.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f32::consts::PI;

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
        let mut c: MeasuredTrace<100> = MeasuredTrace::new();
        for k in 0..(60 * DECIMATION) {
            let i = (k / DECIMATION) as f32 * 0.1; // a ramp: constant within each block
            c.push(i, -i, 0.0).unwrap();
        }
        c.push(1.0, -1.0, 0.0).unwrap(); // partial block: dropped
        c.finish().unwrap();
        let t = c;
        assert_eq!(t.clone().push(1.0, 1.0, 1.0), Err(ConditioningError::Finished));
        assert_eq!(t.len(), 60);
        assert!((t.current_a()[10] - 1.0).abs() < 1e-6);
        // A constant slope: İ = C everywhere, so every weight is exactly 1/2.
        assert!(t.weight().iter().all(|w| (*w - 0.5).abs() < 1e-6));
    }

    #[test]
    fn weights_drop_where_the_current_jumps() {
        let mut c: MeasuredTrace<200> = MeasuredTrace::new();
        for k in 0..(100 * DECIMATION) {
            let i = if k < 50 * DECIMATION { 1.0 } else { 5.0 };
            c.push(i, -i, 0.0).unwrap();
        }
        c.finish().unwrap();
        let w = c.weight();
        assert!(w[49] < 0.2 && w[50] < 0.2, "{} {}", w[49], w[50]);
        assert_eq!(w[10], 1.0);
    }

    #[test]
    fn bad_input_gives_errors() {
        let mut c: MeasuredTrace<60> = MeasuredTrace::new();
        assert_eq!(c.push(f32::NAN, 0.0, 0.0), Err(ConditioningError::NonFinite));
        assert_eq!(c.push(0.0, f32::INFINITY, 0.0), Err(ConditioningError::NonFinite));
        assert_eq!(MeasuredTrace::<60>::new().finish(), Err(ConditioningError::TooShort));
        let mut flat: MeasuredTrace<60> = MeasuredTrace::new();
        for _ in 0..(60 * DECIMATION) {
            flat.push(1.0, -1.0, 0.0).unwrap();
        }
        assert_eq!(flat.finish(), Err(ConditioningError::NoExcitation));
        let mut full: MeasuredTrace<60> = MeasuredTrace::new();
        let mut last = Ok(());
        for k in 0..(61 * DECIMATION) {
            last = full.push(k as f32, 0.0, -(k as f32));
        }
        assert_eq!(last, Err(ConditioningError::WindowFull));
    }
}
