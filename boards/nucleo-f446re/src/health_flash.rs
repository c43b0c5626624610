//! The health record in the STM32F446's own flash: sectors 6 and 7 (128 KiB each, offsets
//! [`RECORD_RANGE`], addresses `0x0804_0000..0x0808_0000`), which `memory.x` keeps out of the
//! program's `FLASH` region. stm32f4xx-hal's `UnlockedFlash` is the `embedded-storage` NOR flash
//! (1-byte writes, 128 KiB erase pages: its smaller sectors would be erased together, so the
//! record takes two large ones), under the core's `HealthStore` (`docs/persistence.md`), through
//! the core's `EraseGuarded`: every erase goes one sector at a time, with [`FeedAndFlush`]
//! around each.
//!
//! **Watchdog.** A sector erase stalls the core (the program runs from the same bank) for as long
//! as it takes: the HAL erases at x8 parallelism (FLASH_CR.PSIZE = 00), where the datasheet gives
//! a 128 KiB sector 2 s typical and 4 s at most. Every store operation runs with the watchdog at
//! [`FLASH_WATCHDOG_MS`], fed before and after each sector, so that the timeout covers one
//! sector whatever the number an operation erases (a save that opens a new page, one save in
//! 151; the maintenance reset, two), then sets back the timeout it found.

use core::ops::Range;

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::flight::HealthMonitor;
use ema_monitor::persist::store::MAX_KEPT_SAMPLES;
use ema_monitor::persist::{window_encoded_len, EraseGuard, EraseGuarded, FlashFault};
use ema_monitor::persist::{HealthStore, KeptRecord, RecordOrigin, StoreError};
use ema_monitor::report_log;
use stm32f4xx_hal::flash::{FlashExt, LockedFlash, UnlockedFlash};

use crate::flash_control;
use crate::watchdog::Watchdog;

/// Offsets (from the flash base) of the record's two sectors, 6 and 7.
pub const RECORD_RANGE: Range<u32> = 0x4_0000..0x8_0000;

/// Watchdog timeout while the flash may be erasing or programming (ms). The longest stretch
/// between two feeds is one 128 KiB sector erase, 4 s at most at x8 parallelism (datasheet),
/// or a run of byte writes between two erases: at most 100 µs a byte, 0.09 s for a record,
/// 0.92 s for a commissioning window (9 KiB), about 3 s for the live items (record, archive,
/// three windows) a page change may copy. 10 s is 2.5 times the erase at the LSI's nominal 32 kHz and 1.7 times at its
/// fastest, 47 kHz.
pub const FLASH_WATCHDOG_MS: u32 = 10_000;

/// What runs around each sector erase: the watchdog fed before and after, and the data cache
/// flushed after ([`flash_control::flush_data_cache`]), so that no read returns the erased
/// sector's old bytes.
pub struct FeedAndFlush<'a> {
    /// The watchdog, fed around each sector.
    watchdog: &'a Watchdog,
}

impl<'a> FeedAndFlush<'a> {
    /// The guard that feeds `watchdog` around each sector.
    pub const fn new(watchdog: &'a Watchdog) -> Self {
        Self { watchdog }
    }
}

impl EraseGuard for FeedAndFlush<'_> {
    fn before_page_erase(&mut self, _offset: u32) {
        self.watchdog.feed();
    }

    fn after_page_erase(&mut self, _offset: u32) {
        flash_control::flush_data_cache();
        self.watchdog.feed();
    }
}

/// The store over the record's sectors, each erase guarded.
pub type Store<'a> = HealthStore<EraseGuarded<UnlockedFlash<'a>, FeedAndFlush<'a>>>;

