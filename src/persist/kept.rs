//! [`KeptRecord`]: the health record a firmware holds in RAM, with where it came from
//! ([`RecordOrigin`]), which decides whether it may be saved.
//!
//! A save appends the newest copy, and a load gives the newest copy, so whatever is saved hides
//! what the store held before. A load can fail for reasons that say nothing about the stored
//! history: a transient read error, a corruption the next power-up's repair undoes, a record
//! written by a newer firmware (another format version). Saving a new record after such a
//! failure would make the flight count, trend and pooled evidence unreachable for good. The
//! policy both firmwares share is therefore:
//!
//! - a load that gives a record ([`RecordOrigin::Loaded`]) or finds none
//!   ([`RecordOrigin::Empty`]: a new flash, or after a maintenance reset) gives a record that may
//!   be saved;
//! - a load that fails ([`RecordOrigin::Unreadable`]) gives a new record for this flight alone:
//!   the flight runs cold (`HealthMonitor::diagnose_kept`, [`crate::flight`]), is reported with
//!   the load's error, and is **not saved**. The store is left as it is until a load succeeds
//!   or an explicit maintenance reset erases it; the load is tried again at the next start and,
//!   on a firmware that flies again without a reset (the board), before the next flight;
//! - a record of another unit or other parameters that could not be archived
//!   ([`RecordOrigin::NotArchived`]) is kept from being replaced the same way: the store still
//!   holds it as the newest copy.
//!
//! Nothing here touches the flash: the firmware loads, archives and saves through its own
//! [`super::HealthStore`] and hands the results to this type, which says what may follow.

use super::record::HealthRecord;
use super::store::StoreError;

/// Where a [`KeptRecord`] came from, and so whether it may be saved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RecordOrigin {
    /// The store's newest record: a save appends its successor.
    Loaded,
    /// The store holds no record (a new flash, or after a maintenance reset): a new history
    /// starts, and its first save is the store's first record.
    Empty,
    /// The load failed with this error: the record is a new one for this flight alone, and the
    /// store may still hold a history that a later load reads. Not saved.
    Unreadable(StoreError),
    /// The store's newest record is another unit's or was made under other parameters, and
    /// archiving it failed with this error: saving the new record would hide it. Not saved.
    NotArchived(StoreError),
}

impl RecordOrigin {
    /// `true` when a record of this origin may be saved over what the store holds.
    pub const fn may_save(self) -> bool {
        matches!(self, RecordOrigin::Loaded | RecordOrigin::Empty)
    }

    /// A short name for a report: `loaded`, `empty`, `unreadable` or `not_archived`.
    pub const fn label(self) -> &'static str {
        match self {
            RecordOrigin::Loaded => "loaded",
            RecordOrigin::Empty => "empty",
            RecordOrigin::Unreadable(_) => "unreadable",
            RecordOrigin::NotArchived(_) => "not_archived",
        }
    }
}

/// The health record a firmware keeps in RAM between its load and its save, with its
/// [`RecordOrigin`] (module documentation: the policy).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeptRecord {
    record: HealthRecord,
    origin: RecordOrigin,
}

impl KeptRecord {
    /// The record a load gave: the stored one, a new one when none is stored, or a new one that
    /// must not be saved when the load failed.
    pub fn from_load(loaded: Result<Option<HealthRecord>, StoreError>) -> Self {
        match loaded {
            Ok(Some(record)) => Self { record, origin: RecordOrigin::Loaded },
            Ok(None) => Self { record: HealthRecord::new(), origin: RecordOrigin::Empty },
            Err(e) => Self { record: HealthRecord::new(), origin: RecordOrigin::Unreadable(e) },
        }
    }

    /// Where the record came from.
    pub fn origin(&self) -> RecordOrigin {
        self.origin
    }

    /// `true` when the record may be saved ([`RecordOrigin::may_save`]).
    pub fn may_save(&self) -> bool {
        self.origin.may_save()
    }

    /// `true` when the store must be loaded again before the next flight: the record may not be
    /// saved, and a new load may succeed (a transient error) where this one failed.
    pub fn needs_load(&self) -> bool {
        !self.may_save()
    }

    /// The record, to plan and log with.
    pub fn record(&self) -> &HealthRecord {
        &self.record
    }

    /// The record, to add a flight to or adopt (`HealthMonitor::adopt`).
    pub fn record_mut(&mut self) -> &mut HealthRecord {
        &mut self.record
    }

    /// The record to save, `None` when it may not be saved: the only way to the bytes a save
    /// writes, so that a firmware cannot save what the policy withholds.
    pub fn savable(&self) -> Option<&HealthRecord> {
        self.may_save().then_some(&self.record)
    }

    /// Archiving the record `HealthMonitor::adopt` replaced failed with `error`: the store's
    /// newest copy is still that record, so this one may not be saved
    /// ([`RecordOrigin::NotArchived`]) and the next flight loads and archives again.
    pub fn archive_failed(&mut self, error: StoreError) {
        self.origin = RecordOrigin::NotArchived(error);
    }
}
