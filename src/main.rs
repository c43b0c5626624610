//! ema-monitor firmware (Cortex-M4F, `thumbv7em-none-eabihf`; QEMU `mps2-an386` via `cargo run --release`).
//!
//! Wiring only: the flight policy is the core's [`HealthMonitor`] (`src/flight/`). Steps:
//! 1. take the record's flash (`record_flash.rs`) and paint the stack; `--maintenance` on the
//!    semihosting command line erases the health record first, `--commission` erases it and
//!    commissions the unit over the two flights ([`HealthMonitor::with_commissioning`]);
//! 2. replay the built-in trace (`traces/standard.ematrace`, or `EMA_TRACE` and `EMA_PROFILE`,
//!    `build.rs`) through the replay ADC, one frame per TIMER0 interrupt (`qemu_live.rs`), into
//!    the monitor's acquisition, the trigger raised at the trace's trigger frame (the first tick
//!    for a trace without pre-trigger; after the pre-trigger frames of one with them); a trace
//!    whose `EMA3` checksum does not match is refused (`summary: REFUSED trace Checksum`);
//! 3. flight 1, then flight 2 on the same recording, each through
//!    [`HealthMonitor::diagnose_kept`] with the instruction-count markers around its
//!    identification (`insn_markers.rs`), saved to the record's flash and read back as the next
//!    power-up does (a record that did not load is not saved over);
//! 4. log static RAM and peak stack, then exit through semihosting: 0 with a report, 1 when the
//!    trace is refused (`summary: REFUSED <stage> <error>`, for `scripts/parity`) or on a panic
//!    or fault ([`HardFault`]).
#![no_std]
#![no_main]

use cortex_m as _; // links cortex-m's critical-section implementation, which defmt needs
use defmt_semihosting as _; // global defmt logger over semihosting stdout
use panic_probe as _; // panic → defmt message → `udf` → HardFault → exit(1)

use cortex_m_rt::{entry, exception, ExceptionFrame};
use ema_monitor::acquisition::{Sampler, SamplerConfig, SAMPLER_QUEUE};
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::ONBOARD_WINDOW;
use ema_monitor::flight::{Acquired, HealthMonitor};
use ema_monitor::trace::PackedTrace;
use ema_monitor::unit::Tolerances;
use ema_monitor::{report_log, EmaParams, ModelEffects, Profile};

// `MODEL_EFFECTS`, `MODEL_CONFIG_SOURCE`, `PARAMS`, `PARAMS_SOURCE`, `PROFILE`, `PROFILE_NAME`,
// `TRACE_SOURCE` and `TRACE`, written by `build.rs` from `EMA_MODEL_CONFIG`, `EMA_PARAMS`,
// `EMA_PROFILE` and `EMA_TRACE` (defaults: the paper's model, `EmaParams::NOMINAL`, the standard
// manoeuvre and its recording `traces/standard.ematrace`).
include!(concat!(env!("OUT_DIR"), "/model_config.rs"));

/// The instruction-count markers around each identification.
mod insn_markers;
/// Static RAM and peak stack from the linker symbols.
mod memory_figures;
/// TIMER0 and its interrupt handler: one frame of the replay per control period.
mod qemu_live;
/// The health record's flash (RAM in QEMU), loaded before and saved after each flight.
mod record_flash;
/// The semihosting command line and exit.
mod semihosting_host;

use insn_markers::CountedRegion;
use record_flash::{adopt_record, load_record, maintenance_reset, save_record, RecordFlash};
use semihosting_host::exit;

/// Flights of the commissioning that `--commission` starts: both flights of the run, the first
/// keeping its window, the second fitting the baseline to both and diagnosing against it.
const COMMISSIONING_FLIGHTS: u8 = 2;

/// Ticks the sampler waits for its trigger (200 ms): the replay raises it at the trace's trigger
/// frame, after at most the 100 ms of pre-trigger `ema firmware-trace --from` keeps; a trace
/// whose trigger comes later ends its acquisition with `NoTrigger`.
const TRIGGER_TIMEOUT_FRAMES: u32 = 2000;

