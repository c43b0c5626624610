//! Host tests of the packed trace: layout, lengths, round trips, corrupted headers, lengths and
//! bytes, the built-in trace.

use super::*;

fn packed(frames: &[[u16; 3]], rate: u32) -> std::vec::Vec<u8> {
    let mut buf = std::vec![0u8; packed_len(frames.len())];
    let n = pack(frames, rate, &mut buf).expect("packs");
    assert_eq!(n, buf.len());
    buf
}

#[test]
fn nominal_conversions_are_inverse() {
    assert_eq!(amps_to_counts(0.0), ADC_MIDSCALE);
    assert_eq!(counts_to_amps(ADC_MIDSCALE), 0.0);
    assert_eq!(amps_to_counts(100.0), ADC_MAX);
    assert_eq!(amps_to_counts(-100.0), 0);
    assert_eq!(amps_to_counts(f32::NAN), 0);
    for c in [0u16, 1, 1000, 2047, 2048, 2049, 4000, ADC_MAX] {
        assert_eq!(amps_to_counts(counts_to_amps(c)), c);
    }
}

#[test]
fn known_byte_layout() {
    let buf = packed(&[[0x123, 0x456, 0x789]], 10_000);
    assert_eq!(&buf[..4], b"EMA1");
    assert_eq!(&buf[4..8], &1u32.to_le_bytes());
    assert_eq!(&buf[8..12], &10_000u32.to_le_bytes());
    assert_eq!(&buf[12..], &[0x23, 0x61, 0x45, 0x89, 0x07, 0x00]);
}

#[test]
fn packed_lengths() {
    assert_eq!(packed_len(0), 12);
    assert_eq!(packed_len(1), 12 + 6); // 3 codes: 2 pairs, one padded
    assert_eq!(packed_len(2), 12 + 9); // 6 codes: 3 pairs
    assert_eq!(packed_len(3), 12 + 15);
    assert_eq!(packed_len(usize::MAX), usize::MAX);
    assert_eq!(packed_len(usize::MAX / 3), usize::MAX);
}

#[test]
fn round_trip_even_and_odd_counts() {
    for n in [0usize, 1, 2, 3, 4, 5, 17, 100] {
        let frames: std::vec::Vec<[u16; 3]> = (0..n)
            .map(|i| {
                let i = i as u32;
                [(i * 37 % 4096) as u16, (4095 - i * 11 % 4096) as u16, ((i * 1_234_567) % 4096) as u16]
            })
            .collect();
        let buf = packed(&frames, 12_345);
        let t = PackedTrace::parse(&buf).expect("parses");
        assert_eq!(t.frames(), n);
        assert_eq!(t.is_empty(), n == 0);
        assert_eq!(t.sample_rate_hz(), 12_345);
        for (i, f) in frames.iter().enumerate() {
            assert_eq!(t.frame(i), Some(*f), "frame {i} of {n}");
        }
        assert_eq!(t.frame(n), None);
        assert_eq!(t.frame(usize::MAX), None);
        assert!(t.iter().eq(frames.iter().copied()));
    }
}

#[test]
fn extreme_codes_round_trip() {
    let frames = [[0, ADC_MAX, 0], [ADC_MAX, 0, ADC_MAX], [ADC_MIDSCALE; 3]];
    let buf = packed(&frames, 1);
    let t = PackedTrace::parse(&buf).unwrap();
    assert!(t.iter().eq(frames.iter().copied()));
}

