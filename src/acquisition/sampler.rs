//! [`Sampler`]: timer-paced live acquisition, one frame per timer interrupt, a bounded queue to
//! thread mode, a start trigger with a timeout, and an overrun error.
//!
//! ```text
//!  timer interrupt (every Tc)                       thread mode
//!  SamplerProducer::tick(trigger) ── spsc queue ──► SamplerConsumer (PhaseCurrents) ─► monitor::acquire
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
//! [`monitor::acquire`](crate::monitor::acquire). `read_frame` returns the next queued frame,
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
mod tests {
    use core::cell::RefCell;

    use super::*;
    use crate::acquisition::{
        AcquisitionConfig, Calibration, PhaseA, PhaseB, PhaseC, PhaseCurrentReader, ReplayAdc, ReplayReader,
    };
    use crate::trace::{self, pack, packed_len, PackedTrace};

    /// `n` clean frames whose phase-A code names the frame: `[1000 + i, 3096 − i, 2048]`.
    fn numbered(n: usize) -> std::vec::Vec<u8> {
        let frames: std::vec::Vec<[u16; 3]> = (0..n as u16).map(|i| [1000 + i, 3096 - i, 2048]).collect();
        let mut buf = std::vec![0u8; packed_len(n)];
        pack(&frames, trace::SAMPLE_RATE_HZ, &mut buf).unwrap();
        buf
    }

