//! The health record's flash in QEMU: four 2 KiB pages of RAM (`mps2-an386` has no writable
//! flash model), alive for the run, so that both flights go through the record's save and load
//! path as on a board (`docs/persistence.md`).

use ema_monitor::persist::{HealthRecord, HealthStore, RamFlash, StoreError};

/// The record's flash.
pub type RecordFlash = RamFlash<4, 2048>;

/// The health record's store over the whole of `flash`.
fn open(flash: &mut RecordFlash) -> Result<HealthStore<&mut RecordFlash>, StoreError> {
    HealthStore::new(flash, 0..RecordFlash::CAPACITY as u32)
}

/// Maintenance reset ([`HealthStore::reset`]): erases the health record's flash, so that flight
/// 1 finds no record and starts cold, and logs it; `false` (logged) when the flash refuses.
#[inline(never)]
pub fn maintenance_reset(flash: &mut RecordFlash) -> bool {
    match open(flash).and_then(|mut store| store.reset()) {
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

/// The health record stored in `flash`, a new one when none is stored or it is unreadable;
/// `None` (logged) when the flash refuses. Not inlined: the store's buffers stay out of the
/// identification's stack.
#[inline(never)]
pub fn load_record(flash: &mut RecordFlash) -> Option<HealthRecord> {
    let Ok(mut store) = open(flash) else {
        defmt::error!("health record unavailable");
        return None;
    };
    match store.load() {
        Ok(r) => Some(r.unwrap_or_default()),
        Err(e) => {
            defmt::warn!("health record unreadable ({}): a new record", e);
            Some(HealthRecord::new())
        }
    }
}

/// Keeps `old`, the record of other parameters or another unit, in the store's archive
/// ([`HealthStore::archive`]) and logs it; `false` (logged) when the flash refuses.
#[inline(never)]
pub fn archive_record(flash: &mut RecordFlash, old: &HealthRecord) -> bool {
    match open(flash).and_then(|mut store| store.archive(old)) {
        Ok(()) => {
            defmt::warn!(
                "health record of other parameters or another unit archived ({=u32} flights); a new record starts",
                old.flights()
            );
            true
        }
        Err(e) => {
            defmt::error!("health record of another unit not archived: {}", e);
            false
        }
    }
}

/// Saves `record` to `flash` and reads it back as the next power-up does; `false` (logged) when
/// the flash refuses or gives back another record.
#[inline(never)]
pub fn save_record(flash: &mut RecordFlash, record: &HealthRecord) -> bool {
    let saved = open(flash).and_then(|mut store| store.save(record).and_then(|()| store.load()));
    match saved {
        Ok(Some(r)) if r.same_bits(record) => {
            defmt::info!(
                "health record saved and read back: flight {=u32}, {=u32} since the last cold identification",
                r.flights(),
                r.flights_since_cold()
            );
            true
        }
        Ok(_) => {
            defmt::error!("health record not read back as saved");
            false
        }
        Err(e) => {
            defmt::error!("health record not saved: {}", e);
            false
        }
    }
}
