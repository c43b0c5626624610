//! Phase-current ADC format shared by the reference model (which records it), the firmware's
//! built-in trace (which stores it packed in flash) and acquisition (which converts it back).
//!
//! Current sensors: 12-bit ADC over ±20 A, mid-scale at zero current:
//! `counts = clamp(round(ADC_MIDSCALE + i/AMPS_PER_COUNT), 0, ADC_MAX)`.
//!
//! **Packed trace** ([`PackedTrace`], [`pack`]): the compact on-flash form of a recording. Three
//! versions: `EMA1`, the recording of the manoeuvre alone; `EMA2`, which opens with frames
//! recorded before the manoeuvre (a pre-trigger: the actuator at rest, from which the sensors'
//! zero points can be measured) and holds the trigger frame, the index of the manoeuvre's first
//! frame; and `EMA3`, the `EMA2` layout followed by a CRC-32 of every byte before it, the one
//! [`pack`] writes.
//!
//! | offset | bytes | field |
//! |--------|-------|-------|
//! | 0 | 4 | magic `b"EMA1"` ([`TRACE_MAGIC`]), `b"EMA2"` ([`TRACE_MAGIC_TRIGGERED`]) or `b"EMA3"` ([`TRACE_MAGIC_CHECKED`]) |
//! | 4 | 4 | frame count `n` (pre-trigger frames included), `u32` little-endian |
//! | 8 | 4 | sample rate in Hz, `u32` little-endian, > 0 |
//! | 12 | 4 | `EMA2` and `EMA3`: trigger frame `t ≤ n`, `u32` little-endian (frames `0..t` are the pre-trigger; 0 for none) |
//! | 12 (`EMA1`), 16 (`EMA2`, `EMA3`) | `3·⌈3n/2⌉` | the codes `ia0 ib0 ic0 ia1 ib1 ic1 …`, 12 bits each, two codes per 3 bytes |
//! | after the codes | 4 | `EMA3` only: [`crc32`] of every byte before it, magic included, `u32` little-endian |
//!
//! An `EMA1` trace has trigger frame 0. A pair of codes `(x, y)` is stored as
//! `[x & 0xFF, (x >> 8) | (y & 0x0F) << 4, y >> 4]` (the FAT12 order). With an odd number of codes
//! the last pair is padded with `y = 0`, and the padding must read back as 0.
//!
//! **Integrity.** Only `EMA3` can tell a corrupted trace from a recording: a changed code reads
//! as another current, and a trace with bits flipped in its codes still gives a diagnosis.
//! [`PackedTrace::parse`] checks an `EMA3` trace's CRC-32 before anything else, so every change
//! of one or two bits and every burst of up to 32 bits is refused ([`TraceError::Checksum`]), and
//! any other damage, a truncation included, escapes about one time in 2³². `EMA1` and
//! `EMA2` traces carry no checksum: they are still read, as the recordings of before, but
//! nothing detects their corruption ([`PackedTrace::has_checksum`]; the host's `ema` warns when
//! it reads one).
//!
//! The encoder [`pack`] writes `EMA3` into a caller's buffer (no alloc), whatever the trigger
//! frame ([`TraceHeader`]); the reader [`PackedTrace::parse`] checks magic, checksum (`EMA3`),
//! rate, trigger frame, exact length and padding, then decodes frame by frame. Both return a
//! [`TraceError`] on any bad input and never panic.

/// ADC resolution.
pub const ADC_BITS: u32 = 12;
/// Largest ADC code.
pub const ADC_MAX: u16 = (1 << ADC_BITS) - 1;
/// Code of zero current.
pub const ADC_MIDSCALE: u16 = 1 << (ADC_BITS - 1);
/// Current sensor range: ±`CURRENT_FULL_SCALE_A`.
pub const CURRENT_FULL_SCALE_A: f32 = 20.0;
/// Nominal current per ADC code (40 A over 4096 codes).
pub const AMPS_PER_COUNT: f32 = 2.0 * CURRENT_FULL_SCALE_A / (1 << ADC_BITS) as f32;
/// ADC sample rate of the phase currents: one frame per control period (10 kHz).
pub const SAMPLE_RATE_HZ: u32 = 10_000;

