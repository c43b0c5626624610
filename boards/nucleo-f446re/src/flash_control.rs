//! The flash interface's own registers (RM0390, "Embedded flash memory interface"): the data
//! cache flushed after an erase (FLASH_ACR). The erases and writes themselves go through
//! stm32f4xx-hal's `UnlockedFlash` (`health_flash.rs`).

use stm32f4xx_hal::pac::FLASH;

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
