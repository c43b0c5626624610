//! Transducers (docs/model.md): first-order lags, white noise, quantization.
//!
//! | channel | model |
//! |---|---|
//! | surface position | lag `τ = EmaParams::position_lag_s` (0.2 ms), noise `σ = EmaParams::position_noise_rad` (1e-5 rad), 16-bit quantization over ±0.6 rad |
//! | phase currents | the [`SensorChain`]: per phase a zero error `o_j`, a gain error `g_j`, a first-order bandwidth `f_j` and a conversion instant `t_k + s_j`; noise `σ = EmaParams::current_noise_a` (0.02 A); an ADC of `b` bits over `±I_FS` |
//!
//! The lags are integrated at every step of the model (exact discretization `y += (1 − e^{−dt/τ})·(x − y)`);
//! noise and quantization are applied when the sample is taken.
//!
//! ## The phase-current chain
//!
//! ```text
//! x_j = (1 + g_e,j)·i_j + o_e,j           the drive's sensor (the `sensor_offset` effect; x_j = i_j without it)
//! u_j = (1 + g_j)·x_j + o_j               the chain's zero and gain errors
//! τ_j·dy_j/dt = u_j − y_j,  τ_j = 1/(2π f_j)
//! code_j = clamp(round(2^{b−1} + (y_j(t_k + s_j) + n_j)/q), 0, 2^b − 1),  q = 2·I_FS/2^b
//! recorded i_j = (code_j − 2^{b−1})·q     (the nominal conversion: the chain's errors stay in the data)
//! ```
//!
//! [`SensorChain::IDEAL`] (no zero or gain error, 20 kHz, no skew, the 12-bit ±20 A ADC of
//! [`ema_monitor::trace`]) is the recording path of every run that names no chain: bit for bit
//! the codes of [`ema_monitor::trace::amps_to_counts`]. [`CurrentSensing`] runs a chain in a
//! simulation.

use core::f64::consts::TAU;
use core::fmt;

use ema_monitor::trace;

/// Position transducer resolution.
pub const POSITION_BITS: u32 = 16;
/// Position transducer range `±POSITION_RANGE_RAD`.
pub const POSITION_RANGE_RAD: f64 = 0.6;
/// Current sensor bandwidth of the ideal chain.
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

/// Current ADC: `(counts, amps)` of a current through the shared 12-bit format
/// ([`CurrentAdc::NOMINAL`]).
pub fn adc_current(i_a: f64) -> (u16, f64) {
    CurrentAdc::NOMINAL.convert(i_a)
}

/// The ADC of the phase currents: `bits` bits over `±full_scale_a`, zero current at mid-scale.
///
/// ```text
/// q = 2·I_FS/2^b,  code = clamp(round(2^{b−1} + i/q), 0, 2^b − 1),  amps = (code − 2^{b−1})·q
/// ```
///
/// Computed in `f32`, as [`trace::amps_to_counts`] and [`trace::counts_to_amps`] do, so that
/// [`CurrentAdc::NOMINAL`] gives their codes and amperes exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentAdc {
    /// Resolution, bits ([`CurrentAdc::BITS`]).
    pub bits: u32,
    /// The currents at the ends of the code range, `±full_scale_a`, A.
    pub full_scale_a: f64,
}

impl CurrentAdc {
    /// The shared format of [`ema_monitor::trace`]: 12 bits over ±20 A.
    pub const NOMINAL: Self = Self { bits: trace::ADC_BITS, full_scale_a: trace::CURRENT_FULL_SCALE_A as f64 };

    /// Resolutions accepted: a code fits a `u16`, and 8 bits is already coarser (0.16 A over
    /// ±20 A) than any current ADC of a drive.
    pub const BITS: core::ops::RangeInclusive<u32> = 8..=16;

    /// Largest full scale accepted, A.
    pub const MAX_FULL_SCALE_A: f64 = 1000.0;

    /// Mid-scale code `2^{b−1}` (zero current), as `f32`.
    fn midscale(&self) -> f32 {
        (1u32 << (self.bits.clamp(1, 16) - 1)) as f32
    }

