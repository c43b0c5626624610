//! ema-monitor firmware (Cortex-M4F, `thumbv7em-none-eabihf`; QEMU `mps2-an386` via `cargo run --release`).
//!
//! Wiring only, no math. Numbered steps:
//! 1. paint the stack (for the peak-stack figure at the end). With the command-line word
//!    `--maintenance` (`cargo run --release -- --maintenance`; QEMU
//!    passes it through semihosting's `SYS_GET_CMDLINE`, [`maintenance_requested`]) the health
//!    record's flash is erased before flight 1 and the log says `maintenance: health record reset`
//!    ([`maintenance_reset`]); without it nothing is erased and nothing more is logged;
//! 2. open the built-in phase-current trace (`traces/standard.ematrace`, or `EMA_TRACE` at build
//!    time: a recording of the standard manoeuvre, packed 12-bit, in flash; with `EMA_PROFILE=pbit`
//!    the pre-flight built-in test `Profile::PBIT` and `traces/pbit.ematrace`), put a `ReplayAdc`
//!    behind the embedded-hal 0.2 `OneShot` reader and arm a [`Sampler`] over it: TIMER0
//!    interrupts every 100 µs and its handler reads one frame into the sampler's queue
//!    (`qemu_live`), from the trigger (the first tick: the recording starts at the command's
//!    onset) for the manoeuvre's frame count, 8500;
//! 3. acquire and condition those frames in thread mode ([`monitor::acquire`], sleeping with
//!    `wfi` between frames): a refused frame is held at the last good one and counted; too many
//!    make the report `SENSOR_FAULT`, a declared sample rate other than the control rate makes it
//!    `INCONCLUSIVE (rate mismatch)`; a sampler overrun or a missing trigger stops the firmware;
//! 4. flight 1: identify the faults **cold** with the on-board PSO and the model effects of
//!    `EMA_MODEL_CONFIG` (none by default; logged first), between the instruction-count markers
//!    [`ema_identification_start`] and [`ema_identification_end`] (`scripts/qemu-run` counts the
//!    instructions between them, `identification (cold): N instructions`), and log its health
//!    report with the uncertainty of the reported vector (its 1σ and detectable-below severities,
//!    computed outside the counted region), the fault vector's bits and the one-line summary of
//!    the host/target parity check ([`log_summary`]);
//! 5. add flight 1 to the health record (`ema_monitor::persist`) through the evidence pooled over
//!    flights (`monitor::evidence::record_flight_on`: the flight's per-mode log-likelihood ratios
//!    join the record's sums, and a mode they declare while the report dropped it is refitted
//!    in and logged as `pooled evidence: …`), and save it to flash (RAM in
//!    QEMU, [`RecordFlash`]), read it back as the next power-up does, and plan flight 2 from it
//!    (`monitor::plan_start`): **warm** from the record's diagnosis unless a cold identification
//!    is due, on the same recording, between a second pair of markers
//!    (`identification (warm): N instructions`); log its report and what the warm stages did
//!    (probes fired, evaluations) with its uncertainty, and add it to the record;
//! 6. log static RAM and peak stack over defmt, then exit through semihosting: status 0 when the
//!    monitor gives a report (a diagnosis, or an honest `INCONCLUSIVE` / `SENSOR_FAULT`), 1 when it
//!    refuses the trace (a malformed packed trace, too few frames: [`log_refusal`] logs the summary
//!    `summary: REFUSED <stage> <error>` first); a panic or fault also exits with 1, see
//!    [`HardFault`].
#![no_std]
#![no_main]

use cortex_m as _; // links cortex-m's critical-section implementation, which defmt needs
use defmt_semihosting as _; // global defmt logger over semihosting stdout
use panic_probe as _; // panic → defmt message → `udf` → HardFault → exit(1)

use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::debug;
use ema_monitor::acquisition::{manoeuvre_frames, Sampler, SamplerConfig, SAMPLER_QUEUE};
use ema_monitor::conditioning::MeasuredTrace;
use ema_monitor::health::{Abstain, HealthReport, Status};
use ema_monitor::monitor::{self, Identification, IdentifyConfig, WarmReport, ONBOARD_POPULATION, ONBOARD_WINDOW};
use ema_monitor::persist::{HealthRecord, HealthStore, RamFlash};
use ema_monitor::trace::PackedTrace;
use ema_monitor::{report_log, EmaParams, ModelEffects, Profile};

