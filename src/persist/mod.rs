//! Health state that survives power cycles: the fixed-size [`HealthRecord`] (last diagnosis,
//! history per fault mode, pooled evidence) and the [`HealthStore`] that keeps it in NOR flash
//! through the `embedded-storage` traits and `sequential-storage`'s wear-levelled, CRC-checked map.
//!
//! ```text
//!  HealthReport ─► HealthRecord::new_flight ─► HealthStore::save ─► sequential-storage map
//!                                                                      │ (async NorFlash)
//!  next flight ◄── HealthStore::load ◄──────────────────────────── Blocking<F: NorFlash>
//! ```
//!
//! [`HealthStore::load`] gives the newest intact record, `Ok(None)` when there is none; any error
//! or `None` means a cold start, and the firmware keeps running. [`KeptRecord`] holds what a load
//! gave with its [`RecordOrigin`]: after a failed load the flight runs cold and its record is not
//! saved, so that the stored history stays for the next load. [`HealthStore::reset`] is the
//! maintenance reset. [`RamFlash`] is the flash of the QEMU firmware and of the tests (power cuts
//! at any byte, bit flips, erase counts). Layout, guarantees, power-loss behaviour and wear:
//! `docs/persistence.md`; the choice of `sequential-storage`:
//! `docs/decisions/0019-health-record-storage.md`.

pub mod erase_guard;
pub mod flash;
pub mod kept;
pub mod pages;
#[cfg(test)]
mod power_loss_tests;
#[cfg(test)]
mod read_fault_tests;
pub mod record;
pub mod store;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod watchdog_tests;
pub mod window;

pub use erase_guard::{EraseGuard, EraseGuarded};
pub use flash::{block_on, Blocking, RamFlash, RamFlashError};
pub use kept::{KeptRecord, RecordOrigin};
pub use record::{
    Commissioning, CommissioningRefusal, HealthRecord, HistoryEntry, ModeHistory, RecordError, RecordIdentity,
    UnitBaseline, HISTORY_LEN, RECORD_VERSION,
};
pub use store::{FlashFault, HealthStore, StoreError};
pub use window::{window_encoded_len, WindowError};
