//! The packed traces of the host/target parity check (`scripts/parity`, `traces/parity/`): each
//! is replayed by the firmware in QEMU (`EMA_TRACE=FILE cargo run --release`) and by the host
//! (`ema identify --firmware-trace FILE --bits`), and the two summary lines must be equal.
//!
//! Every trace comes from the reference model (`host-tests/reference`) and is packed with
//! [`ema_monitor::trace::pack`]; the refused ones are the built-in recording cut, frozen or
//! corrupted on purpose. [`parity_traces`] builds them all in memory, deterministically: the
//! committed copies are written from it (`cargo run --release -p ema-cli --example parity-traces`)
//! and `tests/parity_traces.rs` checks them against it.
//!
//! | file | what the monitor says |
//! |---|---|
//! | `backlash-short-viscous-8khz.ematrace` | a full identification of another fault, with a model effect on: `INCONCLUSIVE(rate mismatch)` from the header's 8 kHz (at 10 kHz the same codes read `DEGRADED`) |
//! | `stuck-phase-b.ematrace` | phase B frozen for 40 ms in the step transient: `SENSOR_FAULT` |
//! | `too-short.ematrace` | 10 ms of recording: refused by conditioning, `Conditioning(TooShort)` |
//! | `bad-padding.ematrace` | a non-zero padding nibble (its checksum written over it): refused by the packed format, `Padding` |
//! | `bad-checksum.ematrace` | one bit of a code flipped after packing: refused by the checksum, `Checksum` |
//!
//! The built-in trace (`traces/standard.ematrace`, [`crate::firmware_trace`]) is the first trace
//! of the check; it is not repeated here.

use ema_monitor::trace::{pack, packed_len, reseal, CHECKSUM_LEN, SAMPLE_RATE_HZ};
use ema_monitor::FaultVector;
use ema_reference::{simulate, Effect, Effects, SimConfig};

use crate::error::CliError;
use crate::firmware_trace::firmware_trace_config;

/// Fault vector of the second full identification: backlash `k2 = 0.3` and a short circuit on
/// phase C `k5 = 0.35` (both `DEGRADED`), the rest healthy.
pub const SECOND_FAULTS: FaultVector = FaultVector([0.0, 0.3, 0.0, 0.0, 0.35, 0.0, 0.5, 0.5]);

/// Severity of the extra viscous friction the reference actuator of the second trace has and the
/// monitor model is told about (`viscous.conf`), so the model's effect terms run on both sides.
pub const SECOND_VISCOUS: f64 = 0.5;

/// Seed of the reference model's sensor noise for the second trace.
pub const SECOND_SEED: u64 = 2;

/// Sample rate the second trace's header declares (its frames are at 10 kHz): a mislabelled
/// recording, which the monitor identifies but reports `INCONCLUSIVE (rate mismatch)`.
pub const SECOND_DECLARED_RATE_HZ: u32 = 8_000;

/// The model configuration of the second trace (`EMA_MODEL_CONFIG` on board, `--model-config` on
/// the host).
pub const SECOND_MODEL_CONFIG: &str =
    "# ema-monitor model configuration of traces/parity/backlash-short-viscous-8khz.ematrace\n\
     # lines: effect ID SEVERITY\n\
     effect viscous 0.5\n";

/// The stuck-channel trace: the first [`STUCK_FRAMES`] frames of the built-in recording, phase B
/// frozen at its code of frame [`STUCK_FROM`] for [`STUCK_LEN`] frames (in the step transient,
/// while the other phases carry up to 15 A).
pub const STUCK_FRAMES: usize = 1200;
/// First frozen frame of phase B.
pub const STUCK_FROM: usize = 150;
/// Frames phase B stays frozen.
pub const STUCK_LEN: usize = 400;

/// Frames of the too-short trace: 100 (10 ms, 25 window samples, fewer than
/// `conditioning::MIN_SAMPLES`).
pub const SHORT_FRAMES: usize = 100;

