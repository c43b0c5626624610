//! What the data allow the monitor to say: the acquisition's refused frames, the recording's
//! coverage of the manoeuvre, and the goodness of the best fit against the noise model
//! ([`crate::health::Status`]; `docs/identification.md`, "Status and when the monitor abstains").

use crate::conditioning::{MeasuredEnvelope, DECIMATION};
use crate::params::EmaParams;

/// Largest share of refused frames before the recording is a sensor fault: 1 %. Each refused
/// frame is held at the last good one; 1 % of held frames changes at most 1 % of the samples of
/// `E`, within the identification's error on a clean recording.
pub const MAX_REFUSED_SHARE: f32 = 0.01;

/// Longest run of consecutive refused frames before the recording is a sensor fault: 40 frames
/// (4 ms at 10 kHz, 10 window samples). A longer hold is a flat segment the monitor model would
/// read as dynamics: the reversal transients it identifies from last about 40 ms, and a hold of a
/// tenth of that already moves the fitted friction and backlash.
pub const MAX_REFUSED_RUN: u32 = 40;

/// The monitor model's structural mismatch allowed for in the goodness-of-fit test, in A RMS per
/// window sample: twice the healthy actuator's measured mismatch floor (0.0149 A,
/// `docs/results/mismatch-floor.md`), covering the largest floor with library faults (0.0201 A,
/// backlash and gain) with a margin. The mismatch is smooth, so block means keep all of it.
pub const MODEL_MISMATCH_A: f32 = 0.030;

/// Counts of one acquisition ([`super::acquire`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AcquisitionSummary {
    /// Complete frames read (good and refused).
    pub frames: u32,
    /// Frames refused by acquisition's checks and held at the last good frame.
    pub refused: u32,
    /// Longest run of consecutive refused frames.
    pub longest_refused_run: u32,
}

impl AcquisitionSummary {
    /// Counts one frame, refused or not.
    pub fn count(&mut self, refused: bool, run: &mut u32) {
        self.frames = self.frames.saturating_add(1);
        if refused {
            self.refused = self.refused.saturating_add(1);
            *run = run.saturating_add(1);
            self.longest_refused_run = self.longest_refused_run.max(*run);
        } else {
            *run = 0;
        }
    }

    /// `true` when more than [`MAX_REFUSED_SHARE`] of the frames, or a run of more than
    /// [`MAX_REFUSED_RUN`] frames, were refused.
    pub fn is_sensor_fault(&self) -> bool {
        self.refused as f32 > MAX_REFUSED_SHARE * self.frames as f32 || self.longest_refused_run > MAX_REFUSED_RUN
    }
}

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

/// `true` when `samples` window samples cover a manoeuvre of `duration_s` at the control period of
/// `params`, up to one window sample (the partial block conditioning drops) and half a sample
/// for the rounding of the product.
pub fn covers(samples: usize, duration_s: f32, params: &EmaParams) -> bool {
    let sample_s = DECIMATION as f32 * params.control_period_s;
    (samples as f32 + 1.5) * sample_s >= duration_s
}

/// `true` when a declared sample rate (Hz) is the monitor's control rate `1/T` (to 0.1 %).
pub fn rate_matches(rate_hz: f32, params: &EmaParams) -> bool {
    let expected = 1.0 / params.control_period_s;
    rate_hz.is_finite() && libm::fabsf(rate_hz - expected) <= 1e-3 * expected
}
