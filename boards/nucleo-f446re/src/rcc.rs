//! The reset and clock control (RCC; RM0390, "Reset and clock control"): the cause of the last
//! reset, and the system clock at 180 MHz from the ST-LINK's 8 MHz when it runs, from the
//! internal 16 MHz oscillator when it does not.
//!
//! **Why probe the HSE first.** stm32f4xx-hal's `freeze` sets HSEON and then waits for HSERDY
//! with no bound: a board whose ST-LINK gives no MCO (solder bridges changed, the ST-LINK part
//! cut off, its firmware not driving MCO yet) would hang there until the watchdog resets it, and
//! again after every reset. [`freeze`] turns the HSE on in bypass itself, waits a bounded time for
//! HSERDY, and hands the HAL the HSE only when it is ready (the HAL's own wait then ends at once),
//! the HSI otherwise.

use stm32f4xx_hal::pac::RCC;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::{Config, Rcc};

use crate::watchdog::Watchdog;

/// The core clock the firmware runs at (either source): 180 MHz, APB1 45 MHz, APB2 90 MHz.
pub const SYSCLK_HZ: u32 = 180_000_000;

/// The ST-LINK's MCO, the HSE input in bypass mode: 8 MHz.
const HSE_HZ: u32 = 8_000_000;

/// Polls of RCC_CR.HSERDY, each after [`HSE_POLL_CYCLES`]: at least 100 ms on the 16 MHz HSI
/// the core runs from after a reset. An external clock sets HSERDY six of its cycles after
/// HSEON (under 1 µs); the wait also covers an ST-LINK whose own start-up outlasts the target's.
const HSE_POLLS: u32 = 100;

/// Core cycles between two polls of HSERDY: 1 ms at 16 MHz.
const HSE_POLL_CYCLES: u32 = 16_000;

/// Which oscillator the PLL runs from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum ClockSource {
    /// The HSE input in bypass mode: the ST-LINK's 8 MHz MCO, from its crystal.
    Hse,
    /// The internal 16 MHz RC oscillator: ±1 % at 25 °C (factory trimmed), a few % over the
    /// temperature range (datasheet, HSI accuracy), which the frame rate then inherits.
    Hsi,
}

impl ClockSource {
    /// Lower-case name, as the report line gives it: `hse`, `hsi`.
    pub const fn name(self) -> &'static str {
        match self {
            ClockSource::Hse => "hse",
            ClockSource::Hsi => "hsi",
        }
    }
}

/// `true` when the last reset came from the independent watchdog (RCC_CSR.WDGRSTF); the reset
/// flags are then cleared (RMVF) so that the next start reads its own.
pub fn reset_by_watchdog(rcc: &RCC) -> bool {
    let watchdog = rcc.csr().read().wdgrstf().bit_is_set();
    rcc.csr().modify(|_, w| w.rmvf().set_bit());
    watchdog
}

/// The clocks: 180 MHz through the PLL from the HSE in bypass when it starts within
/// [`HSE_POLLS`] ms, from the HSI otherwise (logged either way); APB1 45 MHz, APB2 90 MHz. The
/// watchdog is fed while the HSE is awaited.
pub fn freeze(rcc: RCC, watchdog: &Watchdog) -> (Rcc, ClockSource) {
    let source = if hse_bypass_ready(&rcc, watchdog) { ClockSource::Hse } else { ClockSource::Hsi };
    let config = match source {
        ClockSource::Hse => Config::hse(HSE_HZ.Hz()).bypass_hse_oscillator(),
        ClockSource::Hsi => Config::hsi(),
    };
    let rcc = rcc.freeze(config.sysclk(SYSCLK_HZ.Hz()).pclk1(45.MHz()).pclk2(90.MHz()));
    match source {
        ClockSource::Hse => defmt::info!("clocks: HSE 8 MHz in bypass (ST-LINK MCO) -> PLL"),
        ClockSource::Hsi => defmt::warn!(
            "clocks: no HSE within {=u32} ms: HSI 16 MHz -> PLL (frame rate as accurate as the HSI, about 1 %)",
            HSE_POLLS
        ),
    }
    defmt::info!(
        "clocks: sysclk {=u32} Hz, pclk1 {=u32} Hz, pclk2 {=u32} Hz",
        rcc.clocks.sysclk().raw(),
        rcc.clocks.pclk1().raw(),
        rcc.clocks.pclk2().raw()
    );
    (rcc, source)
}

/// Turns the HSE on in bypass mode and waits, bounded, for HSERDY (RM0390, RCC_CR: HSEBYP is
/// written only while HSEON is clear). `false` leaves HSEON and HSEBYP clear, as after a reset.
fn hse_bypass_ready(rcc: &RCC, watchdog: &Watchdog) -> bool {
    rcc.cr().modify(|_, w| w.hseon().off());
    rcc.cr().modify(|_, w| w.hsebyp().bypassed());
    rcc.cr().modify(|_, w| w.hseon().on());
    for _ in 0..HSE_POLLS {
        if rcc.cr().read().hserdy().is_ready() {
            return true;
        }
        watchdog.feed();
        cortex_m::asm::delay(HSE_POLL_CYCLES);
    }
    rcc.cr().modify(|_, w| w.hseon().off());
    rcc.cr().modify(|_, w| w.hsebyp().not_bypassed());
    false
}