/// Frames of the bad-padding trace: 101, an odd number of codes, so the last 3-byte pair holds one
/// code and a padding nibble, set to 1 here, the checksum written again over the change so that
/// the padding check is what refuses it.
pub const PADDING_FRAMES: usize = 101;

/// Frames of the bad-checksum trace: the first 100 of the built-in recording, the bit
/// [`CHECKSUM_FLIP_BIT`] of byte [`CHECKSUM_FLIP_AT`] flipped after packing (a code in the step
/// transient: without the checksum, another current that still decodes).
pub const CHECKSUM_FRAMES: usize = 100;
/// The byte of the bad-checksum trace whose bit is flipped: one of the codes' bytes.
pub const CHECKSUM_FLIP_AT: usize = 100;
/// The bit flipped there.
pub const CHECKSUM_FLIP_BIT: u8 = 3;

/// The files of the parity set, in the order [`parity_traces`] returns them.
pub const PARITY_FILES: [&str; 6] = [
    "backlash-short-viscous-8khz.ematrace",
    "viscous.conf",
    "stuck-phase-b.ematrace",
    "too-short.ematrace",
    "bad-padding.ematrace",
    "bad-checksum.ematrace",
];

/// One file of the parity set.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParityFile {
    /// File name in `traces/parity/`.
    pub name: &'static str,
    /// Its content.
    pub bytes: Vec<u8>,
}

/// The ADC codes the reference model records under `config`.
fn recorded_codes(config: &SimConfig) -> Result<Vec<[u16; 3]>, CliError> {
    let recording = simulate(config).map_err(|e| CliError::Simulation(e.to_string()))?;
    Ok(recording.samples.iter().map(|s| s.adc_counts).collect())
}

/// `frames` packed with a header declaring `rate_hz`.
fn packed(frames: &[[u16; 3]], rate_hz: u32) -> Result<Vec<u8>, CliError> {
    let mut bytes = vec![0u8; packed_len(frames.len())];
    let n = pack(frames, rate_hz, &mut bytes)
        .map_err(|e| CliError::Simulation(format!("the recording cannot be packed: {e}")))?;
    bytes.truncate(n);
    Ok(bytes)
}

/// Builds every file of the parity set (traces and the second trace's model configuration).
pub fn parity_traces() -> Result<Vec<ParityFile>, CliError> {
    let mut effects = Effects::NONE;
    effects.set(Effect::Viscous, SECOND_VISCOUS).map_err(|e| CliError::Simulation(e.to_string()))?;
    let second = SimConfig { faults: SECOND_FAULTS, effects, seed: SECOND_SEED, ..firmware_trace_config() };
    let second = packed(&recorded_codes(&second)?, SECOND_DECLARED_RATE_HZ)?;

    let standard = recorded_codes(&firmware_trace_config())?;
    let mut stuck = standard[..STUCK_FRAMES].to_vec();
    let frozen = stuck[STUCK_FROM][1];
    for frame in &mut stuck[STUCK_FROM..STUCK_FROM + STUCK_LEN] {
        frame[1] = frozen;
    }
    let stuck = packed(&stuck, SAMPLE_RATE_HZ)?;
    let short = packed(&standard[..SHORT_FRAMES], SAMPLE_RATE_HZ)?;
    let mut padding = packed(&standard[..PADDING_FRAMES], SAMPLE_RATE_HZ)?;
    // the last byte before the checksum holds the padding's high byte
    let last_code_byte = padding.len() - CHECKSUM_LEN - 1;
    padding[last_code_byte] |= 1;
    reseal(&mut padding).map_err(|e| CliError::Simulation(format!("the padding trace cannot be resealed: {e}")))?;
    let mut checksum = packed(&standard[..CHECKSUM_FRAMES], SAMPLE_RATE_HZ)?;
    checksum[CHECKSUM_FLIP_AT] ^= 1 << CHECKSUM_FLIP_BIT;

    let contents = [second, SECOND_MODEL_CONFIG.as_bytes().to_vec(), stuck, short, padding, checksum];
    Ok(PARITY_FILES.into_iter().zip(contents).map(|(name, bytes)| ParityFile { name, bytes }).collect())
}
