//! Host tests of the packed trace: layout, lengths, round trips, every corrupted header and
//! length, the checksum against every bit flip, the formats without one, the built-in trace.

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

/// The same trace as the writers before `EMA3` wrote it: `EMA1` (`version` 1, trigger frame
/// 0 only) or `EMA2` (`version` 2), without a checksum.
fn legacy(ema3: &[u8], version: u8) -> std::vec::Vec<u8> {
    let t = PackedTrace::parse(ema3).expect("an EMA3 trace");
    let codes = &ema3[TRIGGERED_HEADER_LEN..ema3.len() - CHECKSUM_LEN];
    let mut out = std::vec::Vec::new();
    if version == 1 {
        assert_eq!(t.trigger_frame(), 0, "EMA1 has no trigger frame");
        out.extend_from_slice(&TRACE_MAGIC);
        out.extend_from_slice(&ema3[4..12]);
    } else {
        out.extend_from_slice(&TRACE_MAGIC_TRIGGERED);
        out.extend_from_slice(&ema3[4..16]);
    }
    out.extend_from_slice(codes);
    out
}

/// `bytes` with the edit `f`, the checksum written again: a trace wrong in the edited field
/// alone.
fn edited(bytes: &[u8], f: impl FnOnce(&mut std::vec::Vec<u8>)) -> std::vec::Vec<u8> {
    let mut b = bytes.to_vec();
    f(&mut b);
    reseal(&mut b).expect("an EMA3 trace");
    b
}

#[test]
fn the_checksum_is_crc32_iso_hdlc() {
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    assert_eq!(crc32(b""), 0);
    assert_eq!(crc32(b"a"), 0xE8B7_BE43);
    assert_eq!(crc32(&[0u8; 32]), 0x190A_55AD);
}

#[test]
fn known_byte_layout() {
    let buf = packed(&[[0x123, 0x456, 0x789]], 10_000);
    assert_eq!(&buf[..4], b"EMA3");
    assert_eq!(&buf[4..8], &1u32.to_le_bytes());
    assert_eq!(&buf[8..12], &10_000u32.to_le_bytes());
    assert_eq!(&buf[12..16], &0u32.to_le_bytes());
    assert_eq!(&buf[16..22], &[0x23, 0x61, 0x45, 0x89, 0x07, 0x00]);
    // zlib.crc32 of the 22 bytes before it, little-endian
    assert_eq!(&buf[22..], &0xDC39_0620u32.to_le_bytes());
    let t = PackedTrace::parse(&buf).unwrap();
    assert_eq!((t.version(), t.has_checksum()), (3, true));
}

#[test]
fn packed_lengths() {
    assert_eq!(packed_len(0), 20); // 16-byte header, 4-byte checksum
    assert_eq!(packed_len(1), 20 + 6); // 3 codes: 2 pairs, one padded
    assert_eq!(packed_len(2), 20 + 9); // 6 codes: 3 pairs
    assert_eq!(packed_len(3), 20 + 15);
    assert_eq!(TraceHeader::new(10_000, 2).packed_len(3), packed_len(3));
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
    assert_eq!(PackedTrace::parse(&good[..19]), Err(TraceError::TruncatedHeader));
    let mut bad = good.clone();
    bad[0] = b'X';
    assert_eq!(PackedTrace::parse(&bad), Err(TraceError::BadMagic));
    // a truncation or a trailing byte moves the checksum: refused before the length is read
    assert_eq!(PackedTrace::parse(&good[..good.len() - 1]), Err(TraceError::Checksum));
    let mut long = good.clone();
    long.push(0);
    assert_eq!(PackedTrace::parse(&long), Err(TraceError::Checksum));
    // each field wrong with the checksum written over it: the field's own check refuses it
    let zero_rate = edited(&good, |b| b[8..12].copy_from_slice(&0u32.to_le_bytes()));
    assert_eq!(PackedTrace::parse(&zero_rate), Err(TraceError::SampleRate));
    let huge = edited(&good, |b| b[4..8].copy_from_slice(&u32::MAX.to_le_bytes()));
    assert!(PackedTrace::parse(&huge).is_err());
    let four = edited(&good, |b| b[4..8].copy_from_slice(&4u32.to_le_bytes()));
    assert_eq!(PackedTrace::parse(&four), Err(TraceError::Length));
    let shorter = edited(&good[..good.len() - 1], |_| {});
    assert_eq!(PackedTrace::parse(&shorter), Err(TraceError::Length));
    // 3 frames = 9 codes: the last pair is padded; a non-zero pad is corruption
    let n = good.len() - CHECKSUM_LEN;
    assert_eq!(PackedTrace::parse(&edited(&good, |b| b[n - 1] = 1)), Err(TraceError::Padding));
    assert_eq!(PackedTrace::parse(&edited(&good, |b| b[n - 2] |= 0x10)), Err(TraceError::Padding));
    // reseal refuses what is not an EMA3 trace
    assert_eq!(reseal(&mut legacy(&good, 1)), Err(TraceError::BadMagic));
    assert_eq!(reseal(&mut good.clone()[..19]), Err(TraceError::TruncatedHeader));
}

