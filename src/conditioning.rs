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

/// Intervals of the [`MeasuredEnvelope`] table over `[0, 4σ]`.
const ENVELOPE_TABLE_LEN: usize = 32;
const _: () = assert!(ENVELOPE_TABLE_LEN.is_power_of_two(), "indices are masked with ENVELOPE_TABLE_LEN − 1");

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

/// What the measured `I_3eq` is expected to read for a true (noise-free) pair current `I`.
///
/// Rectification biases `½Σ|i_j|` upward wherever the current is small against its noise:
/// - the conducting pair carries `±(I + j)` plus sensor noise, where `j` is the jitter the
///   controller puts on the current from the position transducer's noise (the derivative on
///   measurement amplifies it): `σ_j = Kd·(α/T)·σ_θ·√(2/(2−α))`, `α = T/τ_D`,
///   `σ_θ² = σ_pos² + q²/12` (noise and resolution `q`); the pair reads `F_{σ_pair}(|I|)` each, with
///   `σ_pair² = σ_j² + σ_s² + h²/3` (the proportional path adds `Kp·σ_θ` ≈ 0.008 A, neglected);
///   `h²/3` is the hysteresis current ripple, a triangle wave of half band `h` (RMS `h/√3` =
///   0.173 A): the reference model with noise off shows `½Σ|i_j| − |I_ref|` with an SD of
///   0.14–0.25 A in regulation. Without it the model reads below the measurement on slow,
///   low-current samples and the identification turns that into friction;
/// - the open phase reads sensor noise only, `F_{σ_s}(0)`;
///
/// so `E[I_3eq] = F_{σ_pair}(|I|) + ½F_{σ_s}(0)`, where `F_σ(μ) = μ·erf(μ/(σ√2)) + σ√(2/π)e^{−μ²/(2σ²)}`
/// is the folded-normal mean. Nominal sensors: `σ_j = 0.29 A`, `σ_s = 0.02 A`. Without the
/// envelope the identification reads the bias as extra friction on a healthy actuator
/// (`docs/decisions/0008-measured-envelope.md`).
/// `F_σ(μ) − μ` is tabulated once over `[0, 4σ_pair]` (beyond, below 1e-5·σ: taken as 0) and
/// interpolated linearly: f32 only in the hot loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredEnvelope {
    /// `F(μ) − μ` at `μ = k·4σ_pair/ENVELOPE_TABLE_LEN`, `k = 0..=ENVELOPE_TABLE_LEN`.
    excess_a: [f32; ENVELOPE_TABLE_LEN + 1],
    /// `ENVELOPE_TABLE_LEN/(4σ_pair)`, 0 when `σ_pair = 0`.
    index_per_a: f32,
    /// `½F_{σ_s}(0) = ½σ_s√(2/π)`, the open phase's share.
    open_phase_a: f32,
}

/// `σ` if finite and positive, else 0.
fn noise_or_zero(sigma: f32) -> f32 {
    if sigma.is_finite() && sigma > 0.0 {
        sigma
    } else {
        0.0
    }
}

impl MeasuredEnvelope {
    /// The envelope for pair-current noise `pair_noise_a` and open-phase sensor noise
    /// `open_noise_a` (RMS; a non-finite or negative value counts as 0).
    pub fn new(pair_noise_a: f32, open_noise_a: f32) -> Self {
        let sigma = noise_or_zero(pair_noise_a);
        let open_phase_a = 0.5 * noise_or_zero(open_noise_a) * libm::sqrtf(2.0 / core::f32::consts::PI);
        let mut excess_a = [0.0; ENVELOPE_TABLE_LEN + 1];
        if sigma == 0.0 {
            return Self { excess_a, index_per_a: 0.0, open_phase_a };
        }
        let f0 = sigma * libm::sqrtf(2.0 / core::f32::consts::PI);
        let step = 4.0 * sigma / ENVELOPE_TABLE_LEN as f32;
        for (k, e) in excess_a.iter_mut().enumerate() {
            let mu = k as f32 * step;
            let z = mu / (sigma * core::f32::consts::SQRT_2);
            // F(μ) − μ = σ√(2/π)e^{−z²} − μ·erfc(z)
            *e = f0 * libm::expf(-z * z) - mu * libm::erfcf(z);
        }
        Self { excess_a, index_per_a: 1.0 / step, open_phase_a }
    }

