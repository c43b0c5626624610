//! The health record's flash in QEMU: eight 4 KiB pages of RAM (`mps2-an386` has no writable
//! flash model), alive for the run, so that both flights go through the record's save and load
//! path as on a board (`docs/persistence.md`), and a commissioning's windows are kept there. It
//! lives in RAM beyond the firmware's 128 KiB (`memory.x`, `EMULATED_FLASH`): it stands in for
//! flash, and counts in neither the static RAM nor the stack.

use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, Ordering};

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::flight::HealthMonitor;
use ema_monitor::persist::{window_encoded_len, HealthStore, KeptRecord, RamFlash, RecordOrigin, StoreError};
use ema_monitor::report_log;

/// The record's flash: room for the record, an archived one and a commissioning window's twelve
/// chunks, with pages free for the store's recycling.
pub type RecordFlash = RamFlash<8, 4096>;

/// The emulated flash, in its own linker section (`memory.x`); written by [`take`].
#[link_section = ".emulated_flash"]
static mut EMULATED: MaybeUninit<RecordFlash> = MaybeUninit::uninit();

/// Whether [`take`] has given the emulated flash out.
static TAKEN: AtomicBool = AtomicBool::new(false);

/// The emulated flash, erased; `None` after the first call. Called before the stack is painted:
/// the erased value may be built on the stack before it is moved into place.
pub fn take() -> Option<&'static mut RecordFlash> {
    if TAKEN.swap(true, Ordering::AcqRel) {
        return None;
    }
    let slot: *mut RecordFlash = (&raw mut EMULATED).cast();
    // SAFETY: `TAKEN` lets this point pass once, so the reference made here is the only one to
    // `EMULATED`; `MaybeUninit<T>` has `T`'s layout, and the write initializes it first.
    unsafe {
        slot.write(RecordFlash::new());
        Some(&mut *slot)
    }
}

/// Bytes of the buffer a window is encoded in: the largest window a slot keeps.
const WINDOW_BUFFER_LEN: usize = window_encoded_len(ema_monitor::persist::store::MAX_KEPT_SAMPLES);

/// Keeps commissioning window `slot` in `flash` ([`HealthStore::keep_window`]); `false` (logged)
/// when the flash refuses. Not inlined: its buffer lives only for the call.
#[inline(never)]
pub fn keep_window<const W: usize>(
    flash: &mut RecordFlash,
    slot: u8,
    window: &ConditionedWindow<W>,
    temperature_c: f32,
) -> bool {
    let mut buffer = [0u8; WINDOW_BUFFER_LEN];
    report_log::log_window_kept(
        slot,
        open(flash).and_then(|mut store| store.keep_window(slot, window, temperature_c, &mut buffer)),
    )
}

/// Reads commissioning window `slot` back from `flash` into `out` ([`HealthStore::load_window`]);
/// `None` (logged) when it cannot. Not inlined, as [`keep_window`].
#[inline(never)]
pub fn load_window<const W: usize>(flash: &mut RecordFlash, slot: u8, out: &mut ConditionedWindow<W>) -> Option<f32> {
    let mut buffer = [0u8; WINDOW_BUFFER_LEN];
    report_log::log_window_loaded(slot, open(flash).and_then(|mut store| store.load_window(slot, out, &mut buffer)))
}

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

/// The health record stored in `flash` as a [`KeptRecord`]: the stored one, a new one when none
/// is stored, or a new one that must not be saved when the load fails (logged: the flight runs
/// cold and the stored record is left as it is, [`ema_monitor::persist::kept`]); `None`
/// (logged) when the store cannot be opened. Not inlined: the store's buffers stay out of the
/// identification's stack.
#[inline(never)]
pub fn load_record(flash: &mut RecordFlash) -> Option<KeptRecord> {
    let Ok(mut store) = open(flash) else {
        defmt::error!("health record unavailable");
        return None;
    };
    let kept = KeptRecord::from_load(store.load());
    if let RecordOrigin::Unreadable(e) = kept.origin() {
        defmt::warn!("health record unreadable ({}): this flight runs cold, the stored record is left as it is", e);
    }
    Some(kept)
}

/// [`HealthMonitor::adopt`]: a record of other parameters is archived in `flash` and a new one
/// started; `false` (logged) when the flash refuses, and the record is then not to be saved
/// ([`KeptRecord::archive_failed`]). Not inlined: the old record stays out of the
/// identification's stack.
#[inline(never)]
pub fn adopt_record(monitor: &HealthMonitor<'_>, kept: &mut KeptRecord, flash: &mut RecordFlash) -> bool {
    let Some(old) = monitor.adopt(kept.record_mut()) else { return true };
    match open(flash).and_then(|mut store| store.archive(&old)) {
        Ok(()) => {
            defmt::warn!(
                "health record of other parameters or another unit archived ({=u32} flights); a new record starts",
                old.flights()
            );
            true
        }
        Err(e) => {
            defmt::error!("health record of another unit not archived: {}", e);
            kept.archive_failed(e);
            false
        }
    }
}

/// Saves the record `kept` holds to `flash` and reads it back as the next power-up does; `false`
/// (logged) when the policy withholds it (the stored record was unreadable or not archived: it
/// stays as it is), the flash refuses, or it reads back as another record.
#[inline(never)]
pub fn save_record(flash: &mut RecordFlash, kept: &KeptRecord) -> bool {
    let Some(record) = kept.savable() else {
        defmt::error!("health record not saved ({}): the stored record is left as it is", kept.origin());
        return false;
    };
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