#[test]
fn corrupt_headers_and_lengths_are_errors() {
    let good = packed(&[[1, 2, 3], [4, 5, 6], [7, 8, 9]], 10_000);
    assert!(PackedTrace::parse(&good).is_ok());
    assert_eq!(PackedTrace::parse(&[]), Err(TraceError::TruncatedHeader));
    assert_eq!(PackedTrace::parse(&good[..11]), Err(TraceError::TruncatedHeader));
    let mut bad = good.clone();
    bad[0] = b'X';
    assert_eq!(PackedTrace::parse(&bad), Err(TraceError::BadMagic));
    let mut bad = good.clone();
    bad[8..12].copy_from_slice(&0u32.to_le_bytes());
    assert_eq!(PackedTrace::parse(&bad), Err(TraceError::SampleRate));
    assert_eq!(PackedTrace::parse(&good[..good.len() - 1]), Err(TraceError::Length));
    let mut long = good.clone();
    long.push(0);
    assert_eq!(PackedTrace::parse(&long), Err(TraceError::Length));
    let mut bad = good.clone();
    bad[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(PackedTrace::parse(&bad).is_err());
    let mut bad = good.clone();
    bad[4..8].copy_from_slice(&4u32.to_le_bytes());
    assert_eq!(PackedTrace::parse(&bad), Err(TraceError::Length));
    // 3 frames = 9 codes: the last pair is padded; a non-zero pad is corruption
    let mut bad = good.clone();
    *bad.last_mut().unwrap() = 1;
    assert_eq!(PackedTrace::parse(&bad), Err(TraceError::Padding));
    let mut bad = good.clone();
    let n = bad.len();
    bad[n - 2] |= 0x10;
    assert_eq!(PackedTrace::parse(&bad), Err(TraceError::Padding));
}

#[test]
fn every_truncation_and_byte_flip_is_handled_without_panic() {
    let good = packed(&synthetic::placeholder_frames()[..50], 10_000);
    for n in 0..good.len() {
        assert!(PackedTrace::parse(&good[..n]).is_err(), "truncated to {n}");
    }
    for at in 0..good.len() {
        for flip in [0x01u8, 0x10, 0x80, 0xFF] {
            let mut b = good.clone();
            b[at] ^= flip;
            if let Ok(t) = PackedTrace::parse(&b) {
                // a body flip still decodes: every frame decodes and stays 12-bit
                assert!(t.iter().count() == t.frames());
                assert!(t.iter().all(|f| f.iter().all(|&c| c <= ADC_MAX)));
            }
        }
    }
}

#[test]
fn pack_rejects_bad_input() {
    let mut buf = [0u8; 64];
    assert_eq!(pack(&[[0, 4096, 0]], 10, &mut buf), Err(TraceError::CodeRange));
    assert_eq!(pack(&[[0, 0, u16::MAX]], 10, &mut buf), Err(TraceError::CodeRange));
    assert_eq!(pack(&[[0; 3]], 0, &mut buf), Err(TraceError::SampleRate));
    assert_eq!(pack(&[[0; 3]; 2], 10, &mut buf[..20]), Err(TraceError::OutputTooSmall));
    assert_eq!(pack(&[[0; 3]; 2], 10, &mut buf[..21]), Ok(21));
    assert_eq!(pack(&[], 10, &mut buf[..11]), Err(TraceError::OutputTooSmall));
    assert_eq!(pack(&[], 10, &mut buf), Ok(12));
    assert_eq!(PackedTrace::parse(&buf[..12]).map(|t| t.frames()), Ok(0));
}

fn packed_triggered(frames: &[[u16; 3]], header: TraceHeader) -> std::vec::Vec<u8> {
    let mut buf = std::vec![0u8; header.packed_len(frames.len())];
    let n = pack(frames, header, &mut buf).expect("packs");
    assert_eq!(n, buf.len());
    buf
}

#[test]
fn triggered_byte_layout() {
    let buf = packed_triggered(&[[0x123, 0x456, 0x789], [1, 2, 3]], TraceHeader::new(10_000, 1));
    assert_eq!(&buf[..4], b"EMA2");
    assert_eq!(&buf[4..8], &2u32.to_le_bytes());
    assert_eq!(&buf[8..12], &10_000u32.to_le_bytes());
    assert_eq!(&buf[12..16], &1u32.to_le_bytes());
    assert_eq!(&buf[16..22], &[0x23, 0x61, 0x45, 0x89, 0x17, 0x00]);
    assert_eq!(buf.len(), packed_len(2) + 4);
    // a trigger frame of 0 is the EMA1 trace, byte for byte
    let frames = [[7, 8, 9], [10, 11, 12], [13, 14, 15]];
    assert_eq!(packed_triggered(&frames, TraceHeader::new(10_000, 0)), packed(&frames, 10_000));
    assert_eq!(TraceHeader::from(10_000), TraceHeader::new(10_000, 0));
    assert_eq!((TraceHeader::new(1, 0).header_len(), TraceHeader::new(1, 5).header_len()), (12, 16));
    assert_eq!(TraceHeader::new(1, 5).packed_len(usize::MAX), usize::MAX);
}

#[test]
fn triggered_round_trip_and_ema1_compatibility() {
    let frames: std::vec::Vec<[u16; 3]> = (0..37u16).map(|i| [2048 + i, 2048 - i, (i * 97) % 4096]).collect();
    for trigger in [1u32, 2, 17, 36, 37] {
        let buf = packed_triggered(&frames, TraceHeader::new(10_000, trigger));
        let t = PackedTrace::parse(&buf).expect("parses");
        assert_eq!((t.frames(), t.sample_rate_hz(), t.trigger_frame()), (37, 10_000, trigger));
        assert_eq!(t.header(), TraceHeader::new(10_000, trigger));
        assert!(t.iter().eq(frames.iter().copied()), "trigger {trigger}");
    }
    // EMA1: trigger frame 0
    let t = PackedTrace::parse(include_bytes!("../../traces/standard.ematrace")).expect("EMA1 parses");
    assert_eq!((t.trigger_frame(), t.header()), (0, TraceHeader::new(SAMPLE_RATE_HZ, 0)));
    let buf = packed(&frames, 10_000);
    assert_eq!(PackedTrace::parse(&buf).map(|t| t.trigger_frame()), Ok(0));
}

#[test]
fn corrupt_triggered_headers_are_errors() {
    let frames = [[1, 2, 3], [4, 5, 6], [7, 8, 9]];
    let good = packed_triggered(&frames, TraceHeader::new(10_000, 2));
    for n in 12..16 {
        assert_eq!(PackedTrace::parse(&good[..n]), Err(TraceError::TruncatedHeader), "{n} bytes");
    }
    let mut bad = good.clone();
    bad[12..16].copy_from_slice(&4u32.to_le_bytes());
    assert_eq!(PackedTrace::parse(&bad), Err(TraceError::TriggerFrame));
    bad[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert_eq!(PackedTrace::parse(&bad), Err(TraceError::TriggerFrame));
    // the trigger at the end: no frame of the manoeuvre, a valid header
    bad[12..16].copy_from_slice(&3u32.to_le_bytes());
    assert_eq!(PackedTrace::parse(&bad).map(|t| t.trigger_frame()), Ok(3));
    // an EMA1 body read as EMA2 (or the reverse) no longer matches its length
    let mut relabelled = good.clone();
    relabelled[3] = b'1';
    assert_eq!(PackedTrace::parse(&relabelled), Err(TraceError::Length));
    let mut buf = [0u8; 64];
    assert_eq!(pack(&frames, TraceHeader::new(10, 4), &mut buf), Err(TraceError::TriggerFrame));
    assert_eq!(pack(&frames, TraceHeader::new(0, 1), &mut buf), Err(TraceError::SampleRate));
    assert_eq!(pack(&frames, TraceHeader::new(10, 1), &mut buf[..30]), Err(TraceError::OutputTooSmall));
    assert_eq!(pack(&frames, TraceHeader::new(10, 1), &mut buf[..31]), Ok(31));
    // every truncation and byte flip of an EMA2 trace gives a value
    let long = packed_triggered(&synthetic::placeholder_frames()[..50], TraceHeader::new(10_000, 20));
    for n in 0..long.len() {
        assert!(PackedTrace::parse(&long[..n]).is_err(), "truncated to {n}");
    }
    for at in 0..long.len() {
        for flip in [0x01u8, 0x10, 0x80, 0xFF] {
            let mut b = long.clone();
            b[at] ^= flip;
            if let Ok(t) = PackedTrace::parse(&b) {
                assert!(t.iter().count() == t.frames());
                assert!(t.trigger_frame() as usize <= t.frames());
            }
        }
    }
}

#[test]
fn synthetic_waveform_is_a_balanced_six_step() {
    let frames = synthetic::placeholder_frames();
    assert_eq!(frames.len(), 2400);
    for f in &frames {
        let sum: i32 = f.iter().map(|&c| i32::from(c) - i32::from(ADC_MIDSCALE)).sum();
        assert!(sum.abs() <= 2, "{f:?}");
        assert!(f.iter().all(|&c| c > 0 && c < ADC_MAX));
    }
}

/// The checked-in built-in trace is the reference model's recording of the standard profile
/// (`ema firmware-trace`, traces/README.md): 0.85 s at 10 kHz, three phases of an isolated star
/// (the currents sum to zero within the sensor noise, as acquisition checks).
#[test]
fn built_in_trace_is_the_standard_recording() {
    let bytes = include_bytes!("../../traces/standard.ematrace");
    let t = PackedTrace::parse(bytes).expect("traces/standard.ematrace is a valid packed trace");
    assert_eq!(t.sample_rate_hz(), SAMPLE_RATE_HZ);
    let expected = libm::roundf(crate::Profile::STANDARD.duration_s() * SAMPLE_RATE_HZ as f32) as usize;
    assert_eq!((t.frames(), expected), (8500, 8500));
    assert_eq!(bytes.len(), packed_len(8500));
    assert_eq!(t.iter().count(), t.frames());
    for (i, f) in t.iter().enumerate() {
        let sum: f32 = f.iter().map(|&c| counts_to_amps(c)).sum();
        assert!(sum.abs() < 0.3, "frame {i}: {f:?} sums to {sum} A");
    }
    // a real recording: the currents vary (noise, commutation), unlike a constant fill
    let first = t.frame(0).expect("frame 0");
    assert!(t.iter().any(|f| f != first));
}