// `MODEL_EFFECTS`, `MODEL_CONFIG_SOURCE`, `PARAMS`, `PARAMS_SOURCE`, `PROFILE` and `PROFILE_NAME`
// (`EMA_PROFILE`: standard or pbit), `TRACE_SOURCE` and `TRACE`,
// written by `build.rs`: the built-in trace is `EMA_TRACE` (default `traces/standard.ematrace`,
// the reference model's recording of the standard manoeuvre, traces/README.md), the monitor
// model's effect terms come from the model configuration file `EMA_MODEL_CONFIG` (default none:
// the paper's model) and the actuator's parameters from the parameter file `EMA_PARAMS` (default
// `EmaParams::NOMINAL`).
include!(concat!(env!("OUT_DIR"), "/model_config.rs"));

/// TIMER0 and its interrupt handler: one frame of the replay per control period.
mod qemu_live;

/// Ticks the sampler waits for its trigger (100 ms); the replay triggers on the first tick.
const TRIGGER_TIMEOUT_FRAMES: u32 = 1000;

#[entry]
fn main() -> ! {
    // 1. Stack paint.
    paint_stack();
    defmt::info!("ema-monitor firmware: {=usize} bytes of built-in trace", TRACE.len());
    log_model_effects();
    // The health record's flash: erased first when maintenance is commanded.
    let Some(flash) = cortex_m::singleton!(: RecordFlash = RecordFlash::new()) else { exit(false) };
    if maintenance_requested() && !maintenance_reset(flash) {
        exit(false)
    }

    // 2. Trace → replay ADC → OneShot reader.
    let trace = match PackedTrace::parse(TRACE) {
        Ok(t) => t,
        Err(e) => {
            defmt::error!("built-in trace invalid: {}", e);
            log_refusal("trace", e);
            exit(false)
        }
    };
    defmt::info!("trace: {=usize} frames at {=u32} Hz", trace.frames(), trace.sample_rate_hz());
    let rate_ok = monitor::rate_matches(trace.sample_rate_hz() as f32, &PARAMS);
    let sampler = match cortex_m::singleton!(: Sampler<SAMPLER_QUEUE> = Sampler::new()) {
        Some(s) => s,
        None => exit(false),
    };
    // The replay starts at the command's onset: the trigger is high from the first tick.
    let frames = manoeuvre_frames(&PROFILE, &PARAMS);
    let config = SamplerConfig { frames, trigger_timeout_frames: TRIGGER_TIMEOUT_FRAMES };
    let mut live = match qemu_live::arm(sampler, trace, config, 0) {
        Ok(c) => c,
        Err(e) => {
            defmt::error!("acquisition config refused: {}", e);
            log_refusal("reader", e);
            exit(false)
        }
    };

    // 3. Acquisition (TIMER0 interrupt) and conditioning (thread mode); the timer stops before
    //    the identification, so no interrupt falls in the counted region.
    let mut trace = MeasuredTrace::<ONBOARD_WINDOW>::new();
    let acquired = monitor::acquire(&mut live, &mut trace);
    qemu_live::disarm();
    if let Err(e) = live.outcome() {
        defmt::error!("acquisition stopped: {}", e);
        log_refusal("sampler", e);
        exit(false)
    }
    let acquired = match acquired {
        Ok(summary) => summary,
        Err(e) => {
            defmt::error!("acquisition stopped: {}", e);
            log_refusal("acquisition", e);
            exit(false)
        }
    };
    defmt::info!("frames read: {=u32}, window samples: {=usize}", live.frames_read(), trace.len());
    defmt::info!(
        "refused frames: {=u32} (longest run {=u32}), held at the last good frame",
        acquired.refused,
        acquired.longest_refused_run
    );

    // 4. Flight 1: cold identification (instruction-counted region 1) and its report.
    defmt::info!("flight 1: cold identification");
    ema_identification_start();
    let report_1 = identify(&trace, None);
    ema_identification_end();
    let report_1 = match report_1 {
        Ok((r, _)) => {
            let r = with_uncertainty(&trace, r).with_acquisition(&acquired);
            let r = if rate_ok { r } else { r.abstaining(Status::Inconclusive(Abstain::RateMismatch)) };
            report_log::log_report(&r);
            Some(r)
        }
        Err(e) => {
            defmt::error!("identification refused: {}", e);
            log_refusal("identification", e);
            None
        }
    };

    // 5. The health record: flight 1 joins it and it is saved to flash, then read back as at the
    //    next power-up; flight 2 starts as the record says (warm from its diagnosis, unless a cold
    //    identification is due) and joins it too. QEMU's flash is RAM ([`RecordFlash`]).
    let stored = report_1.and_then(|r| record_flight(flash, &trace, &r, true));
    let ok = stored.is_some_and(|record| {
        let prior = record.k();
        let last_needs_cold = record.status().is_some_and(|s| matches!(s, Status::Inconclusive(_)));
        let start = monitor::plan_start(
            Some(&prior.0),
            record.flights_since_cold(),
            last_needs_cold,
            &IdentifyConfig::onboard(),
        );
        let warm = start == monitor::Start::Warm;
        if warm {
            defmt::info!("flight 2: warm start from the health record's diagnosis, on the same recording");
        } else {
            defmt::info!("flight 2: {}", start);
        }
        ema_identification_start();
        let report_2 = identify(&trace, warm.then_some(&prior.0));
        ema_identification_end();
        let report_2 = log_warm(&trace, report_2, &acquired, rate_ok);
        report_2.is_some_and(|r| record_flight(flash, &trace, &r, !warm).is_some())
    });

    // 6. Memory figures and exit.
    let ram = static_ram();
    defmt::info!(
        "static RAM: {=usize} bytes (.data {=usize} + .bss {=usize} + .uninit {=usize})",
        ram.total(),
        ram.data,
        ram.bss,
        ram.uninit
    );
    defmt::info!("peak stack: {=usize} bytes (of {=usize} available)", stack_peak(), stack_size());
    if ok {
        defmt::info!("ema-monitor: OK");
    } else {
        defmt::error!("ema-monitor: FAILED");
    }
    exit(ok)
}

