//! The sampler's tests: recording, trigger and its filter, overrun, re-arming, and the sensors'
//! zero points handed to thread mode.
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
    PhaseCurrentReader::new(adc, (PhaseA, PhaseB, PhaseC), Calibration::NOMINAL, AcquisitionConfig::DEFAULT).unwrap()
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