    /// Largest code `2^b − 1`.
    pub fn max_code(&self) -> u16 {
        ((1u32 << self.bits.clamp(1, 16)) - 1) as u16
    }

    /// One code, A (`f32`, as the conversion uses it).
    pub fn lsb_a(&self) -> f32 {
        2.0 * self.full_scale_a as f32 / (1u32 << self.bits.clamp(1, 16)) as f32
    }

    /// The code of `i_a` (saturating at the rails, 0 for NaN) and that code back in amperes.
    pub fn convert(&self, i_a: f64) -> (u16, f64) {
        let (mid, lsb) = (self.midscale(), self.lsb_a());
        let c = (mid + i_a as f32 / lsb).round();
        let code = if c.is_nan() || c < 0.0 {
            0
        } else if c > f32::from(self.max_code()) {
            self.max_code()
        } else {
            c as u16
        };
        (code, f64::from((f32::from(code) - mid) * lsb))
    }
}

/// One phase's current sensor: its errors, its bandwidth and when its conversion is taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseSensor {
    /// Zero error `o_j`, A: what the sensor reads at zero current.
    pub offset_a: f64,
    /// Gain error `g_j` (relative: 0.01 reads 1 % high).
    pub gain_error: f64,
    /// First-order bandwidth `f_j`, Hz: the lag `τ_j = 1/(2π f_j)`.
    pub bandwidth_hz: f64,
    /// Conversion instant after the frame instant, `s_j`, s: 0 for a conversion triggered with
    /// the frame, the conversion order and spacing of a sequential ADC otherwise.
    pub skew_s: f64,
}

impl PhaseSensor {
    /// No error, [`CURRENT_BANDWIDTH_HZ`], converted at the frame instant.
    pub const IDEAL: Self = Self { offset_a: 0.0, gain_error: 0.0, bandwidth_hz: CURRENT_BANDWIDTH_HZ, skew_s: 0.0 };

    /// The sensor's output for an input `x`, A: `(1 + g_j)·x + o_j` (exactly `x` without error).
    pub fn sense(&self, x: f64) -> f64 {
        (1.0 + self.gain_error) * x + self.offset_a
    }

    /// The lag's time constant `1/(2π f_j)`, s.
    pub fn time_constant_s(&self) -> f64 {
        1.0 / (TAU * self.bandwidth_hz)
    }
}

/// The measurement chain of the three phase currents: the sensors a, b, c and their ADC
/// (module documentation; the presets and the file format: docs/sensors.md).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorChain {
    /// Phases a, b, c.
    pub phases: [PhaseSensor; 3],
    /// The ADC.
    pub adc: CurrentAdc,
}

impl Default for SensorChain {
    fn default() -> Self {
        Self::IDEAL
    }
}

/// The NUCLEO-F446RE's Hall sensors (20 kHz) with conversion instants `skew_s`: zero errors
/// +0.15, −0.10, +0.12 A, gain errors +1.0, −0.8, +0.5 %.
const fn nucleo(skew_s: [f64; 3]) -> SensorChain {
    const fn sensor(offset_a: f64, gain_error: f64, skew_s: f64) -> PhaseSensor {
        PhaseSensor { offset_a, gain_error, bandwidth_hz: CURRENT_BANDWIDTH_HZ, skew_s }
    }
    SensorChain {
        phases: [sensor(0.15, 0.010, skew_s[0]), sensor(-0.10, -0.008, skew_s[1]), sensor(0.12, 0.005, skew_s[2])],
        adc: CurrentAdc::NOMINAL,
    }
}

impl SensorChain {
    /// No zero or gain error, 20 kHz, every phase at the frame instant, 12 bits over ±20 A: the
    /// recording path of a run that names no chain.
    pub const IDEAL: Self = Self { phases: [PhaseSensor::IDEAL; 3], adc: CurrentAdc::NOMINAL };

