//! The flash interface's own registers (RM0390, "Embedded flash memory interface"): the data
//! cache flushed after an erase (FLASH_ACR), and the brown-out reset level in the user option
//! bytes (FLASH_OPTCR). The erases and writes themselves go through stm32f4xx-hal's
//! `UnlockedFlash` (`health_flash.rs`).

use cortex_m::peripheral::DWT;
use stm32f4xx_hal::pac::FLASH;

use crate::rcc::SYSCLK_HZ;
use crate::watchdog::Watchdog;

/// Flushes the flash interface's data cache: DCEN cleared, DCRST set then cleared, DCEN set
/// again (FLASH_ACR; DCRST is written only while the cache is off). The data cache keeps the
/// last 128-bit lines read through the D-Code bus and is not told of an erase: after one, a
/// read of the erased page could return its old bytes from a line kept from before. The
/// instruction cache needs no flush: it holds lines fetched as instructions, and the record's
/// sectors 6–7 hold no code (`memory.x` keeps the program in sectors 0–5), so it never holds one
/// of theirs. (ST's own HAL flushes both after an erase because it may erase code.)
///
/// Called between flash operations in thread mode, after the HAL's erase has returned (it waits
/// for FLASH_SR.BSY to clear).
pub fn flush_data_cache() {
    // SAFETY: FLASH_ACR alone is touched, in thread mode and between flash operations; the HAL's
    // `UnlockedFlash`, which owns the peripheral meanwhile, uses KEYR, CR and SR only, and no
    // interrupt handler touches the flash interface. Reading and writing ACR has no side effect
    // beyond the cache bits changed here (the latency, prefetch and instruction-cache bits are
    // written back as read).
    let flash = unsafe { &*FLASH::ptr() };
    let enabled = flash.acr().read().dcen().is_enabled();
    flash.acr().modify(|_, w| w.dcen().disabled());
    flash.acr().modify(|_, w| w.dcrst().reset());
    flash.acr().modify(|_, w| w.dcrst().no_reset());
    if enabled {
        flash.acr().modify(|_, w| w.dcen().enabled());
    }
}

/// FLASH_OPTCR.BOR_LEV (bits 3:2): `00` is BOR level 3, `01` level 2, `10` level 1, `11` off
/// (RM0390, FLASH_OPTCR; ST's `OB_BOR_LEVEL3` = 0x00, `OB_BOR_OFF` = 0x0C). The PAC's
/// enumeration of this field (stm32f4 0.16, `BOR_LEV`) names the values the other way round,
/// so the field is read and written as bits here.
const BOR_LEV_SHIFT: u32 = 2;

/// BOR_LEV's mask in FLASH_OPTCR.
const BOR_LEV_MASK: u32 = 0b11 << BOR_LEV_SHIFT;

/// BOR_LEV for level 3.
const BOR_LEVEL3: u32 = 0b00;

/// FLASH_SR's error flags: OPERR (bit 1), WRPERR (4), PGAERR (5), PGPERR (6), PGSERR (7), RDERR
/// (8); each is cleared by writing 1.
const SR_ERRORS: u32 = 0x1F2;

/// The option-byte unlock keys (FLASH_OPTKEYR).
const OPTKEY1: u32 = 0x0819_2A3B;
/// The second option-byte unlock key.
const OPTKEY2: u32 = 0x4C5D_6E7F;

/// Longest wait for FLASH_SR.BSY around the option-byte programming, in core cycles (2 s at
/// 180 MHz). The programming erases and rewrites the user option bytes; the core stalls on its
/// own instruction fetches meanwhile, so the bound mostly catches a BSY that never clears.
const OPTION_BSY_CYCLES: u32 = 2 * SYSCLK_HZ;

/// Watchdog timeout while the option bytes are programmed (ms): as for a sector erase
/// (`health_flash::FLASH_WATCHDOG_MS`), far above the option bytes' own erase and write.
const OPTION_WATCHDOG_MS: u32 = crate::health_flash::FLASH_WATCHDOG_MS;

/// The brown-out reset level in the user option bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum BrownOut {
    /// Level 3 already: nothing written.
    Level3,
    /// Programmed to level 3 from the level `from` (BOR_LEV bits: `01` level 2, `10` level 1,
    /// `11` off).
    Programmed {
        /// BOR_LEV before.
        from: u8,
    },
    /// Left at `level` (BOR_LEV bits): the programming did not take.
    Failed {
        /// BOR_LEV read back.
        level: u8,
        /// FLASH_SR.BSY did not clear in [`OPTION_BSY_CYCLES`].
        bsy: bool,
        /// FLASH_SR's error flags after the programming (OPERR, WRPERR, PGAERR, PGPERR, PGSERR,
        /// RDERR: [`SR_ERRORS`]); cleared after the read.
        errors: u32,
    },
}