#[entry]
fn main() -> ! {
    // 1. Stack paint; the health record's flash, erased first when maintenance is commanded.
    let Some(flash) = record_flash::take() else { exit(false) };
    memory_figures::paint_stack();
    defmt::info!("ema-monitor firmware: {=usize} bytes of built-in trace", TRACE.len());
    log_model_effects();
    let commission = semihosting_host::word_given(semihosting_host::COMMISSION_WORD);
    if (commission || semihosting_host::word_given(semihosting_host::MAINTENANCE_WORD)) && !maintenance_reset(flash) {
        exit(false)
    }
    let monitor = HealthMonitor::onboard(PARAMS, &PROFILE, MODEL_EFFECTS).and_then(|m| match commission {
        true => m.with_commissioning(COMMISSIONING_FLIGHTS, Tolerances::TYPICAL),
        false => Ok(m),
    });
    let monitor = monitor.unwrap_or_else(|e| refuse("identification", e));

    // 2. Trace → replay ADC → sampler (TIMER0 interrupt) → acquisition (thread mode).
    let trace = match PackedTrace::parse(TRACE) {
        Ok(t) => t,
        Err(e) => refuse("trace", e),
    };
    defmt::info!("trace: {=usize} frames at {=u32} Hz", trace.frames(), trace.sample_rate_hz());
    if trace.trigger_frame() > 0 {
        defmt::info!("trigger at frame {=u32}", trace.trigger_frame());
    }
    let Some(sampler) = cortex_m::singleton!(: Sampler<SAMPLER_QUEUE> = Sampler::new()) else { exit(false) };
    let config = SamplerConfig { frames: monitor.frames(), trigger_timeout_frames: TRIGGER_TIMEOUT_FRAMES };
    let mut live = match qemu_live::arm(sampler, trace, config, trace.trigger_frame()) {
        Ok(c) => c,
        Err(e) => refuse("reader", e),
    };
    let mut window = ConditionedWindow::<ONBOARD_WINDOW>::new();
    let acquired = monitor.acquire(&mut live, &mut window, trace.sample_rate_hz() as f32);
    qemu_live::disarm(); // no interrupt falls in the instruction-counted regions
    if let Err(e) = live.outcome() {
        refuse("sampler", e)
    }
    let acquired = match acquired {
        Ok(a) => a,
        Err(e) => refuse("acquisition", e),
    };
    defmt::info!("frames read: {=u32}, window samples: {=usize}", live.frames_read(), window.len());
    defmt::info!(
        "refused frames: {=u32} (longest run {=u32}), held at the last good frame",
        acquired.summary.refused,
        acquired.summary.longest_refused_run
    );

    // 3. Two flights on the same recording: cold, then warm from the record flight 1 left.
    let ok = fly(&monitor, &window, &acquired, flash) && fly(&monitor, &window, &acquired, flash);

    // 4. Memory figures and exit.
    let ram = memory_figures::static_ram();
    defmt::info!(
        "static RAM: {=usize} bytes (.data {=usize} + .bss {=usize} + .uninit {=usize})",
        ram.total(),
        ram.data,
        ram.bss,
        ram.uninit
    );
    let (peak, size) = (memory_figures::stack_peak(), memory_figures::stack_size());
    defmt::info!("peak stack: {=usize} bytes (of {=usize} available)", peak, size);
    if ok {
        defmt::info!("ema-monitor: OK");
    } else {
        defmt::error!("ema-monitor: FAILED");
    }
    exit(ok)
}

/// One flight: the record loaded from `flash` (a new one when none is stored; a record of other
/// parameters archived and a new one started, [`HealthMonitor::adopt`]), the flight diagnosed
/// and logged ([`HealthMonitor::diagnose_kept`]), the record saved and read back. After a failed
/// load the flight runs cold and nothing is saved, so that the stored record stays for the next
/// load (`ema_monitor::persist::kept`). `false` (logged) when the identification or the flash
/// refuses, or the save is withheld.
#[inline(never)]
fn fly(
    monitor: &HealthMonitor<'_>,
    window: &ConditionedWindow<ONBOARD_WINDOW>,
    acquired: &Acquired,
    flash: &mut RecordFlash,
) -> bool {
    let Some(mut kept) = load_record(flash) else { return false };
    if !adopt_record(monitor, &mut kept, flash) {
        return false;
    }
    match monitor.diagnose_kept(window, acquired, &mut kept, &mut CountedRegion { flash: &mut *flash }) {
        Ok(flight) => report_log::log_flight(&flight),
        Err(e) => refuse("identification", e),
    }
    save_record(flash, &kept)
}

/// Logs where the trace, the parameters and the model effects come from when they are not the
/// defaults, then the effects that are on (`model effects: none` for the paper's model).
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

/// Logs the refusal of the trace by `stage` (`trace`, `reader`, `sampler`, `acquisition`,
/// `identification`) as `summary: REFUSED <stage> <error>` (`scripts/parity` compares it with the
/// host's), then exits with failure.
fn refuse(stage: &str, error: impl defmt::Format) -> ! {
    defmt::error!("{=str} refused: {}", stage, error);
    defmt::println!("summary: REFUSED {=str} {}", stage, error);
    exit(false)
}

/// A fault (or a panic, which panic-probe ends with `udf`) must not spin forever under QEMU,
/// where the default handler would loop: exit with failure.
#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    exit(false)
}