    /// The NUCLEO-F446RE board (docs/board.md): ADC1/2/3 in triple simultaneous mode triggered
    /// by TIM2 (no skew); Hall sensors ±20 A over 0–3.3 V read at 12 bits (zero at mid-scale),
    /// zero errors +0.15, −0.10, +0.12 A, gain errors +1.0, −0.8, +0.5 %, 20 kHz bandwidth.
    pub const NUCLEO_F446RE: Self = nucleo([0.0; 3]);

    /// The same sensors read by one-shot conversions in sequence: a, b, c at 0, 5 and 10 µs.
    pub const NUCLEO_F446RE_ONESHOT: Self = nucleo([0.0, 5.0e-6, 10.0e-6]);

    /// The named chains (`ema simulate --sensors NAME`), with one line on each.
    pub const PRESETS: [(&'static str, Self, &'static str); 3] = [
        ("ideal", Self::IDEAL, "no error, 20 kHz, simultaneous, 12 bits over ±20 A"),
        (
            "nucleo-f446re",
            Self::NUCLEO_F446RE,
            "the board's Hall sensors (zero errors +0.15, -0.10, +0.12 A; gains +1.0, -0.8, +0.5 %; 20 kHz) \
             in triple simultaneous mode, 12 bits over ±20 A",
        ),
        (
            "nucleo-f446re-oneshot",
            Self::NUCLEO_F446RE_ONESHOT,
            "the same sensors converted one after another, a, b, c at 0, 5, 10 µs",
        ),
    ];

    /// The preset called `name`.
    pub fn preset(name: &str) -> Option<Self> {
        Self::PRESETS.iter().find(|(n, _, _)| *n == name).map(|&(_, chain, _)| chain)
    }

    /// The latest conversion instant after the frame instant, s.
    pub fn max_skew_s(&self) -> f64 {
        self.phases.iter().fold(0.0, |m, p| m.max(p.skew_s))
    }

    /// Checks every value against its range (docs/sensors.md): a resolution in
    /// [`CurrentAdc::BITS`], a full scale in `(0,` [`CurrentAdc::MAX_FULL_SCALE_A`]`]`, zero
    /// errors inside the full scale, gain errors within ±50 %, positive bandwidths, and
    /// conversion instants in `[0, control_period_s)`, so that a frame's conversions are taken
    /// before the next frame's.
    pub fn check(&self, control_period_s: f64) -> Result<(), SensorChainError> {
        let adc = |field, message: String| Err(SensorChainError { field, phase: None, message });
        if !CurrentAdc::BITS.contains(&self.adc.bits) {
            let (lo, hi) = (CurrentAdc::BITS.start(), CurrentAdc::BITS.end());
            return adc("adc_bits", format!("{} bits is outside {lo} to {hi}", self.adc.bits));
        }
        let fs = self.adc.full_scale_a;
        if !(fs.is_finite() && fs > 0.0 && fs <= CurrentAdc::MAX_FULL_SCALE_A) {
            return adc(
                "full_scale_a",
                format!(
                    "{} A is outside (0, {}] A (the ADC spans ±full_scale_a)",
                    Shown(fs),
                    CurrentAdc::MAX_FULL_SCALE_A
                ),
            );
        }
        for (j, p) in self.phases.iter().enumerate() {
            let bad = |field, message: String| Err(SensorChainError { field, phase: Some(j), message });
            if !(p.offset_a.is_finite() && p.offset_a.abs() < fs) {
                return bad(
                    "offset_a",
                    format!("{} A is not inside the full scale ±{} A", Shown(p.offset_a), Shown(fs)),
                );
            }
            if !(p.gain_error.is_finite() && p.gain_error.abs() <= 0.5) {
                return bad(
                    "gain_error",
                    format!("{} is outside ±0.5 (a relative error: 0.01 is 1 %)", Shown(p.gain_error)),
                );
            }
            if !(p.bandwidth_hz.is_finite() && p.bandwidth_hz > 0.0) {
                return bad("bandwidth_hz", format!("{} Hz is not a positive bandwidth", Shown(p.bandwidth_hz)));
            }
            if !(p.skew_s.is_finite() && p.skew_s >= 0.0 && p.skew_s < control_period_s) {
                return bad(
                    "skew_us",
                    format!(
                        "{} µs is outside [0, {}) µs (after the frame instant, within one control period)",
                        Shown(micro(p.skew_s)),
                        Shown(micro(control_period_s))
                    ),
                );
            }
        }
        Ok(())
    }
}

