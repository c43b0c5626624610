//! What one acquisition counted: frames read, refused, and the longest refused run, and what
//! the sensors' self-calibration found; and when those make the recording a sensor fault.

use super::SensorCheck;

/// Largest share of refused frames before the recording is a sensor fault: 1 %. Each refused
/// frame is held at the last good one; 1 % of held frames changes at most 1 % of the samples of
/// `E`, within the identification's error on a clean recording.
pub const MAX_REFUSED_SHARE: f32 = 0.01;

/// Longest run of consecutive refused frames before the recording is a sensor fault: 40 frames
/// (4 ms at 10 kHz, 10 window samples). A longer hold is a flat segment the monitor model would
/// read as dynamics: the reversal transients it identifies from last about 40 ms, and a hold of a
/// tenth of that already moves the fitted friction and backlash.
pub const MAX_REFUSED_RUN: u32 = 40;

/// Counts of one acquisition (`diagnosis::acquire`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AcquisitionSummary {
    /// Complete frames read (good and refused).
    pub frames: u32,
    /// Frames refused by acquisition's checks and held at the last good frame.
    pub refused: u32,
    /// Longest run of consecutive refused frames.
    pub longest_refused_run: u32,
    /// The sensors' zero points and gain check (`acquisition::self_calibration`).
    pub sensors: SensorCheck,
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
    /// [`MAX_REFUSED_RUN`] frames, were refused, or the sensors' calibration is not trusted.
    pub fn is_sensor_fault(&self) -> bool {
        self.refused as f32 > MAX_REFUSED_SHARE * self.frames as f32
            || self.longest_refused_run > MAX_REFUSED_RUN
            || self.sensors.fault.is_some()
    }
}