    fn reader(bytes: &[u8]) -> ReplayReader<'_> {
        let adc = ReplayAdc::new(PackedTrace::parse(bytes).unwrap());
        PhaseCurrentReader::new(adc, (PhaseA, PhaseB, PhaseC), Calibration::NOMINAL, AcquisitionConfig::DEFAULT)
            .unwrap()
    }

    fn config(frames: u32, trigger_timeout_frames: u32) -> SamplerConfig {
        SamplerConfig { frames, trigger_timeout_frames }
    }

    /// Drains the consumer, the producer ticking in the wait hook (an interrupt per wait) with the
    /// trigger high from tick `trigger_at` on. Returns the phase-A codes read and the outcome.
    fn run<const N: usize>(
        bytes: &[u8],
        cfg: SamplerConfig,
        trigger_at: u32,
    ) -> (std::vec::Vec<u16>, Result<u32, AcquisitionError>) {
        let (codes, outcome, _) = run_filtered::<N, 0>(bytes, cfg, |t| t >= trigger_at);
        (codes, outcome)
    }

    /// [`run`] through a sampler with glitch filter `C`, the trigger's level at tick `t` (from 0)
    /// being `high(t)`. Returns the phase-A codes read, the outcome and the ticks waited.
    fn run_filtered<const N: usize, const C: usize>(
        bytes: &[u8],
        cfg: SamplerConfig,
        high: impl Fn(u32) -> bool,
    ) -> (std::vec::Vec<u16>, Result<u32, AcquisitionError>, u32) {
        let mut sampler = Sampler::<N, C>::new();
        let slot: RefCell<Option<SamplerProducer<'_, ReplayReader<'_>, C>>> = RefCell::new(None);
        let (producer, mut consumer) = sampler.split(reader(bytes), cfg, || {
            if let Some(p) = slot.borrow_mut().as_mut() {
                let t = p.ticks();
                p.tick(high(t));
            }
        });
        *slot.borrow_mut() = Some(producer);
        let mut codes = std::vec::Vec::new();
        loop {
            match consumer.read_frame() {
                Ok(f) => codes.push(f.codes[0]),
                Err(AcquisitionError::EndOfData) => break,
                Err(e) => panic!("frame refused: {e}"),
            }
        }
        let outcome = consumer.outcome();
        assert_eq!(consumer.frames_read() as usize, codes.len());
        (codes, outcome, consumer.waited_frames())
    }

    #[test]
    fn records_exactly_the_frame_count_from_the_first_tick() {
        let bytes = numbered(300);
        let (codes, outcome) = run::<8>(&bytes, config(200, 1000), 0);
        assert_eq!(outcome, Ok(200));
        assert_eq!(codes, (1000..1200).collect::<std::vec::Vec<u16>>());
    }

    #[test]
    fn late_trigger_drops_the_frames_before_it() {
        let bytes = numbered(300);
        let (codes, outcome) = run::<8>(&bytes, config(200, 1000), 57);
        assert_eq!(outcome, Ok(200));
        assert_eq!(codes, (1057..1257).collect::<std::vec::Vec<u16>>());
    }

    #[test]
    fn missing_trigger_ends_with_no_trigger_after_the_timeout() {
        let bytes = numbered(300);
        let (codes, outcome) = run::<8>(&bytes, config(200, 120), u32::MAX);
        assert!(codes.is_empty());
        assert_eq!(outcome, Err(AcquisitionError::NoTrigger { waited_frames: 120 }));
    }

    #[test]
    fn a_filtered_trigger_starts_the_recording_at_its_first_high_tick() {
        let bytes = numbered(300);
        // five ticks (57 to 61) confirm it; the frames of 57 to 60 were held meanwhile
        let (codes, outcome, waited) = run_filtered::<8, 4>(&bytes, config(200, 1000), |t| t >= 57);
        assert_eq!(outcome, Ok(200));
        assert_eq!(waited, 57);
        assert_eq!(codes, (1057..1257).collect::<std::vec::Vec<u16>>());
    }

    #[test]
    fn a_glitch_shorter_than_the_filter_is_dropped() {
        let bytes = numbered(300);
        // high on ticks 10 to 13 (four, one short) and 20 (one), then from 30 on
        let high = |t: u32| (10..14).contains(&t) || t == 20 || t >= 30;
        let (codes, outcome, waited) = run_filtered::<8, 4>(&bytes, config(100, 1000), high);
        assert_eq!(outcome, Ok(100));
        assert_eq!(waited, 30);
        assert_eq!(codes, (1030..1130).collect::<std::vec::Vec<u16>>());
    }

    #[test]
    fn a_trigger_still_unconfirmed_at_the_timeout_is_no_trigger() {
        let bytes = numbered(300);
        // ticks 117 to 119 are high, but the timeout falls on the 120th tick
        let (codes, outcome, _) = run_filtered::<8, 4>(&bytes, config(100, 120), |t| t >= 117);
        assert!(codes.is_empty());
        assert_eq!(outcome, Err(AcquisitionError::NoTrigger { waited_frames: 120 }));
    }

    #[test]
    fn fewer_frames_than_the_filter_holds_complete_from_the_held_ones() {
        let bytes = numbered(100);
        let (codes, outcome, _) = run_filtered::<8, 4>(&bytes, config(3, 1000), |t| t >= 5);
        assert_eq!(outcome, Ok(3));
        assert_eq!(codes, [1005, 1006, 1007]);
    }

    #[test]
    fn rearm_runs_the_next_acquisition_on_the_same_halves() {
        let bytes = numbered(300);
        let mut sampler = Sampler::<8, 2>::new();
        let (mut producer, mut consumer) = sampler.split(reader(&bytes), config(5, 100), || {});
        // the first acquisition ends with its frames left unread in the queue
        while !producer.tick(true) {}
        assert_eq!(consumer.outcome(), Ok(5));
        assert_eq!(consumer.queued(), 5);
        assert!(producer.rearm(&mut consumer, config(4, 100)));
        assert_eq!(consumer.state(), SamplerState::Armed);
        assert_eq!((consumer.queued(), consumer.frames_read(), consumer.waited_frames()), (0, 0, 0));
        assert_eq!(producer.ticks(), 0);
        // the second one: two low ticks, then the trigger
        let mut level = [false, false, true, true, true, true, true, true, true].into_iter();
        while !producer.tick(level.next().unwrap_or(true)) {}
        let codes: std::vec::Vec<u16> = (0..4).map(|_| consumer.read_frame().unwrap().codes[0]).collect();
        assert_eq!(consumer.read_frame(), Err(AcquisitionError::EndOfData));
        assert_eq!(consumer.outcome(), Ok(4));
        assert_eq!(consumer.waited_frames(), 2);
        // the source went on from where the first acquisition left it (5 frames read)
        assert_eq!(codes, [1007, 1008, 1009, 1010]);
    }

    #[test]
    fn rearm_refuses_the_consumer_of_another_sampler() {
        let bytes = numbered(50);
        let mut one = Sampler::<8>::new();
        let mut other = Sampler::<8>::new();
        let (mut producer, _consumer) = one.split(reader(&bytes), config(5, 100), || {});
        let (_p, mut foreign) = other.split(reader(&bytes), config(5, 100), || {});
        producer.tick(true);
        assert!(!producer.rearm(&mut foreign, config(5, 100)));
        assert_eq!(producer.ticks(), 1);
    }

    #[test]
    fn data_ending_before_the_trigger_records_nothing() {
        let bytes = numbered(50);
        let (codes, outcome) = run::<8>(&bytes, config(20, 1000), 60);
        assert!(codes.is_empty());
        assert_eq!(outcome, Ok(0));
    }

    #[test]
    fn short_source_completes_early() {
        let bytes = numbered(30);
        let (codes, outcome) = run::<8>(&bytes, config(200, 1000), 10);
        assert_eq!(outcome, Ok(20));
        assert_eq!(codes, (1010..1030).collect::<std::vec::Vec<u16>>());
    }

    #[test]
    fn full_queue_is_an_overrun_and_ends_the_acquisition() {
        let bytes = numbered(300);
        let mut sampler = Sampler::<8>::new();
        assert_eq!(sampler.capacity(), 7);
        let (mut producer, mut consumer) = sampler.split(reader(&bytes), config(200, 1000), || {});
        // thread mode does not drain: 7 frames fit, the 8th overruns
        for _ in 0..7 {
            assert!(!producer.tick(true));
        }
        assert_eq!(consumer.queued(), 7);
        assert_eq!(consumer.state(), SamplerState::Recording);
        assert!(producer.tick(true));
        assert_eq!(consumer.outcome(), Err(AcquisitionError::Overrun { frame: 7 }));
        assert_eq!(consumer.read_frame(), Err(AcquisitionError::EndOfData));
        // ended: further ticks read nothing
        let position = producer.source().adc().position();
        assert!(producer.tick(true));
        assert_eq!(producer.source().adc().position(), position);
    }

    #[test]
    fn draining_in_time_never_overruns() {
        let bytes = numbered(300);
        let mut sampler = Sampler::<4>::new();
        let (mut producer, mut consumer) = sampler.split(reader(&bytes), config(250, 1000), || {});
        let mut codes = std::vec::Vec::new();
        // three ticks per drain: the queue (3 frames) is never full
        while !producer.ended() {
            for _ in 0..3 {
                producer.tick(true);
            }
            while consumer.queued() > 0 {
                codes.push(consumer.read_frame().unwrap().codes[0]);
            }
        }
        assert_eq!(consumer.read_frame(), Err(AcquisitionError::EndOfData));
        assert_eq!(consumer.outcome(), Ok(250));
        assert_eq!(codes.len(), 250);
    }

    #[test]
    fn refused_frames_are_queued_as_errors() {
        let mut frames = std::vec![[2048u16, 2048, 2048]; 20];
        frames[3] = [2048, 4095, 2048];
        let mut buf = std::vec![0u8; packed_len(frames.len())];
        pack(&frames, trace::SAMPLE_RATE_HZ, &mut buf).unwrap();
        let mut sampler = Sampler::<32>::new();
        let (mut producer, mut consumer) = sampler.split(reader(&buf), config(10, 100), || {});
        while !producer.tick(true) {}
        let samples: std::vec::Vec<_> = (0..10).map(|_| consumer.read_frame()).collect();
        assert_eq!(samples.iter().filter(|s| s.is_err()).count(), 1);
        assert_eq!(samples[3], Err(AcquisitionError::Saturated { phase: crate::acquisition::Phase::B, code: 4095 }));
        assert_eq!(consumer.read_frame(), Err(AcquisitionError::EndOfData));
        assert_eq!(consumer.outcome(), Ok(10));
    }

    #[test]
    fn a_sampler_is_reusable_after_split() {
        let bytes = numbered(100);
        let mut sampler = Sampler::<8>::new();
        {
            let (mut p, _c) = sampler.split(reader(&bytes), config(5, 100), || {});
            for _ in 0..4 {
                p.tick(true);
            }
        }
        let (mut p, c) = sampler.split(reader(&bytes), config(5, 100), || {});
        assert_eq!(c.state(), SamplerState::Armed);
        assert_eq!(c.queued(), 0);
        while !p.tick(true) {}
        assert_eq!(c.outcome(), Ok(5));
    }

    #[test]
    fn the_rest_frames_before_the_trigger_give_the_zero_points_the_consumer_sees() {
        use crate::acquisition::SensorCheck;
        // 400 frames at rest (zeros +7, −5, +3 counts, a ±1-count dither), then 200 moving ones
        let mut frames: std::vec::Vec<[u16; 3]> =
            (0..400u16).map(|i| [2055 + i % 2, 2043 - i % 2, 2051 + (i / 2) % 2]).collect();
        frames.extend((0..200u16).map(|i| [2055 + 10 * i, 2043 - 10 * i, 2051]));
        let mut bytes = std::vec![0u8; packed_len(frames.len())];
        pack(&frames, trace::SAMPLE_RATE_HZ, &mut bytes).unwrap();
        let adc = ReplayAdc::new(PackedTrace::parse(&bytes).unwrap());
        let source = PhaseCurrentReader::new(
            adc,
            (PhaseA, PhaseB, PhaseC),
            Calibration::NOMINAL,
            AcquisitionConfig::SELF_CALIBRATED,
        )
        .unwrap();
        let mut sampler = Sampler::<8>::new();
        let slot: RefCell<Option<SamplerProducer<'_, ReplayReader<'_>>>> = RefCell::new(None);
        let (producer, mut consumer) = sampler.split(source, config(200, 1000), || {
            if let Some(p) = slot.borrow_mut().as_mut() {
                let t = p.ticks();
                p.tick(t >= 400);
            }
        });
        *slot.borrow_mut() = Some(producer);
        let before = consumer.sensor_check();
        assert_eq!((before.source, before.rest_frames), (SensorCheck::DECLARED.source, 0));
        let first = consumer.read_frame().unwrap();
        // the first recorded frame reads zero current on every phase: its codes are the zeros
        assert!(first.currents_a().iter().all(|i| i.abs() < 0.01), "{first:?}");
        while consumer.read_frame().is_ok() {}
        assert_eq!(consumer.outcome(), Ok(200));
        let seen = consumer.sensor_check();
        let producer = slot.borrow_mut().take().unwrap();
        let own = producer.source().sensor_check();
        assert_eq!(seen.zero_shift_counts, own.zero_shift_counts);
        assert_eq!((seen.source, seen.rest_frames, seen.fault), (own.source, 400, None));
        for (got, want) in seen.zero_shift_counts.iter().zip([7.5f32, -5.5, 3.5]) {
            assert!((got - want).abs() < 0.01, "{seen:?}");
        }
    }

    #[test]
    fn every_sensor_check_crosses_the_shared_words_unchanged() {
        use crate::acquisition::{SensorCheck, SensorFault, ZeroSource};
        let base = SensorCheck {
            source: ZeroSource::Rest,
            zero_shift_counts: [1.5, -2.25, 0.125],
            rest_sd_counts: [2.0, 1.75, 3.5],
            rest_frames: 777,
            ..SensorCheck::DECLARED
        };
        let faults = [
            None,
            Some(SensorFault::TooFewRestFrames { frames: 12, needed: 256 }),
            Some(SensorFault::NotAtRest { phase: Phase::C, sd_counts: 31.5 }),
            Some(SensorFault::ZeroBeyondRange { phase: Phase::B, shift_counts: -1000.5 }),
            Some(SensorFault::GainMismatch { phase: Phase::A, mismatch: 0.0625 }),
        ];
        for fault in faults {
            let check = SensorCheck { fault, ..base };
            let back = decode_check(&encode_check(&check));
            assert_eq!(back.fault, check.fault);
            assert_eq!(
                (back.source, back.zero_shift_counts, back.rest_frames),
                (check.source, check.zero_shift_counts, 777)
            );
            assert_eq!(back.rest_sd_counts, check.rest_sd_counts);
        }
        let declared = decode_check(&encode_check(&SensorCheck::DECLARED));
        assert_eq!((declared.source, declared.fault), (ZeroSource::Declared, None));
    }

    #[test]
    fn a_glitch_keeps_the_rest_frames_and_a_rearm_starts_them_afresh() {
        // rest codes at zeros +7, −5, +3 (a dither), then a ramp; the trigger glitches high on
        // ticks 300–301 and rises for good at tick 400; the filter confirms it over 5 more ticks
        let mut frames: std::vec::Vec<[u16; 3]> =
            (0..400u16).map(|i| [2055 + i % 2, 2043 - i % 2, 2051 + (i / 2) % 2]).collect();
        frames.extend((0..300u16).map(|i| [2055 + 5 * i, 2043 - 5 * i, 2051]));
        let mut bytes = std::vec![0u8; packed_len(frames.len())];
        pack(&frames, trace::SAMPLE_RATE_HZ, &mut bytes).unwrap();
        let source = PhaseCurrentReader::new(
            ReplayAdc::new(PackedTrace::parse(&bytes).unwrap()),
            (PhaseA, PhaseB, PhaseC),
            Calibration::NOMINAL,
            AcquisitionConfig::SELF_CALIBRATED,
        )
        .unwrap();
        let mut sampler = Sampler::<512, 5>::new();
        let (mut producer, mut consumer) = sampler.split(source, config(100, 1000), || {});
        for t in 0..520u32 {
            producer.tick((300..302).contains(&t) || t >= 400);
        }
        assert_eq!(consumer.outcome(), Ok(100));
        let first = consumer.read_frame().unwrap();
        assert!(first.currents_a().iter().all(|i| i.abs() < 0.01), "the first frame is tick 400's: {first:?}");
        let check = consumer.sensor_check();
        assert_eq!((check.rest_frames, check.fault), (398, None), "{check:?}");
        // the next flight on the same source: only 50 rest frames of its own
        assert!(producer.rearm(&mut consumer, config(100, 1000)));
        for t in 0..200u32 {
            producer.tick(t >= 50);
        }
        let again = consumer.sensor_check();
        assert!(matches!(again.fault, Some(SensorFault::TooFewRestFrames { frames: 50, .. })), "{again:?}");
    }
}