/// Runs `op` on the store with the watchdog at [`FLASH_WATCHDOG_MS`], then sets back the timeout
/// it found (the commissioning's own, during its fit). When the watchdog cannot be raised, the
/// flash is left untouched (logged) and `op` fails as a flash fault: an erase under the short
/// timeout would reset the chip. Each call is a new store, so its first operation checks the
/// pages for an interrupted erase's remains (the core's `persist::pages`).
pub fn with_store<T>(
    flash: &mut LockedFlash,
    watchdog: &Watchdog,
    op: impl FnOnce(&mut Store<'_>) -> Result<T, StoreError>,
) -> Result<T, StoreError> {
    let previous_ms = watchdog.timeout_ms();
    if let Err(e) = watchdog.set_timeout_ms(FLASH_WATCHDOG_MS) {
        defmt::error!("health record: watchdog not raised for the flash ({}), flash left untouched", e);
        return Err(StoreError::Flash(FlashFault::Other));
    }
    let guarded = EraseGuarded::new(flash.unlocked(), FeedAndFlush::new(watchdog));
    let result = HealthStore::new(guarded, RECORD_RANGE).and_then(|mut store| op(&mut store));
    if let Err(e) = watchdog.set_timeout_ms(previous_ms) {
        defmt::error!("watchdog timeout not set back to {=u32} ms: {}", previous_ms, e);
    }
    result
}

/// At start-up: the maintenance reset when `maintenance` (the user button B1 held), then the
/// record as [`load`] gives it.
pub fn start(flash: &mut LockedFlash, watchdog: &Watchdog, maintenance: bool) -> KeptRecord {
    if maintenance {
        match with_store(flash, watchdog, |s| s.reset()) {
            Ok(()) => defmt::warn!("maintenance: health record erased; this flight runs cold"),
            Err(e) => defmt::error!("maintenance: erasing the health record failed: {}", e),
        }
    }
    load(flash, watchdog)
}

/// The last flight's record, a new one when none is stored, or, when the load fails, a new one
/// that is not to be saved (the core's `persist::kept`: the flight runs cold and the stored
/// record stays for the next load); logged either way. Called at start-up and, while the
/// record may not be saved, before each flight.
pub fn load(flash: &mut LockedFlash, watchdog: &Watchdog) -> KeptRecord {
    let kept = KeptRecord::from_load(with_store(flash, watchdog, |s| s.load()));
    let record = kept.record();
    match kept.origin() {
        RecordOrigin::Loaded => defmt::info!(
            "health record: {=u32} flights, {=u32} since the last cold identification",
            record.flights(),
            record.flights_since_cold()
        ),
        RecordOrigin::Empty => defmt::info!("health record: none stored, cold start"),
        RecordOrigin::Unreadable(e) | RecordOrigin::NotArchived(e) => defmt::warn!(
            "health record unreadable ({}): cold start, the stored record is kept and not saved over; loaded again before the next flight",
            e
        ),
    }
    kept
}

/// Makes the record `monitor`'s (`HealthMonitor::adopt`): a record of other parameters or
/// another unit is kept in the store's archive, readable, while a new record starts. When the
/// flash refuses the archive (logged), the new record is not to be saved
/// ([`KeptRecord::archive_failed`]), so that the other one stays current in flash; the next
/// flight loads and archives it again.
pub fn adopt(flash: &mut LockedFlash, watchdog: &Watchdog, monitor: &HealthMonitor<'_>, kept: &mut KeptRecord) {
    let Some(old) = monitor.adopt(kept.record_mut()) else { return };
    match with_store(flash, watchdog, |s| s.archive(&old)) {
        Ok(()) => {
            defmt::warn!("health record of another unit or other parameters archived ({=u32} flights)", old.flights())
        }
        Err(e) => {
            defmt::error!("health record of another unit not archived ({}): this flight's record is not saved", e);
            kept.archive_failed(e);
        }
    }
}

/// After the flight (which the core's `HealthMonitor::diagnose_kept` added to the record): the
/// record is saved when it may be ([`KeptRecord::savable`]); a save withheld or refused is
/// logged, and the monitor goes on. Not inlined: the record's encoding buffer lives only for
/// the call, not in the frame of the flight loop, which the identification runs above.
#[inline(never)]
pub fn save(flash: &mut LockedFlash, watchdog: &Watchdog, kept: &KeptRecord) {
    let Some(record) = kept.savable() else {
        defmt::warn!("health record not saved ({}): the stored record is left as it is", kept.origin());
        return;
    };
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
    watchdog: &Watchdog,
    slot: u8,
    window: &ConditionedWindow<W>,
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
    watchdog: &Watchdog,
    slot: u8,
    out: &mut ConditionedWindow<W>,
) -> Option<f32> {
    let mut buffer = [0u8; window_encoded_len(MAX_KEPT_SAMPLES)];
    report_log::log_window_loaded(slot, with_store(flash, watchdog, |s| s.load_window(slot, out, &mut buffer)))
}
