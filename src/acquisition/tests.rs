//! Host tests of the acquisition stage: conversions, each check, the replay driver.

use super::*;
use crate::trace::{self, pack, packed_len, synthetic, PackedTrace, ADC_MAX, ADC_MIDSCALE, AMPS_PER_COUNT};

fn packed(frames: &[[u16; 3]]) -> std::vec::Vec<u8> {
    let mut buf = std::vec![0u8; packed_len(frames.len())];
    pack(frames, trace::SAMPLE_RATE_HZ, &mut buf).unwrap();
    buf
}

fn reader(bytes: &[u8]) -> ReplayReader<'_> {
    let adc = ReplayAdc::new(PackedTrace::parse(bytes).unwrap());
    PhaseCurrentReader::new(adc, (PhaseA, PhaseB, PhaseC), Calibration::NOMINAL, AcquisitionConfig::DEFAULT).unwrap()
}

/// Reads until end of data; returns (frame index, error) of every refused frame and the frame count.
fn errors_until_end(r: &mut ReplayReader<'_>) -> (std::vec::Vec<(usize, AcquisitionError)>, usize) {
    let mut errors = std::vec::Vec::new();
    let mut n = 0;
    loop {
        match r.read_frame() {
            Ok(_) => {}
            Err(AcquisitionError::EndOfData) => break,
            Err(e) => errors.push((n, e)),
        }
        n += 1;
    }
    (errors, n)
}

/// A driver whose every conversion is decided by a closure (marker type `Fake`, not the driver).
struct Fake;
struct FakeAdc<F>(F);
impl<F, E, P> OneShot<Fake, u16, P> for FakeAdc<F>
where
    F: FnMut(Phase) -> nb::Result<u16, E>,
    P: PhasePin + Channel<Fake>,
{
    type Error = E;
    fn read(&mut self, _pin: &mut P) -> nb::Result<u16, E> {
        (self.0)(P::PHASE)
    }
}

#[derive(Debug)]
struct Overrun;
impl AdcError for Overrun {
    fn kind(&self) -> AdcErrorKind {
        AdcErrorKind::Overrun
    }
}

fn fake_reader<F, E>(f: F, config: AcquisitionConfig) -> PhaseCurrentReader<FakeAdc<F>, PhaseA, PhaseB, PhaseC, Fake>
where
    F: FnMut(Phase) -> nb::Result<u16, E>,
    E: AdcError,
{
    PhaseCurrentReader::new(FakeAdc(f), (PhaseA, PhaseB, PhaseC), Calibration::NOMINAL, config).unwrap()
}