/// Nominal conversion of a current to its ADC code (saturating at the rails).
pub fn amps_to_counts(i_a: f32) -> u16 {
    let c = libm::roundf(ADC_MIDSCALE as f32 + i_a / AMPS_PER_COUNT);
    if c.is_nan() || c < 0.0 {
        0
    } else if c > ADC_MAX as f32 {
        ADC_MAX
    } else {
        c as u16
    }
}

/// Nominal conversion of an ADC code back to amperes.
pub fn counts_to_amps(counts: u16) -> f32 {
    (counts as f32 - ADC_MIDSCALE as f32) * AMPS_PER_COUNT
}

/// Magic bytes that open a packed trace of the manoeuvre alone (trigger frame 0).
pub const TRACE_MAGIC: [u8; 4] = *b"EMA1";
/// Magic bytes that open a packed trace with a trigger frame and no checksum.
pub const TRACE_MAGIC_TRIGGERED: [u8; 4] = *b"EMA2";
/// Magic bytes that open a packed trace with a trigger frame and a checksum: what [`pack`] writes.
pub const TRACE_MAGIC_CHECKED: [u8; 4] = *b"EMA3";
/// Size of the `EMA1` header: magic, frame count, sample rate.
pub const TRACE_HEADER_LEN: usize = 12;
/// Size of the `EMA2` and `EMA3` header: magic, frame count, sample rate, trigger frame.
pub const TRIGGERED_HEADER_LEN: usize = 16;
/// Size of the `EMA3` checksum after the codes.
pub const CHECKSUM_LEN: usize = 4;

/// CRC-32/ISO-HDLC of `bytes` (the zlib, PNG and Ethernet CRC: polynomial 0x04C11DB7 reflected,
/// initial value and final XOR 0xFFFF_FFFF; check value 0xCBF43926 over `123456789`), the
/// checksum of an `EMA3` trace.
///
/// Bit by bit, without a table, on purpose: no crate of the build offers a CRC-32
/// (`sequential-storage` keeps its own private), the `crc` crate would add two crates to the
/// three workspaces' lock files for these few lines, and a 1 KiB table would sit in the MCU's
/// flash for a check that runs once, at start-up, on the built-in trace (38 KB: 1.1 million
/// instructions in QEMU, 0.014 % of the firmware's run).
pub const fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xFFFF_FFFF_u32;
    let mut rest = bytes;
    while let [byte, tail @ ..] = rest {
        crc ^= *byte as u32;
        let mut bit = 0;
        while bit < 8 {
            // shift out one bit; XOR the reflected polynomial in when it was a 1
            crc = (crc >> 1) ^ (0xEDB8_8320 & (crc & 1).wrapping_neg());
            bit += 1;
        }
        rest = tail;
    }
    !crc
}

// The standard check value of CRC-32/ISO-HDLC, checked when the core builds.
const _: () = assert!(crc32(b"123456789") == 0xCBF4_3926);

/// What a packed trace's header holds besides its frame count: the sample rate and the trigger
/// frame. A bare rate converts to the header of a trace without pre-trigger (trigger frame 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TraceHeader {
    /// Sample rate of the frames, Hz (> 0).
    pub rate_hz: u32,
    /// Index of the manoeuvre's first frame: the number of pre-trigger frames before it.
    pub trigger_frame: u32,
}

impl TraceHeader {
    /// The header of a trace at `rate_hz` whose manoeuvre starts at frame `trigger_frame`.
    pub const fn new(rate_hz: u32, trigger_frame: u32) -> Self {
        Self { rate_hz, trigger_frame }
    }

