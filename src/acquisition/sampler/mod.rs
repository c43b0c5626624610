//! [`Sampler`]: timer-paced live acquisition, one frame per timer interrupt, a bounded queue to
//! thread mode, a start trigger with a timeout, and an overrun error.
//!
//! ```text
//!  timer interrupt (every Tc)                       thread mode
//!  SamplerProducer::tick(trigger) ── spsc queue ──► SamplerConsumer (PhaseCurrents) ─► diagnosis::acquire
//!  reads one frame from the source    (N − 1 frames)   waits with the caller's hook (e.g. `wfi`)
//! ```
//!
//! **Producer** ([`SamplerProducer::tick`], called from the timer's interrupt once per control
//! period `Tc`): reads one frame from its [`PhaseCurrents`] source on *every* tick, so that a
//! replay's position follows time whether or not the frame is kept.
//! - *Armed*: while the `trigger` input is low the frame is a rest frame
//!   ([`PhaseCurrents::read_rest_frame`]: the actuator at rest, its codes go to the sensors' zero
//!   points when the source measures them). The first high tick tells the source the manoeuvre
//!   may start ([`PhaseCurrents::start_recording`]: the zero points fixed from the rest frames so
//!   far, the stuck and sum history from here on), and its frame is the manoeuvre's first (three
//!   conversions and the checks of [`FrameCheck`](super::FrameCheck)). The trigger counts once
//!   it is seen high on `C + 1` consecutive ticks (`C`, the sampler's second parameter, 0 by
//!   default: the first high tick counts); the recording then starts with the frame of the first
//!   of them, the `C` frames read while the level was being confirmed having been held in the
//!   producer, and what the source's self-calibration found is stored for the consumer
//!   ([`PhaseCurrents::sensor_check`]). A high run shorter than that (a glitch) is dropped with
//!   its held frames; the rest frames go on accumulating, and the next high tick fixes the zero
//!   points again. If the trigger has not counted after [`SamplerConfig::trigger_timeout_frames`]
//!   ticks, the acquisition ends with [`AcquisitionError::NoTrigger`]. A source that ends first
//!   (a replay) completes it with no frame, which the conditioning then refuses as too short.
//! - *Recording*: the frame (a refused one too, as its error: it still takes one period) goes into
//!   the queue. After [`SamplerConfig::frames`] frames (the manoeuvre's frame count,
//!   [`manoeuvre_frames`](super::manoeuvre_frames)) the acquisition is complete. A source that
//!   reports [`AcquisitionError::EndOfData`] (a replay shorter than the manoeuvre) completes it
//!   early.
//! - A full queue when a frame is to be queued means thread mode has fallen `N − 1` periods
//!   behind: the acquisition ends with [`AcquisitionError::Overrun`], naming the frame lost. A
//!   recording with a gap would no longer be aligned with the command profile, so it is not
//!   continued.
//! - Once ended, `tick` does nothing: the timer may keep running until thread mode stops it (a
//!   consumer waiting with `wfi` then always wakes up to see the end). With both halves in hand
//!   again, [`SamplerProducer::rearm`] arms the next acquisition on the same queue and source.
//!
//! **Consumer** ([`SamplerConsumer`], thread mode): a [`PhaseCurrents`] source for
//! [`diagnosis::acquire`](crate::diagnosis::acquire). `read_frame` returns the next queued frame,
//! waits with its hook while the queue is empty, and returns [`AcquisitionError::EndOfData`] once
//! the acquisition has ended (complete, overrun or no trigger). Why it ended is
//! [`SamplerConsumer::outcome`]: the caller checks it after `acquire`, before using the trace.
//!
//! **Queue.** `heapless::spsc::Queue`: lock-free for one producer and one consumer (atomic head
//! and tail indices, no critical section in the interrupt), fixed capacity `N − 1`, no allocation.
//! The end state is one atomic byte the producer writes after its last enqueue (release) and the
//! consumer reads before dequeuing (acquire), so the consumer never reports the end before it has
//! returned every frame queued before it.

use core::sync::atomic::{AtomicU32, AtomicU8, Ordering};

use heapless::spsc::{Consumer, Producer, Queue};

use super::{AcquisitionError, Phase, PhaseCurrents, PhaseFrame, SensorCheck, SensorFault, ZeroSource};