/// Every single bit of a 50-frame trace flipped in turn, then 500 random changes of one to
/// eight bytes anywhere (seeded): every one refused, most by the checksum (a flip in the magic
/// is a bad magic, or reads as `EMA1`/`EMA2` whose lengths then differ). And every truncation.
#[test]
fn every_bit_flip_truncation_and_random_damage_is_refused() {
    let good = packed(&synthetic::placeholder_frames()[..50], 10_000);
    for n in 0..good.len() {
        assert!(PackedTrace::parse(&good[..n]).is_err(), "truncated to {n}");
    }
    let mut by_checksum = 0;
    for bit in 0..8 * good.len() {
        let mut b = good.clone();
        b[bit / 8] ^= 1 << (bit % 8);
        let refused = PackedTrace::parse(&b);
        assert!(refused.is_err(), "bit {bit} (byte {}) flipped: accepted", bit / 8);
        by_checksum += usize::from(refused == Err(TraceError::Checksum));
    }
    assert_eq!(by_checksum, 8 * (good.len() - 4), "every flip after the magic is a checksum error");
    let mut rng = crate::optimizer::rng::Rng::new(43);
    for case in 0..500 {
        let mut b = good.clone();
        let bytes = 1 + rng.below(8) as usize;
        let at = rng.below((good.len() - bytes + 1) as u32) as usize;
        for x in &mut b[at..at + bytes] {
            *x ^= 1 + rng.below(255) as u8;
        }
        assert!(PackedTrace::parse(&b).is_err(), "case {case}: {bytes} bytes at {at} changed: accepted");
    }
}

/// An `EMA1` or `EMA2` trace, which has no checksum, is still read; its flips are handled
/// without a panic and may decode (what the checksum of `EMA3` exists for).
#[test]
fn traces_without_checksum_are_read_and_their_flips_handled_without_panic() {
    let ema3 = packed_triggered(&synthetic::placeholder_frames()[..50], TraceHeader::new(10_000, 20));
    let plain = packed(&synthetic::placeholder_frames()[..50], 10_000);
    for (version, bytes) in [(1, legacy(&plain, 1)), (2, legacy(&ema3, 2))] {
        let t = PackedTrace::parse(&bytes).expect("a trace without checksum reads");
        assert_eq!((t.version(), t.has_checksum()), (version, false));
        let reference = PackedTrace::parse(if version == 1 { &plain } else { &ema3 }).unwrap();
        assert!(t.iter().eq(reference.iter()) && t.header() == reference.header());
        let mut decoded = 0;
        for at in 0..bytes.len() {
            for flip in [0x01u8, 0x10, 0x80, 0xFF] {
                let mut b = bytes.clone();
                b[at] ^= flip;
                if let Ok(t) = PackedTrace::parse(&b) {
                    assert!(t.iter().count() == t.frames());
                    assert!(t.iter().all(|f| f.iter().all(|&c| c <= ADC_MAX)));
                    assert!(t.trigger_frame() as usize <= t.frames());
                    decoded += 1;
                }
            }
        }
        assert!(decoded > bytes.len(), "EMA{version}: most body flips still decode ({decoded})");
    }
}

#[test]
fn pack_rejects_bad_input() {
    let mut buf = [0u8; 64];
    assert_eq!(pack(&[[0, 4096, 0]], 10, &mut buf), Err(TraceError::CodeRange));
    assert_eq!(pack(&[[0, 0, u16::MAX]], 10, &mut buf), Err(TraceError::CodeRange));
    assert_eq!(pack(&[[0; 3]], 0, &mut buf), Err(TraceError::SampleRate));
    assert_eq!(pack(&[[0; 3]; 2], 10, &mut buf[..28]), Err(TraceError::OutputTooSmall));
    assert_eq!(pack(&[[0; 3]; 2], 10, &mut buf[..29]), Ok(29));
    assert_eq!(pack(&[], 10, &mut buf[..19]), Err(TraceError::OutputTooSmall));
    assert_eq!(pack(&[], 10, &mut buf), Ok(20));
    assert_eq!(PackedTrace::parse(&buf[..20]).map(|t| t.frames()), Ok(0));
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
    assert_eq!(&buf[..4], b"EMA3");
    assert_eq!(&buf[4..8], &2u32.to_le_bytes());
    assert_eq!(&buf[8..12], &10_000u32.to_le_bytes());
    assert_eq!(&buf[12..16], &1u32.to_le_bytes());
    assert_eq!(&buf[16..25], &[0x23, 0x61, 0x45, 0x89, 0x17, 0x00, 0x02, 0x30, 0x00]);
    assert_eq!(&buf[25..], &crc32(&buf[..25]).to_le_bytes());
    assert_eq!(buf.len(), packed_len(2));
    // the same frames under trigger frame 0 differ in the trigger word and the checksum alone
    let frames = [[7, 8, 9], [10, 11, 12], [13, 14, 15]];
    let (zero, bare) = (packed_triggered(&frames, TraceHeader::new(10_000, 0)), packed(&frames, 10_000));
    assert_eq!(zero, bare);
    let two = packed_triggered(&frames, TraceHeader::new(10_000, 2));
    let differ: std::vec::Vec<usize> = (0..two.len()).filter(|&i| two[i] != zero[i]).collect();
    assert!(differ.iter().all(|&i| i == 12 || i >= two.len() - 4), "{differ:?}");
    assert_eq!(TraceHeader::from(10_000), TraceHeader::new(10_000, 0));
    assert_eq!(TraceHeader::new(1, 5).packed_len(usize::MAX), usize::MAX);
}

