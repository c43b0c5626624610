//! [`FrameLimit`]: ends a live acquisition on the manoeuvre's frame count.

use super::{AcquisitionError, PhaseCurrents, PhaseFrame};
use crate::command::CommandSource;
use crate::params::EmaParams;

/// A [`PhaseCurrents`] source that yields at most `frames` frames, then
/// [`AcquisitionError::EndOfData`].
///
/// A replayed recording ends by itself; a live ADC never does, so the acquisition of a board ends
/// on the number of control periods the manoeuvre lasts, `N = round(T / Tc)`
/// ([`manoeuvre_frames`]). Every call counts, a refused frame too (it still takes one
/// control period), so the window covers exactly `N · Tc` of time. Once the count is reached, the
/// inner source is not read again.
#[derive(Clone, Debug)]
pub struct FrameLimit<S> {
    source: S,
    remaining: u32,
}

impl<S> FrameLimit<S> {
    /// Reads at most `frames` frames from `source`.
    pub const fn new(source: S, frames: u32) -> Self {
        Self { source, remaining: frames }
    }

    /// Reads the frames of one run of `command` (a [`crate::Profile`] or a sampled command) at
    /// the control rate of `params` ([`manoeuvre_frames`]).
    pub fn manoeuvre<'c>(source: S, command: impl CommandSource<'c>, params: &EmaParams) -> Self {
        Self::new(source, manoeuvre_frames(command, params))
    }

    /// Frames left before the end of data.
    pub const fn remaining(&self) -> u32 {
        self.remaining
    }

    /// The inner source.
    pub const fn source(&self) -> &S {
        &self.source
    }

    /// Gives the inner source back.
    pub fn release(self) -> S {
        self.source
    }
}

impl<S: PhaseCurrents> PhaseCurrents for FrameLimit<S> {
    fn read_frame(&mut self) -> Result<PhaseFrame, AcquisitionError> {
        if self.remaining == 0 {
            return Err(AcquisitionError::EndOfData);
        }
        self.remaining -= 1;
        self.source.read_frame()
    }
}

/// Frames in one run of `command` at the control rate ([`crate::Command::frames`]): `round(T / Tc)` with
/// `T` a profile's duration and `Tc` the control period (the standard manoeuvre: 0.85 s / 100 µs =
/// 8500), or a sampled command's samples × stride. A non-finite or negative ratio gives 0 (the
/// `as` cast saturates; nothing panics).
pub fn manoeuvre_frames<'c>(command: impl CommandSource<'c>, params: &EmaParams) -> u32 {
    command.into_command().frames(params)
}
