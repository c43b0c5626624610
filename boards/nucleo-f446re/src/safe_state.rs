//! The watchdog and the safe state: the watchdog's start and its flight hooks (fed before each
//! objective evaluation, each evaluation timed); a refused configuration idles with the watchdog
//! fed; a panic, a fault or a lost state parks without feeding it, so that the IWDG resets the chip.
//! The registers are in `watchdog.rs`, `dbgmcu.rs` and `rcc.rs`.

use cortex_m::peripheral::DWT;
use cortex_m_rt::{exception, ExceptionFrame};
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::Start;
use ema_monitor::flight::{FlightCall, FlightHooks};
use ema_monitor::report_log;
use stm32f4xx_hal::flash::LockedFlash;
use stm32f4xx_hal::pac::{DBGMCU, IWDG, RCC};

use crate::rcc::SYSCLK_HZ;
use crate::watchdog::Watchdog;
use crate::{dbgmcu, rcc, WATCHDOG_MS};

/// Starts the independent watchdog at [`WATCHDOG_MS`], frozen while a probe halts the core (with
/// the debug connection kept through `wfi`: [`dbgmcu::keep_debug_in_low_power`]), and says when
/// the last reset came from it (the previous run ended in the safe state or hung).
pub fn start_watchdog(iwdg: IWDG, dbgmcu: &DBGMCU, rcc: &RCC) -> Watchdog {
    let watchdog = Watchdog::start(iwdg);
    dbgmcu::keep_debug_in_low_power(dbgmcu);
    match watchdog.set_timeout_ms(WATCHDOG_MS) {
        Ok(ms) => defmt::info!("ema-monitor on NUCLEO-F446RE: watchdog {=u32} ms", ms),
        Err(e) => defmt::error!("ema-monitor on NUCLEO-F446RE: watchdog timeout not set ({}), 512 ms at reset", e),
    }
    if rcc::reset_by_watchdog(rcc) {
        defmt::warn!("reset by the watchdog: the previous run ended in the safe state or hung");
    }
    watchdog
}

/// Logs `what` and its error `e`, then idles failed ([`idle_failed`]).
pub fn refused(what: &str, e: impl defmt::Format, watchdog: &Watchdog) -> ! {
    defmt::error!("{=str}: {}", what, e);
    idle_failed(watchdog)
}

/// A configuration refused at start-up: no flight can run (`ema-monitor: FAILED`), but the
/// firmware itself is sound, so it idles with the watchdog fed every 100 ms (timed by the DWT
/// cycle counter, so no timer is needed).
pub fn idle_failed(watchdog: &Watchdog) -> ! {
    defmt::error!("ema-monitor: FAILED (no health report)");
    loop {
        watchdog.feed();
        let start = DWT::cycle_count();
        while DWT::cycle_count().wrapping_sub(start) < SYSCLK_HZ / 10 {}
    }
}

/// Logs a failure that leaves the firmware's state unknown, then parks (see [`park`]).
pub fn failsafe(what: &str) -> ! {
    defmt::error!("FAILSAFE: {=str}: monitor output invalid", what);
    park()
}

/// The safe state: interrupts off, the core asleep, the watchdog no longer fed, so the IWDG
/// resets the chip within `WATCHDOG_MS`. The monitor gives no report rather than a wrong one.
fn park() -> ! {
    cortex_m::interrupt::disable();
    loop {
        cortex_m::asm::wfi();
    }
}

/// A panic (the firmware's panic-probe logs its message, then executes `udf`; `main.rs`), a stack
/// overflow (flip-link: the stack hits the bottom of RAM) or any other fault: log the status and
/// park.
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!(
        "FAILSAFE: panic or hard fault at pc {=u32:#010x}: monitor output invalid, parked until the watchdog resets",
        frame.pc()
    );
    park()
}

/// The board's flight hooks: the watchdog fed before each objective evaluation, and raised to
/// [`CALL_WATCHDOG_MS`] for each of the flight's later calls (the uncertainty, the record), fed
/// again between the record's model runs; each evaluation and call timed by the DWT cycle
/// counter (32-bit, read per step: a step or a call lasts far less than the 23.8 s wrap at
/// 180 MHz).
pub struct WatchdogHooks<'a> {
    /// The watchdog, fed before each evaluation.
    watchdog: &'a Watchdog,
    /// The flash the commissioning windows are kept in (`health_flash`).
    flash: &'a mut LockedFlash,
    /// DWT count at the current step's start.
    step_start: u32,
    /// Cycles of the identification so far.
    total_cycles: u64,
    /// The longest step's cycles.
    longest_step_cycles: u32,
    /// The watchdog's timeout before the commissioning's fit raised it (ms).
    before_commissioning_ms: u32,
}