/// The health record's flash in QEMU: four 2 KiB pages of RAM (`mps2-an386` has no writable
/// flash model), alive for the run, so that both flights go through the record's save and load
/// path as on a board (`docs/persistence.md`).
type RecordFlash = RamFlash<4, 2048>;

/// The semihosting command-line word that commands a maintenance reset of the health record.
const MAINTENANCE_WORD: &[u8] = b"--maintenance";

/// Bytes of the command line read ([`maintenance_requested`]); a longer line is no command.
const CMDLINE_LEN: usize = 256;

/// `true` when the semihosting command line (`SYS_GET_CMDLINE`, 0x15: the host writes the line,
/// NUL-terminated, into the buffer and its length into the block's second word) holds the word
/// [`MAINTENANCE_WORD`], words separated by spaces. A host that refuses the call, or a line
/// longer than [`CMDLINE_LEN`], is no command: the record stays.
#[inline(never)]
fn maintenance_requested() -> bool {
    let mut line = [0u8; CMDLINE_LEN];
    let mut block = [line.as_mut_ptr() as usize, CMDLINE_LEN];
    // SAFETY: SYS_GET_CMDLINE writes at most `block[1]` bytes into `line`, which lives through
    // the call, and its length into `block[1]`; both are read back volatile below, as the
    // compiler does not see the host's writes.
    let status =
        unsafe { cortex_m_semihosting::syscall1(cortex_m_semihosting::nr::GET_CMDLINE, block.as_mut_ptr() as usize) };
    if status != 0 {
        return false;
    }
    // SAFETY: `block` is a live, aligned local.
    let len = unsafe { core::ptr::read_volatile(block.as_ptr().wrapping_add(1)) };
    // SAFETY: `line` is a live local array; volatile for the host's writes.
    let line = unsafe { core::ptr::read_volatile(&line) };
    line.get(..len.min(CMDLINE_LEN)).is_some_and(|l| l.split(|&b| b == b' ' || b == 0).any(|w| w == MAINTENANCE_WORD))
}