/// What the producer queues for each recorded frame: the frame, or why it was refused.
pub type Sample = Result<PhaseFrame, AcquisitionError>;

/// Queue length of the on-board sampler: 64 slots, 63 frames (6.3 ms at 10 kHz) of slack for
/// thread mode, 1.5 KiB of RAM.
pub const SAMPLER_QUEUE: usize = 64;

/// Settings of one live acquisition.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SamplerConfig {
    /// Frames recorded from the trigger on (the manoeuvre's frame count).
    pub frames: u32,
    /// Ticks waited for the trigger before [`AcquisitionError::NoTrigger`].
    pub trigger_timeout_frames: u32,
}

const ARMED: u8 = 0;
const RECORDING: u8 = 1;
const COMPLETE: u8 = 2;
const OVERRUN: u8 = 3;
const NO_TRIGGER: u8 = 4;

/// Where an acquisition stands, as the consumer sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SamplerState {
    /// Waiting for the trigger.
    Armed,
    /// Queuing frames.
    Recording,
    /// Every frame is queued (or the source ended): nothing more comes.
    Complete,
    /// Ended with an error ([`AcquisitionError::Overrun`] or [`AcquisitionError::NoTrigger`]).
    Failed(AcquisitionError),
}

/// The state shared by the two halves: written by the producer only.
#[derive(Debug)]
struct Shared {
    state: AtomicU8,
    /// Ticks seen before the trigger.
    waited: AtomicU32,
    /// Frames queued since the trigger.
    queued: AtomicU32,
    /// The source's [`SensorCheck`] at the trigger ([`encode_check`]), written before the state
    /// becomes [`RECORDING`] (release) and read after it is seen (acquire).
    sensors: [AtomicU32; CHECK_WORDS],
}

impl Shared {
    const fn new() -> Self {
        Self {
            state: AtomicU8::new(ARMED),
            waited: AtomicU32::new(0),
            queued: AtomicU32::new(0),
            sensors: [const { AtomicU32::new(0) }; CHECK_WORDS],
        }
    }

    /// The sensor check the producer stored at the trigger; the declared one before it.
    fn sensors(&self) -> SensorCheck {
        if self.state.load(Ordering::Acquire) == ARMED {
            return SensorCheck::DECLARED;
        }
        decode_check(&self.sensors.each_ref().map(|w| w.load(Ordering::Relaxed)))
    }

    fn state(&self) -> SamplerState {
        match self.state.load(Ordering::Acquire) {
            ARMED => SamplerState::Armed,
            RECORDING => SamplerState::Recording,
            OVERRUN => SamplerState::Failed(AcquisitionError::Overrun { frame: self.queued.load(Ordering::Relaxed) }),
            NO_TRIGGER => {
                SamplerState::Failed(AcquisitionError::NoTrigger { waited_frames: self.waited.load(Ordering::Relaxed) })
            }
            _ => SamplerState::Complete,
        }
    }
}

/// The storage of one live acquisition: a queue of `N − 1` frames and the shared state. Place it
/// in a `static` (e.g. `cortex_m::singleton!`) so that its producer half can be handed to the
/// timer's interrupt, then [`Sampler::split`] it. `C` is the trigger's glitch filter: the ticks
/// the trigger must stay high after its first high tick before it counts (module doc); the
/// producer holds that many frames, so that `C` sizes its buffer and the default, 0, holds none.
#[derive(Debug)]
pub struct Sampler<const N: usize, const C: usize = 0> {
    queue: Queue<Sample, N>,
    shared: Shared,
}

impl<const N: usize, const C: usize> Sampler<N, C> {
    /// An empty sampler (`const`, so it can initialise a `static`).
    pub const fn new() -> Self {
        Self { queue: Queue::new(), shared: Shared::new() }
    }

    /// Frames the queue holds: `N − 1`.
    pub const fn capacity(&self) -> usize {
        N.saturating_sub(1)
    }