    /// Bytes of the `EMA3` trace [`pack`] writes of `frames` frames under this header (any
    /// trigger frame: the header, the codes and the checksum); `usize::MAX` if that overflows (as
    /// [`packed_len`]).
    pub const fn packed_len(&self, frames: usize) -> usize {
        let body = match frames.checked_mul(3) {
            Some(codes) => packed_codes_len(codes),
            None => None,
        };
        match body {
            Some(b) => match b.checked_add(TRIGGERED_HEADER_LEN + CHECKSUM_LEN) {
                Some(n) => n,
                None => usize::MAX,
            },
            None => usize::MAX,
        }
    }
}

impl From<u32> for TraceHeader {
    /// The header of a trace at `rate_hz` without pre-trigger.
    fn from(rate_hz: u32) -> Self {
        Self::new(rate_hz, 0)
    }
}

/// Why a packed trace could not be read or written. Never a panic: every input gives a value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum TraceError {
    /// Fewer bytes than the header (12 bytes, 16 for `EMA2`, 20 with the checksum for `EMA3`).
    TruncatedHeader,
    /// The first four bytes are not `b"EMA1"`, `b"EMA2"` or `b"EMA3"`.
    BadMagic,
    /// The `EMA3` checksum is not the CRC-32 of the bytes before it: the trace was corrupted or
    /// truncated.
    Checksum,
    /// The trigger frame of an `EMA2` header is past the last frame.
    TriggerFrame,
    /// The byte length does not match the frame count in the header (truncated or trailing data).
    Length,
    /// The sample rate in the header is 0.
    SampleRate,
    /// The padding nibbles after an odd number of codes are not zero.
    Padding,
    /// A code to pack is above [`ADC_MAX`] (does not fit in 12 bits).
    CodeRange,
    /// Too many frames: the frame count does not fit the `u32` header field or the address space.
    TooManyFrames,
    /// The output buffer is shorter than [`packed_len`] of the frames.
    OutputTooSmall,
}

impl core::fmt::Display for TraceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            TraceError::TruncatedHeader => {
                "packed trace shorter than its 12-byte header (16 bytes for EMA2, 20 with the checksum for EMA3)"
            }
            TraceError::BadMagic => "packed trace does not start with EMA1, EMA2 or EMA3",
            TraceError::Checksum => {
                "packed trace checksum does not match its contents: the file is corrupted or truncated"
            }
            TraceError::TriggerFrame => "packed trace's trigger frame is past its last frame",
            TraceError::Length => "packed trace length does not match its frame count",
            TraceError::SampleRate => "packed trace sample rate is zero",
            TraceError::Padding => "packed trace padding is not zero",
            TraceError::CodeRange => "ADC code above 12 bits",
            TraceError::TooManyFrames => "too many frames for a packed trace",
            TraceError::OutputTooSmall => "output buffer too small for the packed trace",
        })
    }
}

impl core::error::Error for TraceError {}

/// Bytes needed for `codes` packed 12-bit codes (pairs of codes in 3 bytes), `None` on overflow.
const fn packed_codes_len(codes: usize) -> Option<usize> {
    match codes.checked_add(1) {
        Some(c) => (c / 2).checked_mul(3),
        None => None,
    }
}

/// Bytes of the packed trace [`pack`] writes of `frames` frames (`EMA3`: header, codes and
/// checksum, whatever the trigger frame); `usize::MAX` if that overflows (such a trace can never
/// fit a buffer, so [`pack`] then reports [`TraceError::TooManyFrames`]).
pub const fn packed_len(frames: usize) -> usize {
    TraceHeader::new(1, 0).packed_len(frames)
}

/// A validated, borrowed packed trace (typically `include_bytes!` in flash). Decoding is lazy:
/// [`PackedTrace::frame`] unpacks one frame on demand, so nothing is copied to RAM.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PackedTrace<'a> {
    codes: &'a [u8],
    frames: usize,
    sample_rate_hz: u32,
    trigger_frame: u32,
    version: u8,
}