/// Maintenance reset ([`HealthStore::reset`]): erases the health record's flash, so that flight
/// 1 finds no record and starts cold, and logs it; `false` (logged) when the flash refuses.
#[inline(never)]
fn maintenance_reset(flash: &mut RecordFlash) -> bool {
    match HealthStore::new(flash, 0..RecordFlash::CAPACITY as u32).and_then(|mut store| store.reset()) {
        Ok(()) => {
            defmt::info!("maintenance: health record reset");
            true
        }
        Err(e) => {
            defmt::error!("maintenance: health record not reset: {}", e);
            false
        }
    }
}

/// Adds a flight's report to the health record in `flash` (a fresh record when none is stored or
/// the stored one is unreadable) through the evidence pooled over flights
/// ([`monitor::evidence::record_flight_on`] on `trace`: the flight's evidence joins the record's
/// accumulators, and a mode they declare while the report dropped it is refitted in and logged),
/// saves it, and reads it back as the next power-up does; the record read back, `None` (logged)
/// when the flash refuses. Not inlined: the store's buffers stay out of `main`'s frame.
#[inline(never)]
fn record_flight(
    flash: &mut RecordFlash,
    trace: &MeasuredTrace<ONBOARD_WINDOW>,
    report: &HealthReport,
    cold: bool,
) -> Option<HealthRecord> {
    let mut store = match HealthStore::new(flash, 0..RecordFlash::CAPACITY as u32) {
        Ok(s) => s,
        Err(e) => {
            defmt::error!("health record unavailable: {}", e);
            return None;
        }
    };
    let mut record = match store.load() {
        Ok(Some(r)) => r,
        Ok(None) => HealthRecord::new(),
        Err(e) => {
            defmt::warn!("health record unreadable ({}): a new record", e);
            HealthRecord::new()
        }
    };
    let config = IdentifyConfig { effects: MODEL_EFFECTS, ..IdentifyConfig::onboard() };
    let pooled = monitor::evidence::record_flight_on(&mut record, trace, PARAMS, PROFILE, &config, report, cold);
    if let Some(p) = pooled.filter(|p| p.any_declared()) {
        log_declared(&p);
    }
    if let Err(e) = store.save(&record) {
        defmt::error!("health record not saved: {}", e);
        return None;
    }
    match store.load() {
        Ok(Some(r)) => {
            defmt::info!(
                "health record saved and read back: flight {=u32}, {=u32} since the last cold identification",
                r.flights(),
                r.flights_since_cold()
            );
            Some(r)
        }
        Ok(None) => {
            defmt::error!("health record not found after its save");
            None
        }
        Err(e) => {
            defmt::error!("health record unreadable after its save: {}", e);
            None
        }
    }
}

/// Logs each mode declared by the evidence pooled over flights (present by the accumulated
/// evidence, dropped by the flight's own model selection) with its refitted severity. Not
/// inlined: its formatting locals stay out of `main`'s frame.
#[inline(never)]
fn log_declared(pooled: &monitor::evidence::PooledFlight) {
    for (m, (&declared, mode)) in pooled.declared.iter().zip(pooled.report.modes.iter()).enumerate() {
        if declared {
            defmt::info!(
                "pooled evidence: {=str} declared after {=u32} flights (sum {=f32} nats), refitted severity {=f32}",
                monitor::evidence::mode_name(m),
                pooled.evidence.flights,
                pooled.evidence.llr.get(m).copied().unwrap_or(0.0),
                mode.severity
            );
        }
    }
}