    /// Arms a new acquisition of `config` from `source`: the producer half for the timer's
    /// interrupt (owning the source), the consumer half for thread mode, which waits with `wait`
    /// while the queue is empty (`cortex_m::asm::wfi` on a target, `core::hint::spin_loop` on the
    /// host).
    pub fn split<S, W: FnMut()>(
        &mut self,
        source: S,
        config: SamplerConfig,
        wait: W,
    ) -> (SamplerProducer<'_, S, C>, SamplerConsumer<'_, W>) {
        self.queue = Queue::new();
        self.shared = Shared::new();
        let (producer, consumer) = self.queue.split();
        let shared = &self.shared;
        const { assert!(C < 256, "the trigger's glitch filter holds at most 255 frames") };
        let held = [Err(AcquisitionError::EndOfData); C];
        (
            SamplerProducer {
                queue: producer,
                shared,
                source,
                config,
                ticks: 0,
                state: ARMED,
                queued: 0,
                held,
                high: 0,
            },
            SamplerConsumer { queue: consumer, shared, wait, read: 0 },
        )
    }
}

impl<const N: usize, const C: usize> Default for Sampler<N, C> {
    fn default() -> Self {
        Self::new()
    }
}

/// The interrupt half: one [`SamplerProducer::tick`] per timer period. `C` is the trigger's
/// glitch filter ([`Sampler`]).
pub struct SamplerProducer<'a, S, const C: usize = 0> {
    queue: Producer<'a, Sample>,
    shared: &'a Shared,
    source: S,
    config: SamplerConfig,
    ticks: u32,
    state: u8,
    queued: u32,
    /// The frames of the trigger's first high ticks while it is being confirmed (armed only).
    held: [Sample; C],
    /// Consecutive high ticks so far, while armed, at most `C` (below 256, checked when the
    /// sampler is split): the frames in `held`.
    high: u8,
}

impl<S, const C: usize> SamplerProducer<'_, S, C> {
    /// Ticks seen so far (from arming; one per call of [`SamplerProducer::tick`]).
    pub const fn ticks(&self) -> u32 {
        self.ticks
    }

    /// `true` once the acquisition has ended (complete, overrun or no trigger): the timer can stop.
    pub const fn ended(&self) -> bool {
        self.state >= COMPLETE
    }

    /// The source.
    pub const fn source(&self) -> &S {
        &self.source
    }

    /// The source, for use between acquisitions (e.g. another input of the same ADC while no
    /// tick runs).
    pub fn source_mut(&mut self) -> &mut S {
        &mut self.source
    }

    /// Gives the source back.
    pub fn release(self) -> S {
        self.source
    }

    fn end(&mut self, state: u8) {
        self.state = state;
        if state == NO_TRIGGER {
            self.shared.waited.store(self.ticks, Ordering::Relaxed);
        }
        self.shared.queued.store(self.queued, Ordering::Relaxed);
        self.shared.state.store(state, Ordering::Release);
    }
}

