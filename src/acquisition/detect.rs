//! The stuck-channel and sum rules of the reader (rules and defaults: the module doc of
//! [`acquisition`](super)). Constant memory: a few words per phase, no history buffer.

use super::{AcquisitionConfig, Phase};

/// A run of identical codes on one channel, and the span the other two channels covered meanwhile.
#[derive(Clone, Copy, Debug)]
struct Run {
    code: u16,
    len: u32,
    /// min and max of the two other channels (in phase order) since the run started
    lo: [u16; 2],
    hi: [u16; 2],
}

/// Tracks one [`Run`] per channel.
#[derive(Clone, Copy, Debug)]
pub(super) struct StuckDetector {
    runs: [Run; 3],
}

/// The two other phases of `j`, in phase order.
const fn others(j: usize) -> [usize; 2] {
    match j {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    }
}

impl StuckDetector {
    pub(super) const fn new() -> Self {
        Self { runs: [Run { code: 0, len: 0, lo: [0; 2], hi: [0; 2] }; 3] }
    }

    /// Feeds one frame of codes; returns the first stuck phase (and its code), if any.
    pub(super) fn update(
        &mut self,
        codes: [u16; 3],
        zero_codes: [u16; 3],
        cfg: &AcquisitionConfig,
    ) -> Option<(Phase, u16)> {
        let mut stuck = None;
        for phase in Phase::ALL {
            let j = phase.index();
            let o = others(j);
            let other = [codes[o[0]], codes[o[1]]];
            let run = &mut self.runs[j];
            if run.len == 0 || run.code != codes[j] {
                *run = Run { code: codes[j], len: 1, lo: other, hi: other };
            } else {
                run.len = run.len.saturating_add(1);
                for ((lo, hi), &x) in run.lo.iter_mut().zip(run.hi.iter_mut()).zip(other.iter()) {
                    *lo = (*lo).min(x);
                    *hi = (*hi).max(x);
                }
            }
            let long = run.len >= cfg.stuck_min_frames;
            let others_moved =
                run.hi.iter().zip(run.lo.iter()).any(|(hi, lo)| hi.abs_diff(*lo) >= cfg.stuck_activity_counts);
            let off_zero = run.code.abs_diff(zero_codes[j]) > cfg.stuck_zero_band_counts;
            if stuck.is_none() && long && others_moved && off_zero {
                stuck = Some((phase, run.code));
            }
        }
        stuck
    }
}

/// Counts consecutive frames whose current sum is beyond the tolerance.
#[derive(Clone, Copy, Debug)]
pub(super) struct SumDetector {
    consecutive: u32,
}

impl SumDetector {
    pub(super) const fn new() -> Self {
        Self { consecutive: 0 }
    }

    /// Feeds the sum of one frame whose largest phase current is `peak_a` (its magnitude);
    /// `true` when it is to be reported as inconsistent. A NaN sum (cannot come from a valid
    /// calibration) counts as inconsistent.
    pub(super) fn update(&mut self, sum_a: f32, peak_a: f32, cfg: &AcquisitionConfig) -> bool {
        let ok = libm::fabsf(sum_a) <= cfg.sum_tolerance_at(peak_a);
        if ok {
            self.consecutive = 0;
            false
        } else {
            self.consecutive = self.consecutive.saturating_add(1);
            self.consecutive >= cfg.sum_frames
        }
    }
}