impl<'a> PackedTrace<'a> {
    /// Checks the magic, then an `EMA3` trace's checksum (before any field it covers is read),
    /// then the header (non-zero rate, a trigger frame not past the last frame), that the length
    /// matches the frame count exactly and that any padding is zero. An `EMA1` or `EMA2` trace
    /// has no checksum: it is read as it is ([`PackedTrace::has_checksum`]).
    pub fn parse(bytes: &'a [u8]) -> Result<Self, TraceError> {
        if bytes.len() < TRACE_HEADER_LEN {
            return Err(TraceError::TruncatedHeader);
        }
        let (version, header_len, trailer) = match bytes.get(..4) {
            Some(m) if m == TRACE_MAGIC => (1, TRACE_HEADER_LEN, 0),
            Some(m) if m == TRACE_MAGIC_TRIGGERED => (2, TRIGGERED_HEADER_LEN, 0),
            Some(m) if m == TRACE_MAGIC_CHECKED => (3, TRIGGERED_HEADER_LEN, CHECKSUM_LEN),
            _ => return Err(TraceError::BadMagic),
        };
        let payload_len =
            bytes.len().checked_sub(trailer).filter(|&n| n >= header_len).ok_or(TraceError::TruncatedHeader)?;
        let (payload, stored) = bytes.split_at_checked(payload_len).ok_or(TraceError::TruncatedHeader)?;
        if let [a, b, c, d] = *stored {
            if u32::from_le_bytes([a, b, c, d]) != crc32(payload) {
                return Err(TraceError::Checksum);
            }
        }
        let (header, codes) = payload.split_at_checked(header_len).ok_or(TraceError::TruncatedHeader)?;
        let word = |at: usize| -> u32 {
            let mut w = [0u8; 4];
            if let Some(src) = header.get(at..at + 4) {
                w.copy_from_slice(src);
            }
            u32::from_le_bytes(w)
        };
        let frame_count = word(4);
        let frames = usize::try_from(frame_count).map_err(|_| TraceError::TooManyFrames)?;
        let sample_rate_hz = word(8);
        if sample_rate_hz == 0 {
            return Err(TraceError::SampleRate);
        }
        // an EMA1 header has no word at 12: trigger frame 0
        let trigger_frame = word(12);
        if trigger_frame > frame_count {
            return Err(TraceError::TriggerFrame);
        }
        let n_codes = frames.checked_mul(3).ok_or(TraceError::TooManyFrames)?;
        let expected = packed_codes_len(n_codes).ok_or(TraceError::TooManyFrames)?;
        if codes.len() != expected {
            return Err(TraceError::Length);
        }
        if !n_codes.is_multiple_of(2) {
            // The last pair holds one code: its partner (high nibble of byte 1, byte 2) is padding.
            let pad_ok = match codes {
                [.., b1, b2] => b1 >> 4 == 0 && *b2 == 0,
                _ => false,
            };
            if !pad_ok {
                return Err(TraceError::Padding);
            }
        }
        Ok(Self { codes, frames, sample_rate_hz, trigger_frame, version })
    }

    /// The format version: 1 (`EMA1`), 2 (`EMA2`) or 3 (`EMA3`).
    pub const fn version(&self) -> u8 {
        self.version
    }

    /// `true` for an `EMA3` trace, whose checksum [`PackedTrace::parse`] checked; `false` for an
    /// `EMA1` or `EMA2` one, whose corruption nothing detects.
    pub const fn has_checksum(&self) -> bool {
        self.version >= 3
    }

    /// Number of frames (each frame: the three phase codes `ia, ib, ic`).
    pub const fn frames(&self) -> usize {
        self.frames
    }

    /// Sample rate of the frames.
    pub const fn sample_rate_hz(&self) -> u32 {
        self.sample_rate_hz
    }

    /// Index of the manoeuvre's first frame: the number of pre-trigger frames before it (0 for
    /// an `EMA1` trace).
    pub const fn trigger_frame(&self) -> u32 {
        self.trigger_frame
    }

    /// The header's rate and trigger frame.
    pub const fn header(&self) -> TraceHeader {
        TraceHeader::new(self.sample_rate_hz, self.trigger_frame)
    }

