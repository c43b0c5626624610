//! The measured envelope: what the measured equivalent current `I_3eq` reads, on average, for a
//! true pair current, once the sensors' noise, the controller's jitter and the hysteresis ripple
//! are rectified by `½Σ|i_j|` ([`MeasuredEnvelope`]); and the same with the sensors' zero and
//! gain errors of the `sensor_offset` effect ([`SensorErrorEnvelope`]). The monitor model's
//! output is compared with the measurement through it (`fitness.rs`).

use crate::params::EmaParams;

/// Intervals of the [`MeasuredEnvelope`] table over `[0, 4σ]`.
const ENVELOPE_TABLE_LEN: usize = 32;
const _: () = assert!(ENVELOPE_TABLE_LEN.is_power_of_two(), "indices are masked with ENVELOPE_TABLE_LEN − 1");

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conditioning::equivalent_current_a;
    use core::f32::consts::PI;
    use heapless::Vec;

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
}