/// A value in a message: Rust's shortest round-trip form, in exponent form outside 1e-6 to 1e9
/// (`1e308`, not its 309 digits).
struct Shown(f64);

impl fmt::Display for Shown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        if x == 0.0 || !x.is_finite() || (1e-6..1e9).contains(&x.abs()) {
            write!(f, "{x}")
        } else {
            write!(f, "{x:e}")
        }
    }
}

/// Seconds in microseconds, to the nanosecond (for messages: `1e-4` s shows as `100`).
fn micro(s: f64) -> f64 {
    (s * 1e9).round() / 1e3
}

/// Why a [`SensorChain`] was refused: the field (as a sensor file names it), the phase (0, 1, 2
/// for a, b, c) when the field is per phase, and what is wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorChainError {
    /// The field: `adc_bits`, `full_scale_a`, `offset_a`, `gain_error`, `bandwidth_hz` or `skew_us`.
    pub field: &'static str,
    /// The phase of a per-phase field.
    pub phase: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for SensorChainError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.phase {
            Some(j) => write!(f, "{} of phase {}: {}", self.field, ["a", "b", "c"][j.min(2)], self.message),
            None => write!(f, "{}: {}", self.field, self.message),
        }
    }
}

impl std::error::Error for SensorChainError {}

/// A [`SensorChain`] at work in a simulation stepped every `dt`: the three lags, and the
/// conversions of the frame being taken.
///
/// At the frame instant `t_k` ([`CurrentSensing::start_frame`]) a phase without skew is
/// converted at once; a phase with skew `s_j` is converted during the integration steps that
/// follow ([`CurrentSensing::update`]): at `t_k + s_j`, between the outputs of the steps that
/// end just before and just after it, linearly (`s_j/dt = m + f`: `(1 − f)·y_m + f·y_{m+1}`).
/// The lag is exact for an input held over each step, and the currents of the reference's
/// explicit Euler are straight lines between its steps, so the interpolation is as exact as the
/// integration; a skew on the step grid (5 µs is 20 steps of 0.25 µs) takes the step's own
/// output.
#[derive(Clone, Debug)]
pub struct CurrentSensing {
    chain: SensorChain,
    phases: [PhaseState; 3],
    /// Steps since the frame instant.
    steps: u32,
}

/// One phase of a [`CurrentSensing`].
#[derive(Clone, Copy, Debug)]
struct PhaseState {
    sensor: PhaseSensor,
    /// The drive's sensor error (the `sensor_offset` effect): `x_j = (1 + g_e,j)·i_j + o_e,j`.
    drive_offset_a: f64,
    drive_gain_error: f64,
    lag: Lag,
    /// `s_j/dt`, whole when within rounding of a step.
    skew_steps: f64,
    /// The noise of the frame's conversion while it is still to take.
    pending: Option<f64>,
    /// The frame's value at its conversion instant, noise included, before the ADC.
    taken: f64,
}

impl PhaseState {
    /// The value to convert: the one taken, or the lag's present output for one still pending.
    fn raw(&self) -> f64 {
        match self.pending {
            Some(noise) => self.lag.value + noise,
            None => self.taken,
        }
    }
}

impl CurrentSensing {
    /// `chain` behind the drive's sensor error `drive_offset_a`, `drive_gain_error`, stepped every
    /// `dt` s. Each lag starts at its sensor's reading of zero current `o_j` (the sensors are on
    /// before a recording starts); the drive's error enters through the lags from the first step.
    pub fn new(chain: &SensorChain, drive_offset_a: [f64; 3], drive_gain_error: [f64; 3], dt: f64) -> Self {
        let phase = |j: usize| {
            let sensor = chain.phases[j];
            let x = sensor.skew_s / dt;
            PhaseState {
                sensor,
                drive_offset_a: drive_offset_a[j],
                drive_gain_error: drive_gain_error[j],
                lag: Lag { value: sensor.offset_a, ..Lag::new(sensor.time_constant_s(), dt) },
                skew_steps: if (x - x.round()).abs() <= 1e-9 * x.max(1.0) { x.round() } else { x },
                pending: None,
                taken: 0.0,
            }
        };
        Self { chain: *chain, phases: [phase(0), phase(1), phase(2)], steps: 0 }
    }