impl<S: PhaseCurrents, const C: usize> SamplerProducer<'_, S, C> {
    /// Arms the next acquisition of `config` on the same queue and source, without a new
    /// [`Sampler::split`]: the frames `consumer` has not read are dropped, the counts and the
    /// state start again (armed), and the source's rest frames too ([`PhaseCurrents::rearm`]). Both halves are borrowed mutably, so no tick runs while the
    /// queue is emptied: the caller has taken the producer back from the timer's interrupt.
    /// `false`, and nothing changes, when `consumer` is the other half of another sampler.
    pub fn rearm<W>(&mut self, consumer: &mut SamplerConsumer<'_, W>, config: SamplerConfig) -> bool {
        if !core::ptr::eq(self.shared, consumer.shared) {
            return false;
        }
        if !no_slot(consumer.queue.capacity()) {
            // no producer runs, so the queue empties within its capacity
            for _ in 0..consumer.queue.capacity() {
                if consumer.queue.dequeue().is_none() {
                    break;
                }
            }
        }
        self.source.rearm();
        self.config = config;
        self.ticks = 0;
        self.state = ARMED;
        self.queued = 0;
        self.high = 0;
        consumer.read = 0;
        self.shared.waited.store(0, Ordering::Relaxed);
        self.shared.queued.store(0, Ordering::Relaxed);
        self.shared.state.store(ARMED, Ordering::Release);
        true
    }

    /// One timer period: reads one frame from the source and drops it (armed), holds it (armed,
    /// the trigger being confirmed), queues it (recording) or does nothing (ended); `trigger` is
    /// the start input's level at this tick. Returns [`SamplerProducer::ended`].
    pub fn tick(&mut self, trigger: bool) -> bool {
        if self.ended() {
            return true;
        }
        self.ticks = self.ticks.saturating_add(1);
        if self.state == ARMED {
            if !trigger {
                self.high = 0; // a glitch's held frames are dropped
                if matches!(self.source.read_rest_frame(), Err(AcquisitionError::EndOfData)) {
                    self.end(COMPLETE);
                    return true;
                }
            } else {
                if self.high == 0 {
                    // the first high tick: the zero points from the rest frames so far, so that
                    // the frames from here on are checked through them
                    self.source.start_recording();
                }
                let sample = self.source.read_frame();
                if matches!(sample, Err(AcquisitionError::EndOfData)) {
                    self.end(COMPLETE);
                    return true;
                }
                if let Some(slot) = self.held.get_mut(usize::from(self.high)) {
                    // high, not yet on `C + 1` ticks: held until the trigger counts
                    *slot = sample;
                    self.high += 1;
                } else {
                    return self.start(sample);
                }
            }
            if self.ticks >= self.config.trigger_timeout_frames {
                self.end(NO_TRIGGER);
            }
            return self.ended();
        }
        let sample = self.source.read_frame();
        let source_ended = matches!(sample, Err(AcquisitionError::EndOfData));
        self.record(sample, source_ended)
    }

    /// The trigger counts at this tick: the recording starts with the held frames of its first
    /// high ticks, then this tick's `sample`. Inlined, as [`SamplerProducer::record`]: the tick
    /// runs in the timer's interrupt, on top of thread mode's deepest stack.
    #[inline(always)]
    fn start(&mut self, sample: Sample) -> bool {
        let count = self.high;
        self.high = 0;
        self.state = RECORDING;
        for (word, value) in self.shared.sensors.iter().zip(encode_check(&self.source.sensor_check())) {
            word.store(value, Ordering::Relaxed);
        }
        self.shared.waited.store(self.ticks.saturating_sub(1 + u32::from(count)), Ordering::Relaxed);
        self.shared.state.store(RECORDING, Ordering::Release);
        if C > 0 {
            // (no filter, no frame held: the block folds away)
            for i in 0..usize::from(count) {
                let Some(&frame) = self.held.get(i) else { break };
                if self.record(frame, false) {
                    return true;
                }
            }
        }
        self.record(sample, false)
    }

    /// Queues one recorded `sample`, or ends the acquisition: complete after the frame count or
    /// when the source has ended, overrun when the queue is full.
    #[inline(always)]
    fn record(&mut self, sample: Sample, source_ended: bool) -> bool {
        if self.queued >= self.config.frames || source_ended {
            self.end(COMPLETE);
            return true;
        }
        if no_slot(self.queue.capacity()) || self.queue.enqueue(sample).is_err() {
            self.end(OVERRUN);
            return true;
        }
        self.queued += 1;
        if self.queued >= self.config.frames {
            self.end(COMPLETE);
        }
        self.ended()
    }
}

/// Words of an encoded [`SensorCheck`] (its gain check, made in thread mode, left out).
const CHECK_WORDS: usize = 10;

/// `check` as words for the shared atomics: `[source | fault kind << 8 | fault phase << 16,
/// zero shifts ×3, rest sd ×3, rest frames, fault value, fault frames needed]`.
fn encode_check(check: &SensorCheck) -> [u32; CHECK_WORDS] {
    let source = match check.source {
        ZeroSource::Declared => 0u32,
        ZeroSource::Rest => 1,
    };
    let (kind, phase, value, needed) = match check.fault {
        None => (0u32, 0usize, 0u32, 0u32),
        Some(SensorFault::TooFewRestFrames { frames, needed }) => (1, 0, frames, needed),
        Some(SensorFault::NotAtRest { phase, sd_counts }) => (2, phase.index(), sd_counts.to_bits(), 0),
        Some(SensorFault::ZeroBeyondRange { phase, shift_counts }) => (3, phase.index(), shift_counts.to_bits(), 0),
        Some(SensorFault::GainMismatch { phase, mismatch }) => (4, phase.index(), mismatch.to_bits(), 0),
    };
    let [s0, s1, s2] = check.zero_shift_counts.map(f32::to_bits);
    let [d0, d1, d2] = check.rest_sd_counts.map(f32::to_bits);
    [source | kind << 8 | (phase as u32) << 16, s0, s1, s2, d0, d1, d2, check.rest_frames, value, needed]
}

