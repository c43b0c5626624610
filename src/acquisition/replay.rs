//! [`ReplayAdc`]: a board-agnostic `OneShot` ADC that replays a packed trace, frame by frame.

use core::fmt;

use embedded_hal::adc::{Channel, OneShot};

use super::{AcquisitionConfig, AdcError, AdcErrorKind, PhasePin};
use crate::trace::PackedTrace;

/// Why the replay could not give a code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ReplayError {
    /// Every frame of the trace has been read.
    EndOfTrace,
}

/// The acquisition settings a replay of `trace` is read with: its frames before the trigger are
/// its rest frames ([`AcquisitionConfig::for_recorded_rest`]).
pub fn replay_config(trace: &PackedTrace<'_>) -> AcquisitionConfig {
    AcquisitionConfig::for_recorded_rest(trace.trigger_frame() as usize)
}

impl fmt::Display for ReplayError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReplayError::EndOfTrace => f.write_str("end of the replayed trace"),
        }
    }
}

impl core::error::Error for ReplayError {}

impl AdcError for ReplayError {
    fn kind(&self) -> AdcErrorKind {
        match self {
            ReplayError::EndOfTrace => AdcErrorKind::EndOfData,
        }
    }
}

/// Replays a [`PackedTrace`] through embedded-hal 0.2's `OneShot<ReplayAdc, u16, PhaseX>`.
///
/// Each read of a phase pin returns that phase's code in the current frame; the frame advances once
/// all three channels of it have been read (in any order; reading a channel twice before that
/// returns the same code again). Past the last frame every read is `Err(ReplayError::EndOfTrace)`.
/// Optionally each conversion first answers `nb::WouldBlock` a fixed number of times, like a real
/// ADC that is still converting ([`ReplayAdc::with_busy_polls`]).
#[derive(Clone, Copy, Debug)]
pub struct ReplayAdc<'a> {
    trace: PackedTrace<'a>,
    next: usize,
    current: Option<[u16; 3]>,
    read_mask: u8,
    busy_polls: u16,
    busy_left: u16,
}

impl<'a> ReplayAdc<'a> {
    /// A replay from the first frame of `trace`.
    pub const fn new(trace: PackedTrace<'a>) -> Self {
        Self { trace, next: 0, current: None, read_mask: 0, busy_polls: 0, busy_left: 0 }
    }

    /// Every conversion answers `WouldBlock` `polls` times before its code.
    pub const fn with_busy_polls(mut self, polls: u16) -> Self {
        self.busy_polls = polls;
        self.busy_left = polls;
        self
    }

    /// The trace being replayed.
    pub const fn trace(&self) -> &PackedTrace<'a> {
        &self.trace
    }

    /// Index of the frame the next reads come from (= frames completed so far).
    pub const fn position(&self) -> usize {
        self.next
    }

    /// Frames not yet completed.
    pub const fn remaining(&self) -> usize {
        self.trace.frames().saturating_sub(self.next)
    }

    /// Back to the first frame.
    pub fn rewind(&mut self) {
        *self = Self::new(self.trace).with_busy_polls(self.busy_polls);
    }

    fn read_phase(&mut self, index: usize) -> nb::Result<u16, ReplayError> {
        let frame = match self.current {
            Some(f) => f,
            None => {
                let f = self.trace.frame(self.next).ok_or(nb::Error::Other(ReplayError::EndOfTrace))?;
                self.current = Some(f);
                f
            }
        };
        if self.busy_left > 0 {
            self.busy_left -= 1;
            return Err(nb::Error::WouldBlock);
        }
        self.busy_left = self.busy_polls;
        let code = match index {
            0 => frame[0],
            1 => frame[1],
            _ => frame[2],
        };
        self.read_mask |= 1 << index;
        if self.read_mask == 0b111 {
            self.read_mask = 0;
            self.current = None;
            self.next = self.next.saturating_add(1);
        }
        Ok(code)
    }
}

impl<'a, P> OneShot<ReplayAdc<'a>, u16, P> for ReplayAdc<'a>
where
    P: PhasePin + Channel<ReplayAdc<'a>>,
{
    type Error = ReplayError;

    fn read(&mut self, _pin: &mut P) -> nb::Result<u16, ReplayError> {
        self.read_phase(P::PHASE.index())
    }
}
