//! What the data allow the monitor to say: the acquisition's refused frames, the recording's
//! coverage of the manoeuvre, and the goodness of the best fit against the noise model
//! ([`crate::health::Status`]; `docs/identification.md`, "Status and when the monitor abstains").

use crate::conditioning::{MeasuredEnvelope, DECIMATION};
use crate::params::EmaParams;

pub use crate::acquisition::AcquisitionSummary;
pub use crate::conditioning::covers;

/// The monitor model's structural mismatch allowed for in the goodness-of-fit test, in A RMS per
/// window sample: twice the healthy actuator's measured mismatch floor (0.0149 A,
/// `docs/results/mismatch-floor.md`), covering the largest floor with library faults (0.0201 A,
/// backlash and gain) with a margin. The mismatch is smooth, so block means keep all of it.
pub const MODEL_MISMATCH_A: f32 = 0.030;

/// Noise variance of one window sample (a block mean of [`DECIMATION`] frames of `I_3eq`), A²:
/// `σ² = (σ_j² + σ_s² + σ_ripple²)/n`, the controller jitter, sensor noise and sensed hysteresis
/// ripple of the conducting pair ([`MeasuredEnvelope`]), with `n` the independent frames in a
/// block: [`DECIMATION`] when every frame was sampled (frames independent from one to the next),
/// fewer when the frames were interpolated from a slower recording (a 5 kHz file brought to
/// 10 kHz has 2 independent frames a block). `n` is clamped to `[1, DECIMATION]`; a non-finite
/// `n` counts as [`DECIMATION`].
pub fn window_noise_variance_a2(params: &EmaParams, independent_frames: f32) -> f32 {
    let jitter = MeasuredEnvelope::controller_jitter_a(params);
    let ripple = MeasuredEnvelope::sensed_ripple_a(params);
    let sensor = params.current_noise_a;
    let n = if independent_frames.is_finite() {
        independent_frames.clamp(1.0, DECIMATION as f32)
    } else {
        DECIMATION as f32
    };
    (jitter * jitter + sensor * sensor + ripple * ripple) / n
}

/// `true` when a declared sample rate (Hz) is the monitor's control rate `1/T` (to 0.1 %).
pub fn rate_matches(rate_hz: f32, params: &EmaParams) -> bool {
    let expected = 1.0 / params.control_period_s;
    rate_hz.is_finite() && libm::fabsf(rate_hz - expected) <= 1e-3 * expected
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::acquisition::MAX_REFUSED_RUN;

    #[test]
    fn sensor_fault_coverage_and_rate_rules() {
        let p = EmaParams::NOMINAL;
        assert!(covers(2125, 0.85, &p) && covers(2124, 0.85, &p) && !covers(2125 / 6, 0.85, &p));
        assert!(rate_matches(10_000.0, &p) && !rate_matches(1_000.0, &p) && !rate_matches(f32::NAN, &p));
        let run = AcquisitionSummary {
            frames: 100_000,
            refused: MAX_REFUSED_RUN + 1,
            longest_refused_run: MAX_REFUSED_RUN + 1,
            ..Default::default()
        };
        assert!(run.is_sensor_fault());
        let scattered = AcquisitionSummary { frames: 8500, refused: 86, longest_refused_run: 1, ..Default::default() };
        assert!(scattered.is_sensor_fault());
        let few = AcquisitionSummary { frames: 8500, refused: 85, longest_refused_run: 1, ..Default::default() };
        assert!(!few.is_sensor_fault());
    }
}