/// Logs flight 2's report (with the acquisition's counts and the rate check, as flight 1's) and
/// what the warm stages did; the report, `None` when refused. Not inlined: its formatting locals
/// stay out of `main`'s frame.
#[inline(never)]
fn log_warm(
    trace: &MeasuredTrace<ONBOARD_WINDOW>,
    report: Result<(HealthReport, WarmReport), monitor::MonitorError>,
    acquired: &monitor::AcquisitionSummary,
    rate_ok: bool,
) -> Option<HealthReport> {
    match report {
        Ok((r, warm)) => {
            let r = with_uncertainty(trace, r).with_acquisition(acquired);
            let r = if rate_ok { r } else { r.abstaining(Status::Inconclusive(Abstain::RateMismatch)) };
            report_log::log_report(&r);
            defmt::info!(
                "warm start: probes fired {=u8:07b} (groups), {=u16} probes, {=u8} refits, {=u32} evaluations of the warm stages; cold next: {=bool}",
                warm.fired,
                warm.probes,
                warm.refits,
                warm.evaluations,
                warm.needs_cold(&r)
            );
            Some(r)
        }
        Err(e) => {
            defmt::error!("flight 2's identification refused: {}", e);
            None
        }
    }
}

/// Logs where the trace and the model effects come from when they are not the defaults, then the
/// effects that are on (`model effects: none` for the paper's model). Not inlined, so that its
/// formatting locals stay out of `main`'s frame, which lies below the identification's.
#[inline(never)]
fn log_model_effects() {
    if PROFILE_NAME != "standard" {
        defmt::info!("profile: {=str}", PROFILE_NAME);
    }
    if TRACE_SOURCE != "traces/standard.ematrace" {
        defmt::info!("trace file: {=str}", TRACE_SOURCE);
    }
    if !MODEL_CONFIG_SOURCE.is_empty() {
        defmt::info!("model config: {=str}", MODEL_CONFIG_SOURCE);
    }
    if !PARAMS_SOURCE.is_empty() {
        defmt::info!("actuator parameters: {=str}", PARAMS_SOURCE);
    }
    if MODEL_EFFECTS.is_none() {
        defmt::info!("model effects: none");
    }
    for (effect, severity) in MODEL_EFFECTS.active() {
        defmt::info!("model effect {=str} {=f32}", effect.id(), severity);
    }
}

/// The on-board identification: monitor model (with [`MODEL_EFFECTS`]) + PSO
/// (`IdentifyConfig::onboard`), run to its end; cold without a prior, warm from `prior` (flight
/// 1's fault vector: model selection, the polish, the new-fault probes and, when one fires, the
/// targeted refit, [`Identification::warm`]). One function for both flights: the identification's
/// constructor has one caller and is built in place, in this frame.
#[inline(never)]
fn identify(
    trace: &MeasuredTrace<ONBOARD_WINDOW>,
    prior: Option<&[f32; 8]>,
) -> Result<(HealthReport, WarmReport), monitor::MonitorError> {
    let config = IdentifyConfig { effects: MODEL_EFFECTS, prior: prior.copied(), ..IdentifyConfig::onboard() };
    let mut id: Identification<'_, ONBOARD_WINDOW, ONBOARD_POPULATION> =
        Identification::new(trace, PARAMS, PROFILE, &config)?;
    id.run(u32::MAX);
    Ok((id.report(), id.warm_report().unwrap_or_default()))
}

/// The report with the 1σ of each parameter and the detectable-below severities
/// ([`monitor::with_uncertainty`]: 9 model runs in lockstep), after the counted region so that
/// the identification's instruction count stays the identification's.
#[inline(never)]
fn with_uncertainty(trace: &MeasuredTrace<ONBOARD_WINDOW>, report: HealthReport) -> HealthReport {
    let config = IdentifyConfig { effects: MODEL_EFFECTS, ..IdentifyConfig::onboard() };
    monitor::with_uncertainty(trace, PARAMS, PROFILE, &config, report)
}

/// Logs the summary of a refusal, `summary: REFUSED <stage> <error>`: the stage that refused the
/// trace (`trace`, `reader`, `acquisition`, `identification`) and the core's error as its
/// `defmt::Format` writes it (the variant, e.g. `Padding` or `Conditioning(TooShort)`, the same
/// text as the host's `Debug`), for `scripts/parity`.
fn log_refusal(stage: &str, error: impl defmt::Format) {
    defmt::println!("summary: REFUSED {=str} {}", stage, error);
}

