//! A commissioning flight's conditioned window, kept in flash until the last commissioning
//! flight fits the unit's baseline to all of them at once (`docs/commissioning.md`). The window
//! is kept as its block means alone: the weights follow from them
//! ([`ConditionedWindow::rebuild`]), so the window read back is the acquired one bit for bit.
//!
//! **Layout** (little-endian, `f32` as its IEEE-754 bits):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 1 | format version, [`WINDOW_VERSION`] |
//! | 1 | 1 | reserved, 0 |
//! | 2 | 2 | window samples `n` (`u16`) |
//! | 4 | 4 | the flight's temperature (°C, NaN when none was read) |
//! | 8 | 4·n | the block means ([`ConditionedWindow::current_a`]) |

use crate::conditioning::{ConditionedWindow, ConditioningError};

/// Format version of a kept window.
pub const WINDOW_VERSION: u8 = 1;

/// Bytes before the samples.
pub const WINDOW_HEADER_LEN: usize = 8;

/// Bytes of a kept window of `samples` block means.
pub const fn window_encoded_len(samples: usize) -> usize {
    WINDOW_HEADER_LEN + 4 * samples
}

/// Why bytes do not decode as a kept window, or a window cannot be kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WindowError {
    /// The buffer is shorter than the encoding.
    BufferTooSmall,
    /// The window is not closed, or holds more samples than a `u16` counts.
    NotKeepable,
    /// Not [`WINDOW_VERSION`].
    Version(u8),
    /// Not the length its sample count says.
    Length,
    /// The samples do not make a window ([`ConditionedWindow::rebuild`]).
    Conditioning(ConditioningError),
}

/// Writes `window` (closed) and the flight's `temperature_c` into `out`; returns the bytes
/// written.
pub fn encode_window<const W: usize>(
    window: &ConditionedWindow<W>,
    temperature_c: f32,
    out: &mut [u8],
) -> Result<usize, WindowError> {
    let samples = window.current_a();
    let n = u16::try_from(samples.len()).map_err(|_| WindowError::NotKeepable)?;
    if !window.is_finished() {
        return Err(WindowError::NotKeepable);
    }
    let len = window_encoded_len(samples.len());
    let out = out.get_mut(..len).ok_or(WindowError::BufferTooSmall)?;
    let (header, body) = out.split_at_mut_checked(WINDOW_HEADER_LEN).ok_or(WindowError::BufferTooSmall)?;
    let [n0, n1] = n.to_le_bytes();
    let [t0, t1, t2, t3] = temperature_c.to_bits().to_le_bytes();
    for (dst, b) in header.iter_mut().zip([WINDOW_VERSION, 0, n0, n1, t0, t1, t2, t3]) {
        *dst = b;
    }
    for (dst, y) in body.chunks_exact_mut(4).zip(samples) {
        dst.copy_from_slice(&y.to_bits().to_le_bytes());
    }
    Ok(len)
}

/// Bytes of the whole encoding that starts with `bytes` (its header at least), from the sample
/// count the header gives: what a reader of the encoding in pieces needs to know after the
/// first one.
pub fn encoded_len_of(bytes: &[u8]) -> Result<usize, WindowError> {
    match bytes.get(..WINDOW_HEADER_LEN) {
        Some(&[version, _, n0, n1, ..]) if version == WINDOW_VERSION => {
            Ok(window_encoded_len(usize::from(u16::from_le_bytes([n0, n1]))))
        }
        Some(&[version, ..]) => Err(WindowError::Version(version)),
        _ => Err(WindowError::Length),
    }
}

/// Rebuilds the window of `bytes` into `out` ([`ConditionedWindow::rebuild`]); returns the flight's
/// temperature.
pub fn decode_window_into<const W: usize>(bytes: &[u8], out: &mut ConditionedWindow<W>) -> Result<f32, WindowError> {
    if bytes.len() != encoded_len_of(bytes)? {
        return Err(WindowError::Length);
    }
    let (header, body) = bytes.split_at_checked(WINDOW_HEADER_LEN).ok_or(WindowError::Length)?;
    let Ok(&[_, _, _, _, t0, t1, t2, t3]) = <&[u8; WINDOW_HEADER_LEN]>::try_from(header) else {
        return Err(WindowError::Length);
    };
    let temperature_c = f32::from_bits(u32::from_le_bytes([t0, t1, t2, t3]));
    let samples = body.chunks_exact(4).map(|b| {
        let word: [u8; 4] = b.try_into().unwrap_or([0xFF; 4]);
        f32::from_bits(u32::from_le_bytes(word))
    });
    out.rebuild(samples).map_err(WindowError::Conditioning)?;
    Ok(temperature_c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window() -> ConditionedWindow<300> {
        ConditionedWindow::from_samples((0..240).map(|j| 3.5 + 3.0 * libm::sinf(0.05 * j as f32) + 0.01 * j as f32))
            .unwrap()
    }

    #[test]
    fn a_kept_window_reads_back_bit_for_bit() {
        let w = window();
        let mut bytes = [0u8; window_encoded_len(300)];
        let len = encode_window(&w, -12.5, &mut bytes).unwrap();
        assert_eq!(len, window_encoded_len(240));
        let mut back = ConditionedWindow::<300>::from_samples((0..100).map(|j| j as f32)).unwrap();
        assert_eq!(decode_window_into(&bytes[..len], &mut back), Ok(-12.5));
        assert!(back.current_a().zip(w.current_a()).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(back.weights().zip(w.weights()).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert_eq!(back.len(), 240);
    }

    #[test]
    fn bad_bytes_and_open_windows_are_refused() {
        let w = window();
        let mut bytes = [0u8; window_encoded_len(240)];
        assert_eq!(encode_window(&w, 0.0, &mut bytes[..100]), Err(WindowError::BufferTooSmall));
        assert_eq!(encode_window(&ConditionedWindow::<300>::new(), 0.0, &mut bytes), Err(WindowError::NotKeepable));
        let len = encode_window(&w, f32::NAN, &mut bytes).unwrap();
        let mut out = ConditionedWindow::<300>::new();
        assert!(decode_window_into(&bytes[..len], &mut out).unwrap().is_nan());
        assert_eq!(decode_window_into(&bytes[..len - 4], &mut out), Err(WindowError::Length));
        assert_eq!(decode_window_into(&bytes[..3], &mut out), Err(WindowError::Length));
        let mut bad = bytes;
        bad[0] = 9;
        assert_eq!(decode_window_into(&bad, &mut out), Err(WindowError::Version(9)));
        let mut nan = bytes;
        nan[8..12].copy_from_slice(&f32::NAN.to_bits().to_le_bytes());
        assert_eq!(decode_window_into(&nan, &mut out), Err(WindowError::Conditioning(ConditioningError::NonFinite)));
        let mut small = ConditionedWindow::<100>::new();
        assert_eq!(
            decode_window_into(&bytes[..len], &mut small),
            Err(WindowError::Conditioning(ConditioningError::WindowFull))
        );
    }
}