    /// `true` when the trace holds no frame.
    pub const fn is_empty(&self) -> bool {
        self.frames == 0
    }

    /// Codes `[ia, ib, ic]` of frame `i`, `None` past the end.
    pub fn frame(&self, i: usize) -> Option<[u16; 3]> {
        if i >= self.frames {
            return None;
        }
        let s = i.checked_mul(3)?;
        Some([self.code(s)?, self.code(s + 1)?, self.code(s + 2)?])
    }

    /// Iterator over all frames, in order.
    pub fn iter(&self) -> impl Iterator<Item = [u16; 3]> + 'a {
        let t = *self;
        (0..t.frames).map_while(move |i| t.frame(i))
    }

    /// Code number `s` (0-based over all samples).
    fn code(&self, s: usize) -> Option<u16> {
        let at = (s / 2) * 3;
        let b = self.codes.get(at..at + 3)?;
        let (b0, b1, b2) = (u16::from(b[0]), u16::from(b[1]), u16::from(b[2]));
        Some(if s.is_multiple_of(2) { b0 | (b1 & 0x0F) << 8 } else { b1 >> 4 | b2 << 4 })
    }
}

/// Packs `frames` (codes `[ia, ib, ic]`, each ≤ [`ADC_MAX`]) under `header` (its rate and
/// trigger frame; a bare rate for a trace without pre-trigger) into `out`, without allocating,
/// as `EMA3`: header, codes, checksum. Returns the number of bytes written,
/// [`TraceHeader::packed_len`]`(frames.len())`.
///
/// Nothing is written past that length; on error the content of `out` is unspecified.
pub fn pack(frames: &[[u16; 3]], header: impl Into<TraceHeader>, out: &mut [u8]) -> Result<usize, TraceError> {
    let header = header.into();
    let count = u32::try_from(frames.len()).map_err(|_| TraceError::TooManyFrames)?;
    if header.rate_hz == 0 {
        return Err(TraceError::SampleRate);
    }
    if header.trigger_frame > count {
        return Err(TraceError::TriggerFrame);
    }
    let len = header.packed_len(frames.len());
    if len == usize::MAX {
        return Err(TraceError::TooManyFrames);
    }
    let out = out.get_mut(..len).ok_or(TraceError::OutputTooSmall)?;
    // len counts the header and the checksum: the payload holds the header
    let payload = out.get_mut(..len.saturating_sub(CHECKSUM_LEN)).ok_or(TraceError::OutputTooSmall)?;
    let (head, body) = payload.split_at_mut_checked(TRIGGERED_HEADER_LEN).ok_or(TraceError::OutputTooSmall)?;
    let words =
        [TRACE_MAGIC_CHECKED, count.to_le_bytes(), header.rate_hz.to_le_bytes(), header.trigger_frame.to_le_bytes()];
    for (dst, src) in head.chunks_exact_mut(4).zip(words.iter()) {
        dst.copy_from_slice(src);
    }
    let mut codes = frames.iter().flat_map(|f| f.iter().copied());
    for chunk in body.chunks_exact_mut(3) {
        let x = codes.next().unwrap_or(0);
        let y = codes.next().unwrap_or(0);
        if x > ADC_MAX || y > ADC_MAX {
            return Err(TraceError::CodeRange);
        }
        chunk[0] = (x & 0xFF) as u8;
        chunk[1] = ((x >> 8) | (y & 0x0F) << 4) as u8;
        chunk[2] = (y >> 4) as u8;
    }
    reseal(out)?;
    Ok(len)
}