/// Sets the brown-out reset to level 3 when the option bytes hold a lower one (logged either
/// way). Level 3 holds the chip in reset while VDD is below V_BOR3 (about 2.8 V, falling-edge
/// minimum 2.75 V in the STM32F446 datasheet), which keeps the supply within the 2.7–3.6 V range
/// that 180 MHz with the 5 wait states the HAL sets needs (RM0390, "Relation between CPU clock
/// frequency and flash memory read time": below 2.7 V, 180 MHz needs more). The flash's own
/// program and erase at the HAL's x8 parallelism run from 1.8 V, so level 3 is for the clock,
/// not for the flash. The factory value is BOR off (about 1.7 V).
///
/// The sequence is RM0390's "Programming user option bytes": BSY clear, OPTCR unlocked
/// (OPTKEYR), BOR_LEV written with every other option bit as read, OPTSTRT set, BSY awaited,
/// OPTCR locked again; the watchdog runs with the flash timeout meanwhile. Needs the DWT cycle
/// counter running.
pub fn ensure_brown_out_level3(flash: &FLASH, watchdog: &Watchdog) -> BrownOut {
    let level = bor_level(flash);
    if level == BOR_LEVEL3 as u8 {
        defmt::info!("brown-out reset: level 3 (option bytes)");
        return BrownOut::Level3;
    }
    defmt::warn!("brown-out reset at BOR_LEV {=u8:02b}, below level 3: programming the option bytes", level);
    let previous_ms = watchdog.timeout_ms();
    if let Err(e) = watchdog.set_timeout_ms(OPTION_WATCHDOG_MS) {
        defmt::error!("brown-out level not programmed: watchdog not raised ({})", e);
        return BrownOut::Failed { level, bsy: false, errors: 0 };
    }
    let mut bsy = !wait_not_busy(flash);
    if !bsy {
        if flash.optcr().read().optlock().is_locked() {
            flash.optkeyr().write(|w| w.optkeyr().set(OPTKEY1));
            flash.optkeyr().write(|w| w.optkeyr().set(OPTKEY2));
        }
        // SAFETY: OPTCR is rewritten as read except BOR_LEV, so the read protection (RDP), the
        // write protections and the user bits keep their values; BOR_LEV = 00 is a defined level.
        flash.optcr().modify(|r, w| unsafe { w.bits((r.bits() & !BOR_LEV_MASK) | (BOR_LEVEL3 << BOR_LEV_SHIFT)) });
        flash.optcr().modify(|_, w| w.optstrt().set_());
        bsy = !wait_not_busy(flash);
        flash.optcr().modify(|_, w| w.optlock().set_());
    }
    watchdog.feed();
    if let Err(e) = watchdog.set_timeout_ms(previous_ms) {
        defmt::error!("watchdog timeout not set back to {=u32} ms: {}", previous_ms, e);
    }
    let errors = flash.sr().read().bits() & SR_ERRORS;
    // SAFETY: writing 1 clears an error flag (rc_w1); BSY and the zeros written elsewhere are
    // read-only or write-0-ignored bits of FLASH_SR.
    flash.sr().write(|w| unsafe { w.bits(errors) });
    let now = bor_level(flash);
    if now == BOR_LEVEL3 as u8 && !bsy && errors == 0 {
        defmt::warn!("brown-out reset: level 3 programmed (was BOR_LEV {=u8:02b})", level);
        BrownOut::Programmed { from: level }
    } else {
        defmt::error!(
            "brown-out reset level not programmed: BOR_LEV {=u8:02b}, BSY stuck: {=bool}, FLASH_SR errors {=u32:#x}",
            now,
            bsy,
            errors
        );
        BrownOut::Failed { level: now, bsy, errors }
    }
}

/// FLASH_OPTCR.BOR_LEV as bits.
fn bor_level(flash: &FLASH) -> u8 {
    ((flash.optcr().read().bits() & BOR_LEV_MASK) >> BOR_LEV_SHIFT) as u8
}

/// Waits until FLASH_SR.BSY is clear, at most [`OPTION_BSY_CYCLES`]; `false` if it is still set.
fn wait_not_busy(flash: &FLASH) -> bool {
    let start = DWT::cycle_count();
    while flash.sr().read().bsy().bit_is_set() {
        if DWT::cycle_count().wrapping_sub(start) > OPTION_BSY_CYCLES {
            return false;
        }
    }
    true
}