    /// The envelope of the actuator's sensors and controller (formulas above).
    pub fn of(params: &EmaParams) -> Self {
        let jitter = Self::controller_jitter_a(params);
        let sensor = params.current_noise_a;
        let ripple = Self::sensed_ripple_a(params);
        Self::new(libm::sqrtf(jitter * jitter + sensor * sensor + ripple * ripple), sensor)
    }

    /// RMS of the hysteresis ripple as the ADC samples it: the pair current's triangle wave of
    /// half band `h` (RMS `h/√3` at the winding) through the current sensor's first-order lag
    /// `τ_i` ([`EmaParams::current_loop_lag_s`]). At rest the pair current rises and falls at
    /// `V_dc/(2L)`, so the triangle's period is `P = 8hL/V_dc` (17.8 µs nominal) and its odd
    /// harmonics `8h/(π²n²)` are each attenuated by `1/√(1 + (2πnτ_i/P)²)`:
    ///
    /// ```text
    /// σ_ripple² = Σ_{n odd} ½·(8h/(π²n²))² / (1 + (2πnτ_i/P)²)
    /// ```
    ///
    /// 0.058 A nominal, a third of the winding's `h/√3` = 0.173 A: the ADC sees the current
    /// through the sensor, so the winding's ripple would overstate the rectification at the slow,
    /// low-current samples (`docs/decisions/0008-measured-envelope.md`).
    pub fn sensed_ripple_a(params: &EmaParams) -> f32 {
        let h = params.hysteresis_half_band_a;
        let slew_a_per_s = params.supply_voltage_v / (2.0 * params.phase_inductance_h);
        let tau_s = params.current_loop_lag_s;
        if !(h > 0.0 && slew_a_per_s > 0.0 && slew_a_per_s.is_finite() && tau_s >= 0.0) {
            return noise_or_zero(h) * (1.0 / 1.732_050_8); // no slew to set a period: the winding's h/√3
        }
        let period_s = 4.0 * h / slew_a_per_s;
        let w1_tau = 2.0 * core::f32::consts::PI * tau_s / period_s;
        let mut sum = 0.0;
        for n in [1.0f32, 3.0, 5.0, 7.0, 9.0] {
            let b = 8.0 * h / (core::f32::consts::PI * core::f32::consts::PI * n * n);
            sum += 0.5 * b * b / (1.0 + n * n * w1_tau * w1_tau);
        }
        libm::sqrtf(sum)
    }

    /// `σ_j`, the RMS current the controller's derivative on measurement puts on the pair
    /// ([`EmaParams::controller_jitter_a`]).
    pub fn controller_jitter_a(params: &EmaParams) -> f32 {
        params.controller_jitter_a()
    }

    /// Expected measured `I_3eq` for a true pair current `current_a`.
    #[cfg_attr(not(target_os = "none"), inline)]
    pub fn expected_a(&self, current_a: f32) -> f32 {
        self.conducting_phase_a(current_a) + self.open_phase_a
    }

    /// Expected rectified reading `F_{σ_pair}(|μ|)` of one conducting phase whose mean reading is
    /// `mean_a` (`|I|` for an ideal sensor): half of a conducting pair's share of `E[I_3eq]`
    /// counts each of its two phases this way. Used with sensor errors, when the two phases of
    /// the pair read different means ([`crate::effects`]).
    pub fn conducting_phase_a(&self, mean_a: f32) -> f32 {
        let mu = libm::fabsf(mean_a);
        let x = mu * self.index_per_a;
        let excess = if x < ENVELOPE_TABLE_LEN as f32 {
            // x ≥ 0 and below the table length, so k < ENVELOPE_TABLE_LEN, a power of two: the mask
            // changes no value and states the bound to the compiler (no bounds check, no panic path).
            let k = (x as usize) & (ENVELOPE_TABLE_LEN - 1);
            let frac = x - k as f32;
            let lo = self.excess_a[k];
            let hi = self.excess_a[k + 1];
            lo + (hi - lo) * frac
        } else {
            0.0
        };
        mu + excess
    }
}