/// The inverse of [`encode_check`].
fn decode_check(w: &[u32; CHECK_WORDS]) -> SensorCheck {
    let phase = match (w[0] >> 16) & 0xFF {
        0 => Phase::A,
        1 => Phase::B,
        _ => Phase::C,
    };
    let value = f32::from_bits(w[8]);
    let fault = match (w[0] >> 8) & 0xFF {
        0 => None,
        1 => Some(SensorFault::TooFewRestFrames { frames: w[8], needed: w[9] }),
        2 => Some(SensorFault::NotAtRest { phase, sd_counts: value }),
        3 => Some(SensorFault::ZeroBeyondRange { phase, shift_counts: value }),
        _ => Some(SensorFault::GainMismatch { phase, mismatch: value }),
    };
    SensorCheck {
        source: if w[0] & 0xFF == 0 { ZeroSource::Declared } else { ZeroSource::Rest },
        zero_shift_counts: [w[1], w[2], w[3]].map(f32::from_bits),
        rest_sd_counts: [w[4], w[5], w[6]].map(f32::from_bits),
        rest_frames: w[7],
        fault,
        ..SensorCheck::DECLARED
    }
}

/// `true` when the queue has no slot at all (`N = 0`: `capacity` = `N − 1` wraps), where every
/// frame overruns.
/// heapless's split halves index the ring modulo the length of a slice view, which the optimizer
/// cannot see is `N`; testing it first tells it the length is not 0, so that no division-by-zero
/// panic path remains (`scripts/prove-no-panic`).
const fn no_slot(capacity: usize) -> bool {
    capacity == usize::MAX
}

/// The thread-mode half: a [`PhaseCurrents`] source of the recorded frames.
pub struct SamplerConsumer<'a, W> {
    queue: Consumer<'a, Sample>,
    shared: &'a Shared,
    wait: W,
    read: u32,
}

impl<W> SamplerConsumer<'_, W> {
    /// Where the acquisition stands.
    pub fn state(&self) -> SamplerState {
        self.shared.state()
    }

    /// Frames returned so far.
    pub const fn frames_read(&self) -> u32 {
        self.read
    }

    /// Frames waiting in the queue.
    pub fn queued(&self) -> usize {
        self.queue.len()
    }

    /// Ticks dropped before the trigger's first high tick, the recording's first frame (0 until
    /// the trigger counts or the timeout).
    pub fn waited_frames(&self) -> u32 {
        self.shared.waited.load(Ordering::Relaxed)
    }

    /// How the acquisition ended: `Ok(frames recorded)` when complete,
    /// [`AcquisitionError::Overrun`] or [`AcquisitionError::NoTrigger`] when it failed, and
    /// [`AcquisitionError::EndOfData`] while it is still running.
    pub fn outcome(&self) -> Result<u32, AcquisitionError> {
        match self.shared.state() {
            SamplerState::Complete => Ok(self.shared.queued.load(Ordering::Relaxed)),
            SamplerState::Failed(e) => Err(e),
            SamplerState::Armed | SamplerState::Recording => Err(AcquisitionError::EndOfData),
        }
    }
}

impl<W: FnMut()> PhaseCurrents for SamplerConsumer<'_, W> {
    /// The next recorded frame; waits (the hook) while none is queued; `EndOfData` once the
    /// acquisition has ended and every frame queued before a complete end has been returned
    /// (after an overrun or no trigger: at once, see [`SamplerConsumer::outcome`]).
    fn read_frame(&mut self) -> Result<PhaseFrame, AcquisitionError> {
        loop {
            let state = self.shared.state.load(Ordering::Acquire);
            if state == OVERRUN || state == NO_TRIGGER {
                return Err(AcquisitionError::EndOfData);
            }
            if no_slot(self.queue.capacity()) {
                return Err(AcquisitionError::EndOfData);
            }
            if let Some(sample) = self.queue.dequeue() {
                self.read = self.read.saturating_add(1);
                return sample;
            }
            if state == COMPLETE {
                return Err(AcquisitionError::EndOfData);
            }
            (self.wait)();
        }
    }

    /// The source's sensor check, as the producer stored it at the trigger.
    fn sensor_check(&self) -> SensorCheck {
        self.shared.sensors()
    }
}

#[cfg(test)]
mod tests;
