//! The firmware's path on a packed trace (`ema identify --firmware-trace`), step for step as
//! `src/main.rs` runs it, and the one-line summary the firmware logs, which `scripts/parity`
//! compares with the firmware's in QEMU.

use std::fmt::{Debug, Display};
use std::fs::File;
use std::path::Path;

use ema_monitor::acquisition::{
    replay_config, AcquisitionError, Calibration, PhaseA, PhaseB, PhaseC, PhaseCurrentReader, PhaseCurrents, ReplayAdc,
};
use ema_monitor::conditioning::{ConditionedWindow, DECIMATION};
use ema_monitor::health::{Abstain, HealthReport, Status};
use ema_monitor::monitor::{self, IdentifyConfig, ONBOARD_WINDOW};
use ema_monitor::trace::{PackedTrace, TraceHeader};
use ema_monitor::{Command, EmaParams, Profile};

use super::identification::{run_identification, Outcome};
use crate::error::{CliError, Place};
use crate::input;

/// Most pre-trigger frames of a packed trace `ema firmware-trace --from` writes: 100 ms at
/// 10 kHz, half the 200 ms the firmware waits for its trigger (`TRIGGER_TIMEOUT_FRAMES` in
/// `src/main.rs`).
pub const MAX_PRE_TRIGGER_FRAMES: usize = 1000;

/// Largest packed trace the on-board window takes, in bytes: an `EMA3` header and checksum,
/// [`MAX_PRE_TRIGGER_FRAMES`], then [`ONBOARD_WINDOW`] blocks of [`DECIMATION`] frames and a
/// trailing partial block (which conditioning drops); a longer one would stop acquisition with a
/// full window anyway, so a larger file is refused unread. (An `EMA1` or `EMA2` trace of as many
/// frames is smaller.)
pub const MAX_FIRMWARE_TRACE_BYTES: usize =
    TraceHeader::new(1, 1).packed_len(MAX_PRE_TRIGGER_FRAMES + ONBOARD_WINDOW * DECIMATION + DECIMATION - 1);

/// Why the firmware's path refused a packed trace, named as the firmware names it in its summary
/// line (`src/main.rs`, `refuse`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Refusal {
    /// The step that refused: `trace` (the packed format), `reader` (the acquisition settings),
    /// `acquisition` (conditioning the frames) or `identification` (its settings or the trace).
    pub stage: &'static str,
    /// The core's error as `Debug` writes it (`Padding`, `Conditioning(TooShort)`): the text the
    /// firmware's `defmt::Format` derive writes for these field-less or nested variants.
    pub error: String,
    /// The error's message (`Display`), for the command's error line.
    pub message: String,
}

impl Refusal {
    fn new<E: Debug + Display>(stage: &'static str, e: E) -> Self {
        Self { stage, error: format!("{e:?}"), message: e.to_string() }
    }

    /// `summary: REFUSED <stage> <error>`, the firmware's summary of a refused trace.
    pub fn summary_line(&self) -> String {
        format!("summary: REFUSED {} {}", self.stage, self.error)
    }
}

/// The warning line for a packed trace that carries no checksum (`EMA1`, `EMA2`: nothing detects
/// its corruption, the core's `trace` module); `None` for an `EMA3` trace and for bytes that do
/// not parse (the refusal says why).
pub fn checksum_warning(path: &Path, bytes: &[u8]) -> Option<String> {
    let t = PackedTrace::parse(bytes).ok().filter(|t| !t.has_checksum())?;
    Some(format!(
        "warning: {}: an EMA{} packed trace carries no checksum, so a corrupted code would read as a current \
         unnoticed; `ema firmware-trace` writes EMA3, which carries one",
        Place::file(path),
        t.version()
    ))
}

/// Reads a packed trace file (`--firmware-trace`), at most [`MAX_FIRMWARE_TRACE_BYTES`].
pub fn read_firmware_trace(path: &Path) -> Result<Vec<u8>, CliError> {
    let file = File::open(path).map_err(|e| CliError::input(path, format!("cannot read: {e}")))?;
    input::read_bounded(file, MAX_FIRMWARE_TRACE_BYTES).map_err(|e| e.at(path))
}