/// The expected measured `I_3eq` with current-sensor errors (`sensor_offset`,
/// [`crate::effects`]): `i_m,j = (1 + g_j)·i_j + o_j`. In a sector with pair `(p, q)` carrying the
/// true current `I` (signed, `i_p = I`, `i_q = −I`) and the open phase `r` carrying none:
///
/// ```text
/// E[I_3eq] = ½F_{σ_pair}((1 + g_p)·I + o_p) + ½F_{σ_pair}((1 + g_q)·I − o_q) + ½F_{σ_s}(o_r)
/// ```
///
/// (`F` the folded-normal mean of [`MeasuredEnvelope`]): the offsets bias each sector differently,
/// the open phase by `½|o_r|`. Without errors it is [`MeasuredEnvelope::expected_a`] exactly.
///
/// With unequal targets the loop freewheels the pair on one rail and the idle phase conducts
/// through that rail's diode ([`crate::model::ModelState::freewheel_shift_a`]): the mean phase
/// currents move by `δ_j` (`+i_r` on the idle phase, `−i_r` on the pair phase that is not
/// regulated), and the sum reads `½F((1 + g_p)(I + δ_p) + o_p) + ½F((1 + g_q)(−I + δ_q) + o_q)`
/// `+ ½F_{σ_s}(o_r) + ½(|(1 + g_r)δ_r + o_r| − |o_r|)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorErrorEnvelope {
    envelope: MeasuredEnvelope,
    /// Per sector `(1 + g_p, o_p, 1 + g_q, −o_q)`.
    pair: [[f32; 4]; 6],
    /// Per sector `½F_{σ_s}(o_r)` of the open phase.
    open_a: [f32; 6],
    /// Per sector `(1 + g_r, o_r)` of the open phase.
    open: [[f32; 2]; 6],
}

impl SensorErrorEnvelope {
    /// The envelope of `params` with per-phase sensor gain errors `gain` and offsets `offset_a`.
    pub fn new(params: &EmaParams, gain: [f32; 3], offset_a: [f32; 3]) -> Self {
        Self::around(MeasuredEnvelope::of(params), params, gain, offset_a)
    }

    /// [`SensorErrorEnvelope::new`] around `envelope`, the [`MeasuredEnvelope::of`] `params`.
    fn around(envelope: MeasuredEnvelope, params: &EmaParams, gain: [f32; 3], offset_a: [f32; 3]) -> Self {
        let mut pair = [[0.0; 4]; 6];
        let mut open_a = [0.0; 6];
        let mut open = [[1.0, 0.0]; 6];
        for sector in 0..6 {
            let (p, q, r) = crate::six_step::sector_phases(sector);
            pair[sector] = [1.0 + gain[p], offset_a[p], 1.0 + gain[q], -offset_a[q]];
            open_a[sector] = 0.5 * folded_normal_mean_a(offset_a[r], params.current_noise_a);
            open[sector] = [1.0 + gain[r], offset_a[r]];
        }
        Self { envelope, pair, open_a, open }
    }

    /// The envelope of `params` with the `sensor_offset` effect of `effects`, around `envelope`
    /// (the [`MeasuredEnvelope::of`] `params`, which a model run has already: not computed
    /// twice); `None` when the effect is off, and always without the `effect-terms` feature.
    pub fn of(envelope: &MeasuredEnvelope, params: &EmaParams, effects: &crate::effects::ModelEffects) -> Option<Self> {
        use crate::effects::{maxima, EffectId};
        if !cfg!(feature = "effect-terms") {
            return None;
        }
        let s = effects.get(EffectId::SensorOffset);
        if s == 0.0 {
            return None;
        }
        let (gain, offset_a) = (maxima::SENSOR_GAIN.map(|g| s * g), maxima::SENSOR_OFFSET_A.map(|o| s * o));
        Some(Self::around(*envelope, params, gain, offset_a))
    }