    /// The chain.
    pub fn chain(&self) -> &SensorChain {
        &self.chain
    }

    /// Starts the frame at this instant with the noise `noise` of its three conversions: the
    /// phases without skew are taken now, the others are pending.
    pub fn start_frame(&mut self, noise: [f64; 3]) {
        self.steps = 0;
        for (p, n) in self.phases.iter_mut().zip(noise) {
            if p.skew_steps > 0.0 {
                p.pending = Some(n);
            } else {
                p.pending = None;
                p.taken = p.lag.value + n;
            }
        }
    }

    /// `true` once every conversion of the frame is taken.
    pub fn frame_complete(&self) -> bool {
        self.phases.iter().all(|p| p.pending.is_none())
    }

    /// One integration step with the true phase currents `i` at its end: the lags advance, and
    /// the conversions that fall in the step are taken.
    pub fn update(&mut self, i: [f64; 3]) {
        self.steps = self.steps.saturating_add(1);
        let step_end = f64::from(self.steps);
        for (p, i) in self.phases.iter_mut().zip(i) {
            let before = p.lag.value;
            let x = (1.0 + p.drive_gain_error) * i + p.drive_offset_a;
            p.lag.update(p.sensor.sense(x));
            if let Some(noise) = p.pending {
                if p.skew_steps <= step_end {
                    let f = p.skew_steps - (step_end - 1.0);
                    let after = p.lag.value;
                    let value = if f >= 1.0 { after } else { before + f * (after - before) };
                    p.taken = value + noise;
                    p.pending = None;
                }
            }
        }
    }