/// Start marker of the instruction-counted identification region (its address is read with `nm`).
// SAFETY: `no_mangle` exports a unique symbol name; nothing else in the image defines it.
#[inline(never)]
#[no_mangle]
pub extern "C" fn ema_identification_start() {
    // distinct bodies keep LTO from merging the two markers into one address
    core::hint::black_box(0x5354_4152_u32);
}

/// End marker of the instruction-counted identification region.
// SAFETY: as for `ema_identification_start`.
#[inline(never)]
#[no_mangle]
pub extern "C" fn ema_identification_end() {
    core::hint::black_box(0x454E_4421_u32);
}

// ---- exit and faults ---------------------------------------------------------------------------

/// Ends the QEMU run through semihosting: status 0 when `ok`, 1 otherwise.
fn exit(ok: bool) -> ! {
    debug::exit(if ok { debug::EXIT_SUCCESS } else { debug::EXIT_FAILURE });
    // not under a semihosting host (real board without debugger): park
    loop {
        cortex_m::asm::wfi();
    }
}

/// A fault (or a panic, which panic-probe ends with `udf`) must not spin forever under QEMU,
/// where the default handler would loop: exit with failure.
#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    exit(false)
}

// ---- memory figures from the linker symbols ----------------------------------------------------

/// Word painted over the free stack at start-up.
const STACK_PAINT: u32 = 0x5AC5_5AC5;

/// Bytes below the current stack pointer left unpainted (the painter's own frame and a margin).
const PAINT_MARGIN: usize = 64;

extern "C" {
    // cortex-m-rt link.x: section bounds and the stack region [_stack_end, _stack_start).
    static __sdata: u32;
    static __edata: u32;
    static __sbss: u32;
    static __ebss: u32;
    static __suninit: u32;
    static __euninit: u32;
    static _stack_end: u32;
    static _stack_start: u32;
}

/// Sizes of the statically allocated RAM sections.
struct StaticRam {
    data: usize,
    bss: usize,
    uninit: usize,
}

impl StaticRam {
    fn total(&self) -> usize {
        self.data + self.bss + self.uninit
    }
}

fn static_ram() -> StaticRam {
    // Only the addresses of the linker symbols are used (`&raw const` on an extern static is safe).
    let span = |start: *const u32, end: *const u32| (end as usize).saturating_sub(start as usize);
    StaticRam {
        data: span(&raw const __sdata, &raw const __edata),
        bss: span(&raw const __sbss, &raw const __ebss),
        uninit: span(&raw const __suninit, &raw const __euninit),
    }
}

/// Bottom (lowest address) and top of the stack region.
fn stack_bounds() -> (usize, usize) {
    (&raw const _stack_end as usize, &raw const _stack_start as usize)
}

fn stack_size() -> usize {
    let (bottom, top) = stack_bounds();
    top.saturating_sub(bottom)
}

/// Fills the unused stack, from its bottom up to just below the current stack pointer, with
/// [`STACK_PAINT`].
#[inline(never)]
fn paint_stack() {
    let (bottom, _) = stack_bounds();
    let limit = (cortex_m::register::msp::read() as usize).saturating_sub(PAINT_MARGIN) & !3;
    let mut p = bottom as *mut u32;
    while (p as usize) < limit {
        // SAFETY: `p` is word-aligned (cortex-m-rt aligns `_stack_end` to 4) and lies in
        // [_stack_end, SP − margin): RAM reserved for the stack and below every live frame; no
        // interrupt is enabled yet, so nothing else uses it. Volatile, so the writes are kept.
        unsafe { p.write_volatile(STACK_PAINT) };
        p = p.wrapping_add(1);
    }
}

/// Peak stack use: from the top of the stack down to the lowest word no longer holding the paint.
fn stack_peak() -> usize {
    let (bottom, top) = stack_bounds();
    let mut p = bottom as *const u32;
    // SAFETY: reads aligned words of the stack region [bottom, top) only; volatile because the
    // compiler cannot know the stack itself wrote them.
    while (p as usize) < top && unsafe { p.read_volatile() } == STACK_PAINT {
        p = p.wrapping_add(1);
    }
    top.saturating_sub(p as usize)
}