    /// Expected measured `I_3eq` in commutation sector `sector` for the true pair current `current_a`,
    /// the phases' mean currents moved by the freewheel's `shift_a` (`δ_j` above).
    pub fn expected_a(&self, sector: usize, current_a: f32, shift_a: &[f32; 3]) -> f32 {
        let sector = sector % 6;
        let (p, q, r) = crate::six_step::sector_phases(sector);
        let [gain_p, off_p, gain_q, off_q] = self.pair[sector];
        let [gain_r, off_r] = self.open[sector];
        let idle_a = shift_a[r];
        0.5 * (self.envelope.conducting_phase_a(gain_p * (current_a + shift_a[p]) + off_p)
            + self.envelope.conducting_phase_a(gain_q * (current_a - shift_a[q]) + off_q)
            + libm::fabsf(gain_r * idle_a + off_r)
            - libm::fabsf(off_r))
            + self.open_a[sector]
    }
}

/// Mean of a folded normal, `E|X|` for `X ~ N(μ, σ²)`:
/// `F_σ(μ) = |μ|·erf(|μ|/(σ√2)) + σ√(2/π)·e^{−μ²/(2σ²)}` (`|μ|` when `σ` is not positive or not finite).
/// Not for the hot loop (`erff`, `expf`): the effect terms evaluate it once per model.
pub fn folded_normal_mean_a(mean_a: f32, sigma_a: f32) -> f32 {
    let mu = libm::fabsf(mean_a);
    let sigma = noise_or_zero(sigma_a);
    if sigma == 0.0 {
        return mu;
    }
    let z = mu / (sigma * core::f32::consts::SQRT_2);
    mu * libm::erff(z) + sigma * libm::sqrtf(2.0 / core::f32::consts::PI) * libm::expf(-z * z)
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
        self.codes.get(i).map(|&c| c as f32 * self.step_a)
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
        let step_a = self.step_a;
        self.codes.iter().map(move |&c| c as f32 * step_a)
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

    /// Seeded standard normal draws (xorshift + Box–Muller), for the Monte Carlo checks.
    struct Normal(u64);
    impl Normal {
        fn uniform(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            ((self.0 >> 40) as f32 + 0.5) / (1u64 << 24) as f32
        }
        fn draw(&mut self) -> f32 {
            let (u1, u2) = (self.uniform(), self.uniform());
            libm::sqrtf(-2.0 * libm::logf(u1)) * libm::cosf(2.0 * PI * u2)
        }
    }

    #[test]
    fn measured_envelope_is_the_mean_of_rectified_noisy_currents() {
        // Monte Carlo: pair jitter j common to the pair, independent sensor noise on each phase.
        let (pair_jitter, sensor) = (0.29f32, 0.02f32);
        let env = MeasuredEnvelope::new(libm::sqrtf(pair_jitter * pair_jitter + sensor * sensor), sensor);
        let mut normal = Normal(0x9E37_79B9_7F4A_7C15);
        for current in [0.0f32, 0.1, 0.3, 0.6, 1.0, 5.0] {
            let n = 200_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                let j = pair_jitter * normal.draw();
                let (na, nb, nc) = (sensor * normal.draw(), sensor * normal.draw(), sensor * normal.draw());
                sum += f64::from(equivalent_current_a(current + j + na, -(current + j) + nb, nc));
            }
            let mc = (sum / n as f64) as f32;
            // Monte Carlo standard error ≈ 0.29/√n ≈ 7e-4 A; interpolation < 1e-4 A.
            assert!((env.expected_a(current) - mc).abs() < 3e-3, "I = {current}: {} vs {mc}", env.expected_a(current));
        }
        assert!((env.expected_a(5.0) - (5.0 + 0.5 * sensor * libm::sqrtf(2.0 / PI))).abs() < 1e-5);
        assert_eq!(MeasuredEnvelope::new(0.0, 0.0).expected_a(-1.5), 1.5);
        assert_eq!(MeasuredEnvelope::new(f32::NAN, -1.0).expected_a(0.0), 0.0);
    }

    #[test]
    fn sensor_error_envelope_reads_the_freewheels_idle_current() {
        let p = EmaParams::NOMINAL;
        let plain = MeasuredEnvelope::of(&p);
        let no_errors = SensorErrorEnvelope::new(&p, [0.0; 3], [0.0; 3]);
        assert!((no_errors.expected_a(0, 2.0, &[0.0; 3]) - plain.expected_a(2.0)).abs() < 1e-6);
        // Sector 0 = (a+, b−), c idle, carrying i_c = 0.1 A. Returned through b (b carries
        // −2.1 A): I_3eq reads |i_c| more. Through a (a carries 1.9 A): it cancels.
        let base = no_errors.expected_a(0, 2.0, &[0.0; 3]);
        let through_b = no_errors.expected_a(0, 2.0, &[0.0, -0.1, 0.1]);
        let through_a = no_errors.expected_a(0, 2.0, &[-0.1, 0.0, 0.1]);
        assert!((through_b - base - 0.1).abs() < 2e-3, "{base} -> {through_b}");
        assert!((through_a - base).abs() < 2e-3, "{base} -> {through_a}");
        // With an offset on the idle phase, its reading moves from |o_c| to |(1 + g_c)·i_c + o_c|.
        let offset_c = SensorErrorEnvelope::new(&p, [0.0, 0.0, 0.01], [0.0, 0.0, -0.15]);
        let moved = offset_c.expected_a(0, 2.0, &[0.0, -0.1, 0.1]) - offset_c.expected_a(0, 2.0, &[0.0; 3]);
        let pair = 0.5 * (plain.conducting_phase_a(2.1) - plain.conducting_phase_a(2.0));
        assert!((moved - pair - 0.5 * (libm::fabsf(1.01 * 0.1 - 0.15) - 0.15)).abs() < 1e-5, "{moved}");
    }

    /// One period of the steady-state output of a first-order lag `τ` driven by a triangle wave
    /// of half band `h` and period `P`, at `m` equally spaced phases (exact discretization of
    /// `y' = (x − y)/τ` on a fine grid, 40 periods to settle).
    fn filtered_triangle(h: f32, period_s: f32, tau_s: f32, m: usize) -> Vec<f32, 512> {
        let fine = 64;
        let dt = period_s / (m * fine) as f32;
        let decay = libm::expf(-dt / tau_s);
        let triangle = |k: usize| {
            let x = (k % (m * fine)) as f32 / (m * fine) as f32; // phase in [0, 1)
            if x < 0.5 {
                h * (4.0 * x - 1.0)
            } else {
                h * (3.0 - 4.0 * x)
            }
        };
        let mut y = 0.0f32;
        let mut out = Vec::new();
        for k in 0..40 * m * fine {
            y = triangle(k) + (y - triangle(k)) * decay;
            if k >= 39 * m * fine && k % fine == 0 {
                out.push(y).unwrap();
            }
        }
        out
    }

    #[test]
    fn sensed_ripple_is_the_triangle_through_the_sensor_lag() {
        let p = EmaParams::NOMINAL;
        let h = p.hysteresis_half_band_a;
        let period_s = 8.0 * h * p.phase_inductance_h / p.supply_voltage_v;
        assert!((period_s - 17.8e-6).abs() < 0.1e-6, "{period_s}");
        let wave = filtered_triangle(h, period_s, p.current_loop_lag_s, 512);
        let mean = wave.iter().sum::<f32>() / wave.len() as f32;
        let rms = libm::sqrtf(wave.iter().map(|y| (y - mean) * (y - mean)).sum::<f32>() / wave.len() as f32);
        let formula = MeasuredEnvelope::sensed_ripple_a(&p);
        assert!((rms - formula).abs() < 0.01 * formula, "filtered {rms} vs formula {formula}");
        // a third of the winding's h/√3: the sensor's 20 kHz bandwidth against a 56 kHz ripple
        assert!((formula - 0.058).abs() < 0.002, "{formula}");
        // without the lag, the winding's ripple
        let mut no_lag = p;
        no_lag.current_loop_lag_s = 0.0;
        let bare = MeasuredEnvelope::sensed_ripple_a(&no_lag);
        assert!((bare - h / libm::sqrtf(3.0)).abs() < 0.002 * h, "{bare}");
    }

    #[test]
    fn nominal_envelope_includes_the_sensed_hysteresis_ripple() {
        // Monte Carlo of the nominal actuator's sampled pair current: I + controller jitter + the
        // hysteresis triangle ripple through the sensor's lag, at a random phase + sensor noise.
        let p = EmaParams::NOMINAL;
        let env = MeasuredEnvelope::of(&p);
        let h = p.hysteresis_half_band_a;
        let sensor = p.current_noise_a;
        let period_s = 8.0 * h * p.phase_inductance_h / p.supply_voltage_v;
        let wave = filtered_triangle(h, period_s, p.current_loop_lag_s, 512);
        let pair_jitter = MeasuredEnvelope::controller_jitter_a(&p); // checked against the controller below
        let winding_ripple =
            MeasuredEnvelope::new(libm::sqrtf(pair_jitter * pair_jitter + sensor * sensor + h * h / 3.0), sensor);
        let without_ripple = MeasuredEnvelope::new(libm::sqrtf(pair_jitter * pair_jitter + sensor * sensor), sensor);
        let mut normal = Normal(0x2545_F491_4F6C_DD1D);
        for current in [0.0f32, 0.2, 0.5, 1.0] {
            let n = 200_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                let phase = ((normal.uniform() * wave.len() as f32) as usize).min(wave.len() - 1);
                let pair = current + pair_jitter * normal.draw() + wave[phase];
                let (na, nb, nc) = (sensor * normal.draw(), sensor * normal.draw(), sensor * normal.draw());
                sum += f64::from(equivalent_current_a(pair + na, -pair + nb, nc));
            }
            let mc = (sum / n as f64) as f32;
            // standard error ≈ 0.3/√n ≈ 7e-4 A
            assert!((env.expected_a(current) - mc).abs() < 3e-3, "I = {current}: {} vs {mc}", env.expected_a(current));
            if current < 0.6 {
                // the winding's ripple h/√3 reads 0.010–0.034 A high here
                assert!(winding_ripple.expected_a(current) - mc > 0.008, "I = {current}: the sensor's lag matters");
            }
            if current < 0.3 {
                // the sensed ripple still adds 3–4 mA of rectification at the lowest currents
                assert!(mc - without_ripple.expected_a(current) > 0.002, "I = {current}: the ripple matters");
            }
        }
    }

    #[test]
    fn controller_jitter_matches_the_derivative_path_formula() {
        // Drive the real controller with a noisy, quantized position at rest and measure the RMS
        // of its derivative action Kd·D: the σ_j of `MeasuredEnvelope::of`.
        let p = EmaParams::NOMINAL;
        let model = crate::model::MonitorModel::new(&p, &crate::faults::FaultVector::HEALTHY);
        let mut state = crate::model::ModelState::at_rest();
        let mut normal = Normal(42);
        let q = p.position_resolution_rad;
        let (mut sum_sq, n) = (0.0f64, 200_000);
        for k in 0..n + 1000 {
            let measured = libm::roundf(p.position_noise_rad * normal.draw() / q) * q;
            model.control(&mut state, 0.0, measured);
            if k >= 1000 {
                let d = p.kd_a_s_per_rad * state.derivative_rad_per_s;
                sum_sq += f64::from(d * d);
            }
        }
        let rms = (sum_sq / n as f64).sqrt() as f32;
        let formula = MeasuredEnvelope::controller_jitter_a(&p);
        assert!((rms - formula).abs() < 0.03 * formula, "{rms} vs {formula}");
        assert!((formula - 0.29).abs() < 0.01, "{formula}");
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