#[test]
fn triggered_round_trip_and_ema1_ema2_compatibility() {
    let frames: std::vec::Vec<[u16; 3]> = (0..37u16).map(|i| [2048 + i, 2048 - i, (i * 97) % 4096]).collect();
    for trigger in [0u32, 1, 2, 17, 36, 37] {
        let buf = packed_triggered(&frames, TraceHeader::new(10_000, trigger));
        let t = PackedTrace::parse(&buf).expect("parses");
        assert_eq!((t.frames(), t.sample_rate_hz(), t.trigger_frame()), (37, 10_000, trigger));
        assert_eq!(t.header(), TraceHeader::new(10_000, trigger));
        assert!(t.iter().eq(frames.iter().copied()), "trigger {trigger}");
        // the same trace as EMA2 reads the same
        let ema2 = legacy(&buf, 2);
        let old = PackedTrace::parse(&ema2).expect("EMA2 parses");
        assert_eq!((old.header(), old.version()), (t.header(), 2));
        assert!(old.iter().eq(frames.iter().copied()));
    }
    // EMA1: trigger frame 0
    let buf = packed(&frames, 10_000);
    let ema1 = legacy(&buf, 1);
    let t = PackedTrace::parse(&ema1).expect("EMA1 parses");
    assert_eq!((t.trigger_frame(), t.header(), t.version()), (0, TraceHeader::new(10_000, 0), 1));
    assert!(t.iter().eq(frames.iter().copied()));
}

#[test]
fn corrupt_triggered_headers_are_errors() {
    let frames = [[1, 2, 3], [4, 5, 6], [7, 8, 9]];
    let good = packed_triggered(&frames, TraceHeader::new(10_000, 2));
    for n in 12..20 {
        assert_eq!(PackedTrace::parse(&good[..n]), Err(TraceError::TruncatedHeader), "{n} bytes");
    }
    let ema2 = legacy(&good, 2);
    for n in 12..16 {
        assert_eq!(PackedTrace::parse(&ema2[..n]), Err(TraceError::TruncatedHeader), "EMA2, {n} bytes");
    }
    let past = edited(&good, |b| b[12..16].copy_from_slice(&4u32.to_le_bytes()));
    assert_eq!(PackedTrace::parse(&past), Err(TraceError::TriggerFrame));
    let far = edited(&good, |b| b[12..16].copy_from_slice(&u32::MAX.to_le_bytes()));
    assert_eq!(PackedTrace::parse(&far), Err(TraceError::TriggerFrame));
    // the trigger at the end: no frame of the manoeuvre, a valid header
    let end = edited(&good, |b| b[12..16].copy_from_slice(&3u32.to_le_bytes()));
    assert_eq!(PackedTrace::parse(&end).map(|t| t.trigger_frame()), Ok(3));
    // EMA3 relabelled as EMA2 or EMA1: its checksum left over, the lengths differ
    for magic in [TRACE_MAGIC_TRIGGERED, TRACE_MAGIC] {
        let mut relabelled = good.clone();
        relabelled[..4].copy_from_slice(&magic);
        assert_eq!(PackedTrace::parse(&relabelled), Err(TraceError::Length));
    }
    let mut buf = [0u8; 64];
    assert_eq!(pack(&frames, TraceHeader::new(10, 4), &mut buf), Err(TraceError::TriggerFrame));
    assert_eq!(pack(&frames, TraceHeader::new(0, 1), &mut buf), Err(TraceError::SampleRate));
    assert_eq!(pack(&frames, TraceHeader::new(10, 1), &mut buf[..34]), Err(TraceError::OutputTooSmall));
    assert_eq!(pack(&frames, TraceHeader::new(10, 1), &mut buf[..35]), Ok(35));
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
    assert_eq!((t.version(), t.trigger_frame()), (3, 0), "EMA3, no pre-trigger");
    assert_eq!(t.iter().count(), t.frames());
    for (i, f) in t.iter().enumerate() {
        let sum: f32 = f.iter().map(|&c| counts_to_amps(c)).sum();
        assert!(sum.abs() < 0.3, "frame {i}: {f:?} sums to {sum} A");
    }
    // a real recording: the currents vary (noise, commutation), unlike a constant fill
    let first = t.frame(0).expect("frame 0");
    assert!(t.iter().any(|f| f != first));
}