#[test]
fn channel_numbers() {
    assert_eq!(<PhaseA as Channel<Fake>>::channel(), 0);
    assert_eq!(<PhaseB as Channel<Fake>>::channel(), 1);
    assert_eq!(<PhaseC as Channel<ReplayAdc<'_>>>::channel(), 2);
}

#[test]
fn analytic_conversion_through_the_reader() {
    let bytes = packed(&[[2048, 2148, 1948], [2048 + 1024, 2048 - 512, 2048 - 512]]);
    let mut r = reader(&bytes);
    let f = r.read_frame().unwrap();
    assert_eq!(f.codes, [2048, 2148, 1948]);
    assert_eq!(f.currents_a(), [0.0, 100.0 * AMPS_PER_COUNT, -100.0 * AMPS_PER_COUNT]);
    assert_eq!(f.ib_a, 0.9765625);
    let f = r.read_frame().unwrap();
    assert_eq!(f.currents_a(), [10.0, -5.0, -5.0]);
    assert_eq!(r.read_frame(), Err(AcquisitionError::EndOfData));
    assert_eq!(r.read_frame(), Err(AcquisitionError::EndOfData));
    assert_eq!(r.frames_read(), 2);
}

#[test]
fn per_phase_calibration_is_applied() {
    let cal = Calibration::new(
        PhaseCalibration::from_f32(2000.0, 0.01).unwrap(),
        PhaseCalibration::from_f32(2100.0, 0.02).unwrap(),
        PhaseCalibration::NOMINAL,
    );
    let bytes = packed(&[[2100, 2050, 2048]]);
    let adc = ReplayAdc::new(PackedTrace::parse(&bytes).unwrap());
    let mut r = PhaseCurrentReader::new(adc, (PhaseA, PhaseB, PhaseC), cal, AcquisitionConfig::DEFAULT).unwrap();
    let f = r.read_frame().unwrap();
    assert!((f.ia_a - 1.0).abs() < 1e-6, "{}", f.ia_a);
    assert!((f.ib_a + 1.0).abs() < 1e-6, "{}", f.ib_a);
    assert_eq!(f.ic_a, 0.0);
}

#[test]
fn saturation_names_the_phase() {
    let bytes = packed(&[[2048; 3], [0, 2048, 4095], [2048, 4095, 2048], [2048, 2048, 0], [2048; 3]]);
    let mut r = reader(&bytes);
    assert!(r.read_frame().is_ok());
    assert_eq!(r.read_frame(), Err(AcquisitionError::Saturated { phase: Phase::A, code: 0 }));
    assert_eq!(r.read_frame(), Err(AcquisitionError::Saturated { phase: Phase::B, code: 4095 }));
    assert_eq!(r.read_frame(), Err(AcquisitionError::Saturated { phase: Phase::C, code: 0 }));
    assert!(r.read_frame().is_ok());
}

#[test]
fn out_of_range_code_is_refused() {
    let mut r =
        fake_reader(|p| Ok::<u16, nb::Error<()>>(if p == Phase::B { 5000 } else { 2048 }), AcquisitionConfig::DEFAULT);
    assert_eq!(r.read_frame(), Err(AcquisitionError::OutOfRange { phase: Phase::B, code: 5000 }));
}

#[test]
fn quiet_standstill_is_not_stuck() {
    // motor at rest, noiseless: every code constant for 1 s
    let bytes = packed(&std::vec![[ADC_MIDSCALE; 3]; 10_000]);
    let (errors, n) = errors_until_end(&mut reader(&bytes));
    assert_eq!((errors.len(), n), (0, 10_000));
    // holding torque at standstill, noiseless: A and B constant at ±3 A, C off
    let hold = [trace::amps_to_counts(3.0), trace::amps_to_counts(-3.0), ADC_MIDSCALE];
    let bytes = packed(&std::vec![hold; 10_000]);
    let (errors, _) = errors_until_end(&mut reader(&bytes));
    assert!(errors.is_empty(), "{errors:?}");
}

#[test]
fn slow_six_step_with_long_off_sectors_is_clean() {
    // the placeholder: rest, hold (C off for 300 frames), six-step from 5 Hz (333-frame sectors)
    let bytes = packed(&synthetic::placeholder_frames());
    let (errors, n) = errors_until_end(&mut reader(&bytes));
    assert_eq!(n, 2400);
    assert!(errors.is_empty(), "{errors:?}");
}

#[test]
fn stuck_channel_is_flagged_after_the_run_length() {
    let mut frames = synthetic::placeholder_frames();
    // phase B freezes at +4.4 A from frame 1000 on, while A and C keep commutating
    let frozen = 2500;
    for f in &mut frames[1000..] {
        f[1] = frozen;
    }
    let (errors, _) = errors_until_end(&mut reader(&packed(&frames)));
    let first_stuck = errors.iter().find(|(_, e)| matches!(e, AcquisitionError::Stuck { .. }));
    // the run starts at frame 1000 (or earlier if B already read 2500 there): flagged after ≥ 200 frames
    let (at, e) = first_stuck.expect("stuck flagged");
    assert_eq!(*e, AcquisitionError::Stuck { phase: Phase::B, code: frozen });
    assert!((1199..1210).contains(at), "first stuck at {at}");
    assert!(errors.iter().all(|(_, e)| e.phase() != Some(Phase::A) && e.phase() != Some(Phase::C)));
    // before the stuck rule fires, the sum rule already complains
    assert!(matches!(errors[0].1, AcquisitionError::InconsistentSum { .. }));
    assert!(errors[0].0 < 1100);
}

#[test]
fn stuck_rule_needs_moving_neighbours_and_a_non_zero_code() {
    // B frozen at a non-zero code, but A and C quiet: not stuck (cannot tell from a motor at rest)
    let cfg = AcquisitionConfig::DEFAULT;
    let mut r = fake_reader(
        |p| {
            Ok::<u16, nb::Error<()>>(if p == Phase::B {
                2300
            } else if p == Phase::A {
                1900
            } else {
                1944
            })
        },
        cfg,
    );
    for _ in 0..1000 {
        assert!(r.read_frame().is_ok());
    }
    // B frozen at zero current while A and C swing: not stuck (an off phase looks the same)
    let mut k = 0u32;
    let mut r = fake_reader(
        move |p| {
            k += 1;
            let swing = ((k / 3) % 200) as u16;
            Ok::<u16, nb::Error<()>>(match p {
                Phase::A => 2048 + swing,
                Phase::B => 2048,
                Phase::C => 2048 - swing,
            })
        },
        cfg,
    );
    for _ in 0..1000 {
        assert_eq!(r.read_frame().map(|_| ()), Ok(()));
    }
}

#[test]
fn inconsistent_sum_after_n_frames_and_reset() {
    let bad = [2148u16; 3]; // +0.977 A each: sum 2.93 A
    let good = [2148u16, 1948, 2048];
    let mut frames = std::vec![bad; 6];
    frames.push(good);
    frames.extend([bad; 5]);
    let bytes = packed(&frames);
    let mut r = reader(&bytes);
    for _ in 0..4 {
        assert!(r.read_frame().is_ok());
    }
    assert_eq!(r.read_frame(), Err(AcquisitionError::InconsistentSum { sum_ma: 2930 }));
    assert_eq!(r.read_frame(), Err(AcquisitionError::InconsistentSum { sum_ma: 2930 }));
    assert!(r.read_frame().is_ok()); // the good frame resets the count
    for _ in 0..4 {
        assert!(r.read_frame().is_ok());
    }
    assert!(matches!(r.read_frame(), Err(AcquisitionError::InconsistentSum { .. })));
}

#[test]
fn small_sum_errors_are_tolerated() {
    // 0.29 A off in every frame: within the 0.3 A tolerance
    let f = [ADC_MIDSCALE + 30, ADC_MIDSCALE, ADC_MIDSCALE];
    let (errors, _) = errors_until_end(&mut reader(&packed(&std::vec![f; 100])));
    assert!(errors.is_empty());
}

#[test]
fn would_block_forever_times_out() {
    let mut polls = 0u32;
    let mut cfg = AcquisitionConfig::DEFAULT;
    cfg.max_polls = 7;
    let mut r = fake_reader(
        |_| {
            polls += 1;
            Err::<u16, _>(nb::Error::<()>::WouldBlock)
        },
        cfg,
    );
    assert_eq!(r.read_frame(), Err(AcquisitionError::Timeout { phase: Phase::A }));
    drop(r);
    assert_eq!(polls, 7);
}

#[test]
fn driver_errors_are_classified() {
    let mut r =
        fake_reader(|p| if p == Phase::C { Err(nb::Error::Other(())) } else { Ok(2048) }, AcquisitionConfig::DEFAULT);
    assert_eq!(r.read_frame(), Err(AcquisitionError::Adc { phase: Phase::C }));
    let mut r = fake_reader(
        |p| if p == Phase::B { Err(nb::Error::Other(Overrun)) } else { Ok(2048) },
        AcquisitionConfig::DEFAULT,
    );
    assert_eq!(r.read_frame(), Err(AcquisitionError::Missing { phase: Phase::B }));
    let mut r = fake_reader(|_| Ok::<u16, nb::Error<Infallible>>(2048), AcquisitionConfig::DEFAULT);
    assert!(r.read_frame().is_ok());
}

#[test]
fn busy_replay_within_and_beyond_the_poll_budget() {
    let bytes = packed(&[[2048; 3], [2048; 3]]);
    let trace = PackedTrace::parse(&bytes).unwrap();
    let mut cfg = AcquisitionConfig::DEFAULT;
    cfg.max_polls = 4;
    let adc = ReplayAdc::new(trace).with_busy_polls(3);
    let mut r = PhaseCurrentReader::new(adc, (PhaseA, PhaseB, PhaseC), Calibration::NOMINAL, cfg).unwrap();
    assert!(r.read_frame().is_ok());
    assert!(r.read_frame().is_ok());
    assert_eq!(r.read_frame(), Err(AcquisitionError::EndOfData));
    let adc = ReplayAdc::new(trace).with_busy_polls(4);
    let mut r = PhaseCurrentReader::new(adc, (PhaseA, PhaseB, PhaseC), Calibration::NOMINAL, cfg).unwrap();
    assert_eq!(r.read_frame(), Err(AcquisitionError::Timeout { phase: Phase::A }));
}

#[test]
fn replay_through_one_shot_reproduces_the_codes() {
    let frames = synthetic::placeholder_frames();
    let bytes = packed(&frames);
    let trace = PackedTrace::parse(&bytes).unwrap();
    let mut adc = ReplayAdc::new(trace);
    let (mut a, mut b, mut c) = (PhaseA, PhaseB, PhaseC);
    for (i, f) in frames.iter().enumerate() {
        assert_eq!(adc.position(), i);
        // any order; a repeated channel before the frame completes gives the same code
        let got = match i % 3 {
            0 => [adc.read(&mut a), adc.read(&mut b), adc.read(&mut c)],
            1 => {
                let cc = adc.read(&mut c);
                let aa = adc.read(&mut a);
                assert_eq!(adc.read(&mut a), aa);
                [aa, adc.read(&mut b), cc]
            }
            _ => {
                let bb = adc.read(&mut b);
                [adc.read(&mut a), bb, adc.read(&mut c)]
            }
        };
        assert_eq!(got, [Ok(f[0]), Ok(f[1]), Ok(f[2])], "frame {i}");
    }
    assert_eq!(adc.remaining(), 0);
    assert_eq!(OneShot::<_, u16, PhaseB>::read(&mut adc, &mut b), Err(nb::Error::Other(ReplayError::EndOfTrace)));
    adc.rewind();
    assert_eq!(adc.read(&mut a), Ok(frames[0][0]));
}

#[test]
fn config_is_validated() {
    let bytes = packed(&[[2048; 3]]);
    let trace = PackedTrace::parse(&bytes).unwrap();
    let try_cfg = |f: fn(&mut AcquisitionConfig)| {
        let mut cfg = AcquisitionConfig::DEFAULT;
        f(&mut cfg);
        PhaseCurrentReader::new(ReplayAdc::new(trace), (PhaseA, PhaseB, PhaseC), Calibration::NOMINAL, cfg).err()
    };
    assert_eq!(try_cfg(|_| {}), None);
    assert_eq!(try_cfg(|c| c.max_polls = 0), Some(ConfigError::MaxPolls));
    assert_eq!(try_cfg(|c| c.stuck_min_frames = 1), Some(ConfigError::StuckRule));
    assert_eq!(try_cfg(|c| c.stuck_activity_counts = 0), Some(ConfigError::StuckRule));
    assert_eq!(try_cfg(|c| c.sum_tolerance_a = f32::NAN), Some(ConfigError::SumRule));
    assert_eq!(try_cfg(|c| c.sum_tolerance_a = 0.0), Some(ConfigError::SumRule));
    assert_eq!(try_cfg(|c| c.sum_frames = 0), Some(ConfigError::SumRule));
    assert_eq!(try_cfg(|c| c.sum_tolerance_share = -0.1), Some(ConfigError::SumRule));
    assert_eq!(try_cfg(|c| c.phase_skew_us = [0.0, f32::NAN, 0.0]), Some(ConfigError::SumRule));
    assert_eq!(try_cfg(|c| c.max_current_slope_a_per_us = f32::INFINITY), Some(ConfigError::SumRule));
    assert_eq!(
        try_cfg(|c| c.self_calibration =
            Some(SelfCalibrationConfig { min_rest_frames: 0, ..SelfCalibrationConfig::DEFAULT })),
        Some(ConfigError::SelfCalibration)
    );
}

#[test]
fn sequential_sampling_widens_the_sum_rule_by_the_skew_it_declares() {
    // one ADC converting A, B, C 5 µs apart while the pair's current ripples at its 0.0675 A/µs:
    // phase C is read 10 µs after A, so the frame sums to 10 µs · 0.0675 A/µs = 0.675 A
    let ramp = |k: u16| {
        let i = 0.015 * f32::from(k) - 3.0; // the pair current at the frame's instant
                                            // the pair A–C conducts; phase C is sampled 10 µs later, the pair's current 0.675 A on
        [i, 0.0, -(i + 0.675)]
    };
    let run = |skew: [f32; 3]| {
        let config = AcquisitionConfig { phase_skew_us: skew, ..AcquisitionConfig::DEFAULT };
        let mut check = FrameCheck::new(Calibration::NOMINAL, config).unwrap();
        (0..400u16).filter(|&k| check.amps(ramp(k)).is_err()).count()
    };
    assert!(run([0.0; 3]) > 300, "simultaneous sampling declared: the skewed frames are refused");
    assert_eq!(run([0.0, 5.0, 10.0]), 0, "the declared skew accounts for them");
    let c = AcquisitionConfig { phase_skew_us: [0.0, 5.0, 10.0], ..AcquisitionConfig::DEFAULT };
    assert!((c.sum_tolerance_at(0.0) - (0.3 + 0.675)).abs() < 1e-6);
}

#[test]
fn errors_display_and_name_their_phase() {
    use std::string::ToString;
    let all = [
        AcquisitionError::Saturated { phase: Phase::A, code: 0 },
        AcquisitionError::OutOfRange { phase: Phase::B, code: 5000 },
        AcquisitionError::Stuck { phase: Phase::C, code: 2500 },
        AcquisitionError::InconsistentSum { sum_ma: 2930 },
        AcquisitionError::Timeout { phase: Phase::A },
        AcquisitionError::Missing { phase: Phase::B },
        AcquisitionError::Adc { phase: Phase::C },
        AcquisitionError::EndOfData,
    ];
    for e in all {
        let s = e.to_string();
        assert!(!s.is_empty());
        if let Some(p) = e.phase() {
            assert!(s.contains(&std::format!("phase {p}")), "{s}");
        }
    }
    assert!(AcquisitionError::InconsistentSum { sum_ma: 2930 }.to_string().contains("2930 mA"));
    let _: &dyn core::error::Error = &ConfigError::Gain;
    let _: &dyn core::error::Error = &ReplayError::EndOfTrace;
}

#[test]
fn frame_check_in_amperes_runs_the_reader_checks() {
    let mut check = FrameCheck::new(Calibration::NOMINAL, AcquisitionConfig::DEFAULT).unwrap();
    let good = check.amps([1.5, -1.5, 0.0]).unwrap();
    assert_eq!(good.currents_a(), [1.5, -1.5, 0.0]);
    assert_eq!(good.codes[2], ADC_MIDSCALE);
    assert!(matches!(check.amps([25.0, -1.5, 0.0]), Err(AcquisitionError::Saturated { phase: Phase::A, .. })));
    assert!(matches!(check.amps([f32::NAN, 0.0, 0.0]), Err(AcquisitionError::OutOfRange { phase: Phase::A, .. })));
    // phase A shifted by −5 A: the sum rule refuses from the fifth frame on
    let results: std::vec::Vec<_> = (0..8).map(|_| check.amps([-5.0 + 1.0, -1.0, 0.0])).collect();
    assert!(results[..4].iter().all(Result::is_ok));
    assert!(results[4..].iter().all(|r| matches!(r, Err(AcquisitionError::InconsistentSum { sum_ma: -5000 }))));
}

#[test]
fn acquire_masks_and_counts_refused_frames() {
    use crate::conditioning::ConditionedWindow;
    let frames: std::vec::Vec<[u16; 3]> = (0..400u16)
        .map(|i| {
            let d = (i % 50) * 4 + 100;
            if i == 123 {
                [ADC_MAX, ADC_MIDSCALE - d, ADC_MIDSCALE]
            } else {
                [ADC_MIDSCALE + d, ADC_MIDSCALE - d, ADC_MIDSCALE]
            }
        })
        .collect();
    let bytes = packed(&frames);
    let mut r = reader(&bytes);
    let mut trace = ConditionedWindow::<128>::new();
    let summary = crate::diagnosis::acquire(&mut r, &mut trace).unwrap();
    assert_eq!((summary.frames, summary.refused, summary.longest_refused_run), (400, 1, 1));
    assert!(!summary.is_sensor_fault());
    assert_eq!(trace.len(), 100);
    // block 30 is frames 120..=123, of 180, 184, 188 counts; frame 123 (the glitch) holds frame 122
    let expected = AMPS_PER_COUNT * (180.0 + 184.0 + 2.0 * 188.0) / 4.0;
    let y30 = trace.current_a().nth(30).unwrap();
    assert!((y30 - expected).abs() < 1e-5, "{y30} vs {expected}");
}

#[test]
fn frame_limit_ends_a_live_source_on_the_manoeuvre_frame_count() {
    use crate::conditioning::ConditionedWindow;
    use crate::{EmaParams, Profile};
    assert_eq!(manoeuvre_frames(&Profile::STANDARD, &EmaParams::NOMINAL), 8500);
    // a source that never ends (a live ADC), counting its reads
    let mut reads = 0u32;
    let live = fake_reader(
        |p| {
            reads += 1;
            let d = (reads / 3 % 50) as u16 * 4 + 100;
            Ok::<_, nb::Error<Infallible>>(match p {
                Phase::A => ADC_MIDSCALE + d,
                Phase::B => ADC_MIDSCALE - d,
                Phase::C => ADC_MIDSCALE,
            })
        },
        AcquisitionConfig::DEFAULT,
    );
    let mut limited = FrameLimit::new(live, 400);
    let mut trace = ConditionedWindow::<128>::new();
    let summary = crate::diagnosis::acquire(&mut limited, &mut trace).unwrap();
    assert_eq!((summary.frames, summary.refused), (400, 0));
    assert_eq!((trace.len(), limited.remaining(), limited.source().frames_read()), (100, 0, 400));
    // past the count: end of data again, and the source is not read
    assert_eq!(limited.read_frame(), Err(AcquisitionError::EndOfData));
    assert_eq!(limited.release().frames_read(), 400);
    assert_eq!(reads, 1200);
}

#[test]
fn frame_limit_of_zero_or_a_bad_ratio_reads_nothing() {
    use crate::{EmaParams, Profile};
    let params = EmaParams { control_period_s: f32::NAN, ..EmaParams::NOMINAL };
    assert_eq!(manoeuvre_frames(&Profile::STANDARD, &params), 0);
    let bytes = packed(&[[ADC_MIDSCALE + 10, ADC_MIDSCALE - 10, ADC_MIDSCALE]; 4]);
    let mut limited = FrameLimit::new(reader(&bytes), 0);
    assert_eq!(limited.read_frame(), Err(AcquisitionError::EndOfData));
    assert_eq!(limited.source().frames_read(), 0);
}

#[test]
fn each_recording_measures_its_zero_points_on_its_own_rest_frames() {
    let mut check = FrameCheck::new(Calibration::NOMINAL, AcquisitionConfig::SELF_CALIBRATED).unwrap();
    for k in 0..600u16 {
        check.rest([2060 + k % 2, 2048, 2040]);
    }
    check.start_recording();
    let first = check.sensor_check();
    assert_eq!((first.rest_frames, first.fault), (600, None));
    assert!((first.zero_shift_counts[0] - 12.5).abs() < 0.01);
    // the next acquisition: too few rest frames of its own, whatever came before
    check.rearm();
    for _ in 0..100 {
        check.rest([2070, 2048, 2040]);
    }
    check.start_recording();
    assert!(matches!(
        check.sensor_check().fault,
        Some(crate::acquisition::SensorFault::TooFewRestFrames { frames: 100, .. })
    ));
}