    /// The frame's ADC codes and recorded currents: the codes back in amperes, or with
    /// `quantization` off the values before the ADC (numerical studies; the codes are still
    /// given). A conversion still pending reads its lag's present output.
    pub fn frame(&self, quantization: bool) -> ([u16; 3], [f64; 3]) {
        let converted = self.phases.map(|p| {
            let raw = p.raw();
            let (code, amps) = self.chain.adc.convert(raw);
            (code, if quantization { amps } else { raw })
        });
        (converted.map(|c| c.0), converted.map(|c| c.1))
    }
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
    fn the_nominal_adc_is_the_trace_format() {
        // every code's centre, both half-code boundaries around it, and the rails
        let lsb = f64::from(trace::AMPS_PER_COUNT);
        for code in 0..=i32::from(trace::ADC_MAX) + 2 {
            for frac in [-0.5, -0.4999, 0.0, 0.4999, 0.5, 0.5001] {
                let i = (f64::from(code - 2048) + frac) * lsb;
                let counts = trace::amps_to_counts(i as f32);
                assert_eq!(adc_current(i), (counts, f64::from(trace::counts_to_amps(counts))), "{i} A");
            }
        }
        for i in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e9, -1e9, -0.0] {
            let counts = trace::amps_to_counts(i as f32);
            assert_eq!(adc_current(i).0, counts, "{i}");
        }
        // another ADC: 10 bits over ±25 A, codes on its own grid, saturating at its rails
        let adc = CurrentAdc { bits: 10, full_scale_a: 25.0 };
        assert_eq!((adc.max_code(), adc.lsb_a()), (1023, 50.0 / 1024.0));
        assert_eq!(adc.convert(0.0), (512, 0.0));
        assert_eq!(adc.convert(1.0), (512 + 20, 20.0 * 50.0 / 1024.0));
        assert_eq!(adc.convert(100.0), (1023, 511.0 * 50.0 / 1024.0));
        assert_eq!(adc.convert(-100.0), (0, -25.0));
    }

    #[test]
    fn presets_pass_their_check_and_bad_values_name_their_field() {
        for (name, chain, _) in SensorChain::PRESETS {
            assert_eq!(chain.check(1e-4), Ok(()), "{name}");
            assert_eq!(SensorChain::preset(name), Some(chain));
        }
        assert_eq!(SensorChain::preset("nucleo"), None);
        assert_eq!(SensorChain::default(), SensorChain::IDEAL);
        assert_eq!(SensorChain::NUCLEO_F446RE_ONESHOT.max_skew_s(), 10e-6);
        // the one-shot chain needs a control period longer than its last conversion
        let e = SensorChain::NUCLEO_F446RE_ONESHOT.check(10e-6).expect_err("10 µs is not within 10 µs");
        assert_eq!((e.field, e.phase), ("skew_us", Some(2)));
        assert!(e.to_string().starts_with("skew_us of phase c: 10 µs is outside [0, 10) µs"), "{e}");
        let mut bad = SensorChain::IDEAL;
        bad.adc.bits = 17;
        assert_eq!(bad.check(1e-4).map_err(|e| e.field), Err("adc_bits"));
        let mut bad = SensorChain::IDEAL;
        bad.adc.full_scale_a = 0.0;
        assert_eq!(bad.check(1e-4).map_err(|e| e.field), Err("full_scale_a"));
        for (field, change) in [
            ("offset_a", (|p: &mut PhaseSensor| p.offset_a = 20.0) as fn(&mut PhaseSensor)),
            ("gain_error", |p| p.gain_error = -0.6),
            ("bandwidth_hz", |p| p.bandwidth_hz = f64::INFINITY),
            ("skew_us", |p| p.skew_s = -1e-9),
        ] {
            let mut bad = SensorChain::IDEAL;
            change(&mut bad.phases[1]);
            let e = bad.check(1e-4).expect_err(field);
            assert_eq!((e.field, e.phase), (field, Some(1)));
        }
    }

    /// A skewed conversion takes the chain's output at `t_k + s_j`: on a current ramp through a
    /// sensor much faster than the step, the ramp's value there, whether `s_j` falls on a step
    /// or between two.
    #[test]
    fn a_skewed_conversion_reads_its_instant() {
        let dt = 0.25e-6;
        let mut chain = SensorChain::IDEAL;
        for (j, skew) in [0.0, 5.0e-6, 3.3e-6].into_iter().enumerate() {
            chain.phases[j].skew_s = skew;
            chain.phases[j].bandwidth_hz = 1e15; // no lag at this step
        }
        chain.phases[0].offset_a = 0.5;
        let mut sensing = CurrentSensing::new(&chain, [0.0; 3], [0.0; 3], dt);
        // ramp 1 A per µs from 2 A; a frame instant at step 0
        let ramp = |step: u32| 2.0 + f64::from(step) * dt * 1e6;
        for step in 1..=4 {
            sensing.update([ramp(step); 3]);
        }
        sensing.start_frame([0.0; 3]);
        assert!(!sensing.frame_complete());
        let mut step = 4;
        while !sensing.frame_complete() {
            step += 1;
            sensing.update([ramp(step); 3]);
        }
        assert_eq!(step, 4 + 20, "the last conversion, at 5 µs, ends the frame at its step");
        let (_, amps) = sensing.frame(false);
        let at_frame = ramp(4);
        assert!((amps[0] - (at_frame + 0.5)).abs() < 1e-9, "{amps:?}");
        assert!((amps[1] - (at_frame + 5.0)).abs() < 1e-9, "{amps:?}");
        assert!((amps[2] - (at_frame + 3.3)).abs() < 1e-9, "{amps:?}");
        // the ADC codes of those values
        let (codes, quantized) = sensing.frame(true);
        assert_eq!(codes.map(f64::from), quantized.map(|a| 2048.0 + a / f64::from(trace::AMPS_PER_COUNT)));
        // the lags start at the sensors' zero errors
        let at_rest = CurrentSensing::new(&SensorChain::NUCLEO_F446RE, [0.0; 3], [0.0; 3], dt);
        let mut at_rest = at_rest;
        at_rest.start_frame([0.0; 3]);
        assert_eq!(at_rest.frame(false).1, [0.15, -0.10, 0.12]);
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