impl<'a> WatchdogHooks<'a> {
    /// Hooks that feed `watchdog` and keep commissioning windows in `flash`, with no cycles
    /// counted yet.
    pub fn new(watchdog: &'a Watchdog, flash: &'a mut LockedFlash) -> Self {
        let before_commissioning_ms = watchdog.timeout_ms();
        Self { watchdog, flash, step_start: 0, total_cycles: 0, longest_step_cycles: 0, before_commissioning_ms }
    }
}

impl FlightHooks for WatchdogHooks<'_> {
    fn identification_start(&mut self, flight: u32, start: Start) {
        report_log::log_start(flight, start);
    }

    fn before_step(&mut self) {
        self.watchdog.feed();
        self.step_start = DWT::cycle_count();
    }

    fn after_step(&mut self) {
        let cycles = DWT::cycle_count().wrapping_sub(self.step_start);
        self.total_cycles += u64::from(cycles);
        self.longest_step_cycles = self.longest_step_cycles.max(cycles);
    }

    fn identification_end(&mut self) {
        defmt::info!(
            "identification: {=u64} cycles ({=u32} ms at {=u32} Hz), longest step {=u32} cycles (watchdog {=u32} ms)",
            self.total_cycles,
            (self.total_cycles / u64::from(SYSCLK_HZ / 1000)) as u32,
            SYSCLK_HZ,
            self.longest_step_cycles,
            self.watchdog.timeout_ms()
        );
    }

    fn before_call(&mut self, call: FlightCall) {
        if let Err(e) = self.watchdog.set_timeout_ms(CALL_WATCHDOG_MS) {
            defmt::error!("{}: watchdog not raised ({})", call, e);
        }
        self.step_start = DWT::cycle_count();
    }

    fn between_runs(&mut self, _call: FlightCall) {
        self.watchdog.feed();
    }

    fn after_call(&mut self, call: FlightCall) {
        let cycles = DWT::cycle_count().wrapping_sub(self.step_start);
        defmt::info!("{}: {=u32} cycles", call, cycles);
        if let Err(e) = self.watchdog.set_timeout_ms(WATCHDOG_MS) {
            defmt::error!("{}: watchdog timeout not set back ({})", call, e);
        }
    }

    fn commissioning_start(&mut self) {
        self.before_commissioning_ms = self.watchdog.timeout_ms();
        match self.watchdog.set_timeout_ms(COMMISSIONING_WATCHDOG_MS) {
            Ok(ms) => defmt::info!("commissioning: fitting the unit's baseline (watchdog {=u32} ms)", ms),
            Err(e) => defmt::error!("commissioning: watchdog not raised for the fit ({})", e),
        }
    }

    fn commissioning_tick(&mut self) {
        self.watchdog.feed();
    }

    fn commissioning_end(&mut self) {
        if let Err(e) = self.watchdog.set_timeout_ms(self.before_commissioning_ms) {
            defmt::error!("commissioning: watchdog timeout not set back ({})", e);
        }
    }

    fn keep_window<const W: usize>(&mut self, slot: u8, window: &ConditionedWindow<W>, temperature_c: f32) -> bool {
        crate::health_flash::keep_window(self.flash, self.watchdog, slot, window, temperature_c)
    }

    fn load_window<const W: usize>(&mut self, slot: u8, out: &mut ConditionedWindow<W>) -> Option<f32> {
        crate::health_flash::load_window(self.flash, self.watchdog, slot, out)
    }
}

/// Watchdog timeout during each of a flight's later calls ([`FlightCall`]). The uncertainty runs
/// without a feed inside: one lockstep pass of 9 models, 4.7e7 instructions in the QEMU build,
/// 5.6e7 at this crate's `opt-level = "s"`, 0.8 s at 2.5 cycles per instruction and 180 MHz. The
/// record is fed between its model runs (`between_runs`; a run is at most 1.2e7 instructions at
/// `"s"`, 0.17 s), however many its evidence and refits take (up to 2.6e8 instructions in all
/// on a recording of `scripts/results-step-lengths`). 4 s leaves a margin near 5 over the
/// uncertainty, and above 3 at the LSI's fastest (docs/board.md, "Watchdog timeout").
const CALL_WATCHDOG_MS: u32 = 4_000;

/// Watchdog timeout during the commissioning's baseline fit: the longest stretch between two
/// feeds is one flight's lockstep run of 12 models, about 1.4e8 instructions at `opt-level =
/// "s"`, 1.3 s at 1.6 cycles per instruction; 8 s leaves a margin above 6, and above 4 at the
/// LSI's fastest.
const COMMISSIONING_WATCHDOG_MS: u32 = 8_000;