/// The firmware's path on the bytes of a packed trace, step for step as `src/main.rs`: parse,
/// replay ADC and `OneShot` reader (nominal calibration, default checks), the frames before the
/// trace's trigger frame read and dropped (as the firmware's sampler drops them while it waits
/// for the trigger), [`monitor::acquire`] into the on-board window, the identification under `config` (the firmware's is
/// `IdentifyConfig::onboard()` with its model effects) of the actuator `params` (the firmware's
/// are `EMA_PARAMS`'), the acquisition's verdict, then
/// `INCONCLUSIVE (rate mismatch)` when the header's rate is not 10 kHz. A step that refuses the
/// trace gives the [`Refusal`] the firmware logs.
pub fn firmware_trace_outcome(bytes: &[u8], params: &EmaParams, config: &IdentifyConfig) -> Result<Outcome, Refusal> {
    firmware_trace_outcome_for(bytes, params, &Profile::STANDARD, config)
}

/// [`firmware_trace_outcome`] of a trace of the manoeuvre `profile` (the firmware's
/// `EMA_PROFILE`: [`Profile::STANDARD`] or [`Profile::PBIT`]).
pub fn firmware_trace_outcome_for(
    bytes: &[u8],
    params: &EmaParams,
    profile: &Profile,
    config: &IdentifyConfig,
) -> Result<Outcome, Refusal> {
    let packed = PackedTrace::parse(bytes).map_err(|e| Refusal::new("trace", e))?;
    let rate_ok = monitor::rate_matches(packed.sample_rate_hz() as f32, params);
    let adc = ReplayAdc::new(packed);
    let mut reader =
        PhaseCurrentReader::new(adc, (PhaseA, PhaseB, PhaseC), Calibration::NOMINAL, replay_config(&packed))
            .map_err(|e| Refusal::new("reader", e))?;
    // the frames before the trigger as the firmware's sampler reads them: the zero points' rest
    for _ in 0..packed.trigger_frame() {
        if matches!(reader.read_rest_frame(), Err(AcquisitionError::EndOfData)) {
            break;
        }
    }
    reader.start_recording();
    let mut trace = Box::new(ConditionedWindow::<ONBOARD_WINDOW>::new());
    let acquired = monitor::acquire(&mut reader, &mut trace).map_err(|e| Refusal::new("acquisition", e))?;
    let outcome = run_identification(&trace, params, Command::Profile(*profile), config)
        .map_err(|e| Refusal::new("identification", e))?;
    let report = outcome.report.with_acquisition(&acquired);
    let report = if rate_ok { report } else { report.abstaining(Status::Inconclusive(Abstain::RateMismatch)) };
    Ok(Outcome { report, sensors: acquired.sensors, ..outcome })
}

/// The fault vector's `f32` bit patterns: 8 lower-case hex words.
fn fault_bits(report: &HealthReport) -> String {
    let words: Vec<String> = report.faults.0.iter().map(|k| format!("{:08x}", k.to_bits())).collect();
    words.join(" ")
}

/// `fault vector bits: xxxxxxxx …` (8 lower-case hex words), as the firmware logs it.
pub fn bits_line(report: &HealthReport) -> String {
    format!("fault vector bits: {}", fault_bits(report))
}

/// The firmware's summary line of a report (`src/report_log.rs`, `log_summary`), which `scripts/parity`
/// compares whole: `summary: STATUS fitness F evaluations N bits K1 … K8`, `STATUS` the status
/// label with its reason in parentheses under `INCONCLUSIVE` (`INCONCLUSIVE(rate mismatch)`), `F`
/// and `K1 … K8` the `f32` bit patterns of the fitness and of the fault vector.
pub fn summary_line(report: &HealthReport) -> String {
    let status = match report.status.reason() {
        Some(reason) => format!("{}({})", report.status.label(), reason.label()),
        None => report.status.label().to_owned(),
    };
    format!(
        "summary: {status} fitness {:08x} evaluations {} bits {}",
        report.fitness.to_bits(),
        report.evaluations,
        fault_bits(report)
    )
}
