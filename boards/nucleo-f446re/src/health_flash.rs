//! The health record in the STM32F446's own flash: sectors 6 and 7 (128 KiB each, offsets
//! [`RECORD_RANGE`], addresses `0x0804_0000..0x0808_0000`), which `memory.x` keeps out of the
//! program's `FLASH` region. stm32f4xx-hal's `UnlockedFlash` is the `embedded-storage` NOR flash
//! (1-byte writes, 128 KiB erase pages: its smaller sectors would be erased together, so the
//! record takes two large ones), under the core's `HealthStore` (`docs/persistence.md`).
//!
//! **Watchdog.** A sector erase stalls the core (the program runs from the same bank) for up to
//! 4 s (RM0390 / datasheet, x8 parallelism, which the HAL programs with), far beyond
//! the 500 ms watchdog; every operation that may erase (a save that opens a new page, about one
//! in 170 saves, and the maintenance reset) runs with the watchdog at [`FLASH_WATCHDOG_MS`] and
//! puts it back after.

use core::ops::Range;

use ema_monitor::conditioning::MeasuredTrace;
use ema_monitor::persist::store::MAX_KEPT_SAMPLES;
use ema_monitor::persist::{window_encoded_len, HealthRecord, HealthStore, StoreError};
use ema_monitor::report_log;
use stm32f4xx_hal::flash::{FlashExt, LockedFlash};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::watchdog::IndependentWatchdog;

use crate::WATCHDOG_MS;

/// Offsets (from the flash base) of the record's two sectors, 6 and 7.
pub const RECORD_RANGE: Range<u32> = 0x4_0000..0x8_0000;

/// Watchdog timeout while the flash may be erasing: two 128 KiB sector erases at their 4 s
/// maximum, with a margin above 1.4 at the LSI's fastest (47 kHz against 32 kHz).
const FLASH_WATCHDOG_MS: u32 = 16_000;

/// Runs `op` on the store with the long flash timeout on the watchdog.
fn with_store<T>(
    flash: &mut LockedFlash,
    watchdog: &mut IndependentWatchdog,
    op: impl FnOnce(&mut HealthStore<stm32f4xx_hal::flash::UnlockedFlash<'_>>) -> Result<T, StoreError>,
) -> Result<T, StoreError> {
    watchdog.start(FLASH_WATCHDOG_MS.millis());
    let result = HealthStore::new(flash.unlocked(), RECORD_RANGE).and_then(|mut store| op(&mut store));
    watchdog.start(WATCHDOG_MS.millis());
    result
}

/// At start-up: the maintenance reset when `maintenance` (the user button B1 held), then the last
/// flight's record, or a new one for a cold start (logged either way).
pub fn start(flash: &mut LockedFlash, watchdog: &mut IndependentWatchdog, maintenance: bool) -> HealthRecord {
    if maintenance {
        match with_store(flash, watchdog, |s| s.reset()) {
            Ok(()) => defmt::warn!("maintenance: health record erased; this flight runs cold"),
            Err(e) => defmt::error!("maintenance: erasing the health record failed: {}", e),
        }
    }
    match with_store(flash, watchdog, |s| s.load()) {
        Ok(Some(record)) => {
            defmt::info!(
                "health record: {=u32} flights, {=u32} since the last cold identification",
                record.flights(),
                record.flights_since_cold()
            );
            record
        }
        Ok(None) => {
            defmt::info!("health record: none stored, cold start");
            HealthRecord::new()
        }
        Err(e) => {
            defmt::warn!("health record unreadable ({}), cold start", e);
            HealthRecord::new()
        }
    }
}

/// A record of other parameters or another unit (`HealthMonitor::adopt` handed it back): kept in
/// the store's archive, readable, while a new record starts. `false` (logged) when the flash
/// refuses: the caller then does not save the new record, so that the old one stays current in
/// flash and is archived at the next start.
pub fn archive(flash: &mut LockedFlash, watchdog: &mut IndependentWatchdog, old: &HealthRecord) -> bool {
    match with_store(flash, watchdog, |s| s.archive(old)) {
        Ok(()) => {
            defmt::warn!("health record of another unit or other parameters archived ({=u32} flights)", old.flights());
            true
        }
        Err(e) => {
            defmt::error!("health record of another unit not archived ({}): this flight's record is not saved", e);
            false
        }
    }
}

/// After the flight (which the core's `HealthMonitor::diagnose` added to `record`): the record
/// is saved (a failure is logged; the monitor goes on).
pub fn save(flash: &mut LockedFlash, watchdog: &mut IndependentWatchdog, record: &HealthRecord) {
    match with_store(flash, watchdog, |s| s.save(record)) {
        Ok(()) => defmt::info!("health record saved: flight {=u32}", record.flights()),
        Err(e) => defmt::error!("health record not saved: {}", e),
    }
}

/// Keeps commissioning window `slot` (logged); `false` when the flash refuses. The encoding's
/// buffer lives only for the call.
#[inline(never)]
pub fn keep_window<const W: usize>(
    flash: &mut LockedFlash,
    watchdog: &mut IndependentWatchdog,
    slot: u8,
    window: &MeasuredTrace<W>,
    temperature_c: f32,
) -> bool {
    let mut buffer = [0u8; window_encoded_len(MAX_KEPT_SAMPLES)];
    report_log::log_window_kept(
        slot,
        with_store(flash, watchdog, |s| s.keep_window(slot, window, temperature_c, &mut buffer)),
    )
}

/// Reads commissioning window `slot` back into `out` (logged when it cannot).
#[inline(never)]
pub fn load_window<const W: usize>(
    flash: &mut LockedFlash,
    watchdog: &mut IndependentWatchdog,
    slot: u8,
    out: &mut MeasuredTrace<W>,
) -> Option<f32> {
    let mut buffer = [0u8; window_encoded_len(MAX_KEPT_SAMPLES)];
    report_log::log_window_loaded(slot, with_store(flash, watchdog, |s| s.load_window(slot, out, &mut buffer)))
}