/// Writes the checksum of the `EMA3` trace `bytes` after an edit of its other bytes: its last
/// four bytes become the [`crc32`] of every byte before them. For tools that make a trace wrong
/// on purpose while keeping it intact to the checksum (a test's relabelled sample rate, the
/// parity set's bad padding), so that the check under test is the one that refuses it.
/// `Err(BadMagic)` for a trace that is not `EMA3`, `Err(TruncatedHeader)` for one shorter than
/// its header and checksum.
pub fn reseal(bytes: &mut [u8]) -> Result<(), TraceError> {
    if bytes.get(..4) != Some(&TRACE_MAGIC_CHECKED[..]) {
        return Err(TraceError::BadMagic);
    }
    let payload_len = bytes
        .len()
        .checked_sub(CHECKSUM_LEN)
        .filter(|&n| n >= TRIGGERED_HEADER_LEN)
        .ok_or(TraceError::TruncatedHeader)?;
    let (payload, trailer) = bytes.split_at_mut(payload_len);
    trailer.copy_from_slice(&crc32(payload).to_le_bytes());
    Ok(())
}

/// Synthetic waveforms for tests (host only): trace-format and acquisition tests.
#[cfg(test)]
pub(crate) mod synthetic {
    use super::amps_to_counts;
    use core::f32::consts::PI;

    /// Currents of an ideal six-step (120° conduction) drive at electrical angle `theta_e` carrying
    /// `i_a` amperes, with a linear 3-frame commutation overlap given by `overlap` in `[0, 1)`
    /// (0 = just commutated). The star is isolated: the three currents always sum to zero.
    pub fn six_step_currents(theta_e: f32, i_a: f32, overlap: f32) -> [f32; 3] {
        let sector = (libm::floorf(theta_e / (PI / 3.0)) as i64).rem_euclid(6) as usize;
        // (positive phase, negative phase) per sector: AB, AC, BC, BA, CA, CB.
        const TABLE: [(usize, usize); 6] = [(0, 1), (0, 2), (1, 2), (1, 0), (2, 0), (2, 1)];
        let (p, n) = TABLE[sector];
        let (pp, pn) = TABLE[(sector + 5) % 6];
        let mut i = [0.0f32; 3];
        i[p] += i_a;
        i[n] -= i_a;
        if overlap > 0.0 {
            // the outgoing pair still carries a decaying share of the current
            let f = 1.0 - overlap;
            i[p] -= f * i_a;
            i[n] += f * i_a;
            i[pp] += f * i_a;
            i[pn] -= f * i_a;
        }
        i
    }

    /// A synthetic six-step recording, 10 kHz, 2400 frames, noiseless: 30 ms at rest with zero
    /// current (all codes constant), 30 ms at standstill holding 3 A in sector 0 (phase C off for the whole segment), then 180 ms of six-step accelerating from 5 Hz
    /// to 100 Hz electrical at 5 A, with a ±0.15 A hysteresis ripple on the conducting pair.
    pub fn placeholder_frames() -> std::vec::Vec<[u16; 3]> {
        let rate = super::SAMPLE_RATE_HZ as f32;
        let mut out = std::vec::Vec::with_capacity(2400);
        let mut theta = 0.0f32;
        let mut last_sector = 0i64;
        let mut since_commutation = 100u32;
        for k in 0..2400u32 {
            let t = k as f32 / rate;
            // hysteresis ripple: triangle of period 0.8 ms, ±0.15 A
            let phase = (t / 0.0008).fract();
            let ripple = 0.15 * (4.0 * libm::fabsf(phase - 0.5) - 1.0);
            let i = if k < 300 {
                [0.0; 3]
            } else if k < 600 {
                six_step_currents(0.1, 3.0 + ripple, 0.0)
            } else {
                let f_e = 5.0 + 95.0 * (k - 600) as f32 / 1800.0;
                theta += 2.0 * PI * f_e / rate;
                let sector = libm::floorf(theta / (PI / 3.0)) as i64;
                if sector != last_sector {
                    last_sector = sector;
                    since_commutation = 0;
                }
                let overlap = if since_commutation < 3 { (since_commutation + 1) as f32 / 4.0 } else { 0.0 };
                since_commutation += 1;
                six_step_currents(theta, 5.0 + ripple, overlap)
            };
            out.push([amps_to_counts(i[0]), amps_to_counts(i[1]), amps_to_counts(i[2])]);
        }
        out
    }
}

#[cfg(test)]
mod tests;
