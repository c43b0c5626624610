//! The firmware's path on a packed trace (`ema identify --firmware-trace`), step for step as
//! `src/main.rs` runs it: its two flights through the core's [`HealthMonitor`] on the health
//! record it keeps in flash, and the one-line summary the firmware logs for each, which
//! `scripts/parity` compares with the firmware's in QEMU.

use std::fmt::{Debug, Display};
use std::fs::File;
use std::path::Path;

use ema_monitor::acquisition::{
    replay_config, AcquisitionError, Calibration, PhaseA, PhaseB, PhaseC, PhaseCurrentReader, PhaseCurrents, ReplayAdc,
};
use ema_monitor::conditioning::{ConditionedWindow, DECIMATION};
use ema_monitor::diagnosis::{self, IdentifyConfig, ONBOARD_POPULATION, ONBOARD_WINDOW};
use ema_monitor::flight::HealthMonitor;
use ema_monitor::health::{Abstain, HealthReport, Status};
use ema_monitor::persist::{HealthStore, KeptRecord, RamFlash, StoreError};
use ema_monitor::trace::{PackedTrace, TraceHeader};
use ema_monitor::{Command, EmaParams, Profile};

use super::flight::HostHooks;
use super::identification::{run_identification, Outcome, WarmStart};
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

/// Flights the firmware flies on its trace (`src/main.rs`): a cold one, then one planned from the
/// health record the first left (warm from its diagnosis).
pub const FIRMWARE_FLIGHTS: usize = 2;

/// The health record's flash of the QEMU firmware (`src/record_flash.rs`, `RecordFlash`).
type RecordFlash = RamFlash<8, 4096>;

/// The firmware's path on the bytes of a packed trace, step for step as `src/main.rs`: parse,
/// replay ADC and `OneShot` reader (nominal calibration, default checks), the frames before the
/// trace's trigger frame read and dropped (as the firmware's sampler drops them while it waits
/// for the trigger), the acquisition into the on-board window, then its first flight
/// ([`firmware_trace_flights_for`]) under `config` (the firmware's is `IdentifyConfig::onboard()`
/// with its model effects) of the actuator `params` (the firmware's are `EMA_PARAMS`'): the
/// acquisition's verdict, and `INCONCLUSIVE (rate mismatch)` when the header's rate is not
/// 10 kHz. With a prior in `config` (`--prior`, which the firmware never has), one identification
/// warm from it on the same window instead, with no health record. A step that refuses the trace
/// gives the [`Refusal`] the firmware logs.
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
    if config.prior.is_none() {
        return Ok(firmware_trace_flights_for(bytes, params, profile, config, 1)?.first);
    }
    let (packed, mut reader) = replay(bytes)?;
    let rate_ok = diagnosis::rate_matches(packed.sample_rate_hz() as f32, params);
    let mut trace = Box::new(ConditionedWindow::<ONBOARD_WINDOW>::new());
    let acquired = diagnosis::acquire(&mut reader, &mut trace).map_err(|e| Refusal::new("acquisition", e))?;
    let outcome = run_identification(&trace, params, Command::Profile(profile), config)
        .map_err(|e| Refusal::new("identification", e))?;
    let report = outcome.report.with_acquisition(&acquired);
    let report = if rate_ok { report } else { report.abstaining(Status::Inconclusive(Abstain::RateMismatch)) };
    Ok(Outcome { report, sensors: acquired.sensors, ..outcome })
}

/// The firmware's flights on one packed trace ([`firmware_trace_flights_for`]).
#[derive(Clone, Debug)]
pub struct FirmwareFlights {
    /// The first flight: cold, on a new health record.
    pub first: Outcome,
    /// The flights after it, each planned from the record the one before left.
    pub later: Vec<Outcome>,
}

/// The firmware's `flights` flights (at least one) on the bytes of a packed trace, step for step as
/// `src/main.rs` flies them: the monitor ([`HealthMonitor`] of `params`, driven by `profile`,
/// identified under `config`), the trace acquired once as [`firmware_trace_outcome`] reads it, then
/// each flight on that window through [`HealthMonitor::diagnose_kept`] on the record loaded from
/// the QEMU firmware's flash (a new one before the first flight), the record saved to that flash
/// and read back after it, as the next power-up reads it. The identifications' sweeps run in
/// parallel ([`HostHooks`]), bit for bit the firmware's. One [`Outcome`] per flight; a step that
/// refuses the trace gives the [`Refusal`] the firmware logs (a flash that refuses the record,
/// which the firmware logs without a summary, is refused at stage `record`).
pub fn firmware_trace_flights_for(
    bytes: &[u8],
    params: &EmaParams,
    profile: &Profile,
    config: &IdentifyConfig,
    flights: usize,
) -> Result<FirmwareFlights, Refusal> {
    let monitor = HealthMonitor::<ONBOARD_WINDOW, ONBOARD_POPULATION>::new(*params, profile, *config)
        .map_err(|e| Refusal::new("identification", e))?;
    let (packed, mut reader) = replay(bytes)?;
    let mut trace = Box::new(ConditionedWindow::<ONBOARD_WINDOW>::new());
    let acquired = monitor
        .acquire(&mut reader, &mut trace, packed.sample_rate_hz() as f32)
        .map_err(|e| Refusal::new("acquisition", e))?;
    let mut flash = Box::new(RecordFlash::new());
    let store_refused = |e: StoreError| Refusal {
        stage: "record",
        error: format!("{e:?}"),
        message: format!("the health record's store refused: {e:?}"),
    };
    let mut fly = || {
        let mut store = HealthStore::new(&mut *flash, 0..RecordFlash::CAPACITY as u32).map_err(store_refused)?;
        let mut kept = KeptRecord::from_load(store.load());
        if let Some(old) = monitor.adopt(kept.record_mut()) {
            store.archive(&old).map_err(store_refused)?;
        }
        let prior = kept.record().faults().0;
        let mut hooks = HostHooks::default();
        let flight = monitor
            .diagnose_kept(&trace, &acquired, &mut kept, &mut hooks)
            .map_err(|e| Refusal::new("identification", e))?;
        let Some(record) = kept.savable() else {
            let message = format!("the health record is not saved ({:?})", kept.origin());
            return Err(Refusal { stage: "record", error: "NotSaved".to_owned(), message });
        };
        store.save(record).map_err(store_refused)?;
        Ok(Outcome {
            report: flight.report,
            seconds: hooks.seconds(),
            warm: flight.warm.map(|report| WarmStart { prior, report }),
            unit_check: None,
            sensors: flight.sensors,
            position: None,
        })
    };
    let first = fly()?;
    let later = (1..flights).map(|_| fly()).collect::<Result<Vec<_>, _>>()?;
    Ok(FirmwareFlights { first, later })
}

/// The firmware's replay reader on a packed trace.
type Replay<'t> = PhaseCurrentReader<ReplayAdc<'t>, PhaseA, PhaseB, PhaseC>;

/// The packed trace in `bytes` (refused at stage `trace`) and its replay as the firmware's
/// sampler reads it: replay ADC and `OneShot` reader (nominal calibration, default checks;
/// refused at stage `reader`), the frames before the trigger frame read as the zero points' rest,
/// and the reader started on the recording.
fn replay(bytes: &[u8]) -> Result<(PackedTrace<'_>, Replay<'_>), Refusal> {
    let packed = PackedTrace::parse(bytes).map_err(|e| Refusal::new("trace", e))?;
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
    Ok((packed, reader))
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
