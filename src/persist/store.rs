//! [`HealthStore`]: the [`HealthRecord`] in a NOR-flash range, through `sequential-storage`'s map.
//!
//! The record is one map item under the key [`RECORD_KEY`]; a save appends a new copy, a load
//! finds the newest intact one. `sequential-storage` gives the guarantees this module relies on
//! (its documentation, "Inner workings"; `docs/persistence.md` for what the tests show):
//! - **CRC.** Each item carries a CRC-32 of its data and a CRC-16 of its length. An item whose
//!   CRC fails is skipped, so a load returns the newest copy that is intact (an older record, or
//!   nothing), never the damaged bytes. A CRC-32 detects every error burst of up to 32 bits, so
//!   any single corrupted byte is caught; no record-level CRC is added on top.
//! - **Power loss.** A save only appends; the previous copy is left in place until its page is
//!   recycled, which happens only after a newer copy is complete. A cut write leaves a torn item
//!   whose CRC fails. A cut erase leaves an undefined page, which the crate alone mistakes for
//!   an open, partially open or closed one: the store's first operation after power-up checks
//!   the pages and erases or closes such remains ([`super::pages`]), and the crate's repair does
//!   the rest. A save, reset, archive or window keep cut at any point leaves the old or the new
//!   value, and the next operation works (`docs/persistence.md`, "Power loss").
//! - **Wear.** Pages are filled in turn and erased cyclically, so N saves spread their erases
//!   evenly over the pages of the range.
//!
//! Every failure is a [`StoreError`] value; nothing here panics on a flash error, and the
//! firmware runs a cold identification when [`HealthStore::load`] gives `Ok(None)` or an error.

use core::ops::Range;

use embedded_storage::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind};
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage, SerializationError, Value};
use sequential_storage::Error as SsError;

use super::flash::{block_on, Blocking};
use super::pages::{check_pages, MAX_PAGES};
use super::record::{HealthRecord, RecordError};
use super::window::{decode_window_into, encode_window, encoded_len_of, WindowError, WINDOW_HEADER_LEN};
use crate::conditioning::ConditionedWindow;

/// The map key of the health record.
pub const RECORD_KEY: u8 = 0x48; // 'H'

/// The map key of the archived record: the last record of another unit or other parameters,
/// kept readable when a new history starts ([`HealthStore::archive`]).
pub const ARCHIVE_KEY: u8 = 0x41; // 'A'

/// The map key of chunk `c` of commissioning window `slot` is this plus
/// `slot·WINDOW_CHUNKS + c` ([`HealthStore::keep_window`]).
pub const WINDOW_KEY_BASE: u8 = 0x60;

/// Commissioning windows the store keeps at most (slots `0..WINDOW_SLOTS`).
pub const WINDOW_SLOTS: u8 = 8;

/// Bytes of one chunk of a kept window. Every map operation migrates the items of a page it
/// recycles through its work buffer, so no item may be larger than the record's: a window
/// (8.5 KB on board) is kept as chunks of this size, a multiple of 4 so that no sample straddles
/// two chunks.
pub const WINDOW_CHUNK_LEN: usize = 768;

/// Chunks per window slot: a window of up to [`MAX_KEPT_SAMPLES`] samples.
pub const WINDOW_CHUNKS: u8 = 12;

/// Most block means a kept window holds (the on-board window's 2200 fit).
pub const MAX_KEPT_SAMPLES: usize = (WINDOW_CHUNKS as usize * WINDOW_CHUNK_LEN - WINDOW_HEADER_LEN) / 4;

/// Bytes of the store's work buffer: key (1 byte) + record, rounded up to the largest flash
/// word `sequential-storage` supports (32 bytes).
pub const BUFFER_LEN: usize = (1 + HealthRecord::ENCODED_LEN).div_ceil(32) * 32;

/// Why a store operation failed. The firmware logs it and runs cold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StoreError {
    /// The flash range does not start and end on erase-page boundaries, spans fewer than two
    /// pages or more than [`super::pages::MAX_PAGES`], or its pages cannot hold the record.
    Range,
    /// The flash driver failed (for the fakes: a power cut, [`super::RamFlashError::PowerLoss`],
    /// or an injected read fault, [`super::RamFlashError::ReadFault`], reads as `Other`).
    Flash(FlashFault),
    /// `sequential-storage` found corruption that its repair could not undo; a
    /// [`HealthStore::reset`] erases the range.
    Corrupt,
    /// The intact stored item is not a record of this format (another version, an unknown
    /// status code): [`RecordError`].
    Record(RecordError),
    /// A commissioning window was refused or does not decode ([`WindowError`]), its slot is not
    /// below [`WINDOW_SLOTS`], or it holds more than [`MAX_KEPT_SAMPLES`].
    Window(WindowError),
    /// The item does not fit in a page, or the storage is full (one key cannot fill it).
    Full,
    /// The flash future did not complete ([`super::block_on`] gave up).
    Stalled,
    /// `sequential-storage` reported an internal error (buffer, serialization, logic).
    Internal,
}

/// The kind of a flash driver error (`embedded_storage::nor_flash::NorFlashErrorKind`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FlashFault {
    /// Misaligned offset or length.
    NotAligned,
    /// Out of the flash's bounds.
    OutOfBounds,
    /// Any other driver error (a write or erase that failed, a power cut).
    Other,
}

impl From<NorFlashErrorKind> for FlashFault {
    fn from(kind: NorFlashErrorKind) -> Self {
        match kind {
            NorFlashErrorKind::NotAligned => FlashFault::NotAligned,
            NorFlashErrorKind::OutOfBounds => FlashFault::OutOfBounds,
            _ => FlashFault::Other,
        }
    }
}

fn store_error<E: NorFlashError>(e: SsError<E>) -> StoreError {
    match e {
        SsError::Storage { value, .. } => StoreError::Flash(value.kind().into()),
        SsError::Corrupted { .. } => StoreError::Corrupt,
        SsError::FullStorage | SsError::ItemTooBig => StoreError::Full,
        _ => StoreError::Internal,
    }
}

/// The work buffer, word-aligned for flash drivers that need aligned source buffers.
#[repr(align(32))]
#[derive(Debug)]
struct AlignedBuf([u8; BUFFER_LEN]);

/// The record as a map value: written by [`HealthRecord::encode`] straight into the store's work
/// buffer (loads read the bytes as `&[u8]` and decode them).
struct Encoded<'r>(&'r HealthRecord);

impl<'a> Value<'a> for Encoded<'_> {
    fn serialize_into(&self, buffer: &mut [u8]) -> Result<usize, SerializationError> {
        self.0.encode(buffer).map_err(|_| SerializationError::BufferTooSmall)
    }

    fn deserialize_from(_buffer: &'a [u8]) -> Result<(Self, usize), SerializationError> {
        Err(SerializationError::InvalidFormat)
    }
}

/// The health record stored in the flash range `range` of the blocking NOR flash `F`.
pub struct HealthStore<F: NorFlash> {
    map: MapStorage<u8, Blocking<F>, Cache<Uncached, Uncached, Uncached, u8>>,
    buf: AlignedBuf,
    /// The pages are checked for the remains of an interrupted erase ([`check_pages`]).
    checked: bool,
}

impl<F: NorFlash> HealthStore<F> {
    /// The store over `range` of `flash` (offsets in the flash's own address space). The range
    /// must start and end on erase-page boundaries and span two to [`super::pages::MAX_PAGES`]
    /// pages, each large enough for one record ([`StoreError::Range`] otherwise). Nothing is read
    /// or written yet: the first operation checks the pages ([`super::pages`]).
    pub fn new(flash: F, range: Range<u32>) -> Result<Self, StoreError> {
        let item = 8 + BUFFER_LEN;
        if F::ERASE_SIZE < item + 2 * F::WRITE_SIZE.max(F::READ_SIZE) {
            return Err(StoreError::Range);
        }
        let pages = (range.end.saturating_sub(range.start) as usize) / F::ERASE_SIZE.max(1);
        if pages > MAX_PAGES {
            return Err(StoreError::Range);
        }
        let config = MapConfig::<Blocking<F>>::try_new(range).map_err(|_| StoreError::Range)?;
        Ok(Self {
            map: MapStorage::new(Blocking(flash), config, Cache::new_uncached()),
            buf: AlignedBuf([0; BUFFER_LEN]),
            checked: false,
        })
    }

    /// Before the store's first operation: the pages checked for the remains of an erase cut
    /// by a power loss, which are erased or closed ([`check_pages`]). Only a power loss leaves
    /// such remains, and a store does not outlive one, so the check runs once per store.
    fn check(&mut self) -> Result<(), StoreError> {
        if !self.checked {
            let range = self.map.flash_range();
            check_pages(self.map.flash().inner_mut(), range).map_err(|e| StoreError::Flash(e.kind().into()))?;
            self.checked = true;
        }
        Ok(())
    }

    /// The newest intact record: `Ok(None)` when none is stored (a fresh or reset range, or every
    /// stored copy failed its CRC); `Err` when the flash fails, the crate finds corruption it
    /// cannot repair, or the intact item does not decode ([`StoreError::Record`]). Anything but
    /// `Ok(Some(_))` means a cold start.
    pub fn load(&mut self) -> Result<Option<HealthRecord>, StoreError> {
        self.load_key(RECORD_KEY)
    }

    /// Appends `record` as the newest copy. On `Err` the previous record stays the one a load
    /// returns (or, for a cut during the write, the new one if it was complete).
    pub fn save(&mut self, record: &HealthRecord) -> Result<(), StoreError> {
        self.save_key(RECORD_KEY, record)
    }

    /// Keeps `record` (the last record of another unit or other parameters) under its own key,
    /// replacing the one archived before; [`HealthStore::load_archive`] reads it back. The
    /// current record is not touched: a power cut after the archive and before the next save
    /// leaves the old record both archived and current, and the next start archives it again.
    pub fn archive(&mut self, record: &HealthRecord) -> Result<(), StoreError> {
        self.save_key(ARCHIVE_KEY, record)
    }

    /// The archived record ([`HealthStore::archive`]), as [`HealthStore::load`] reads the current
    /// one.
    pub fn load_archive(&mut self) -> Result<Option<HealthRecord>, StoreError> {
        self.load_key(ARCHIVE_KEY)
    }

    /// Keeps commissioning window `slot` (the closed `window` of a flight flown at
    /// `temperature_c`), replacing what the slot held, as [`WINDOW_CHUNKS`] items of at most
    /// [`WINDOW_CHUNK_LEN`] bytes. `buffer` holds the whole encoding
    /// ([`super::window_encoded_len`] of the window's samples) for this call: it lives in the
    /// caller's frame, not in the store, since a window is kept only while commissioning.
    ///
    /// The slot's first chunk, which holds the window's header, is replaced by an empty item
    /// before the others are written and written last, so that a cut in the middle leaves a slot
    /// that reads as empty ([`HealthStore::load_window`] gives `Ok(None)`), never as the chunks of
    /// two windows of the same length spliced together: a slot is kept again after a cut that
    /// came before its flight's record was saved.
    pub fn keep_window<const W: usize>(
        &mut self,
        slot: u8,
        window: &ConditionedWindow<W>,
        temperature_c: f32,
        buffer: &mut [u8],
    ) -> Result<(), StoreError> {
        if slot >= WINDOW_SLOTS || window.len() > MAX_KEPT_SAMPLES {
            return Err(StoreError::Window(WindowError::NotKeepable));
        }
        self.check()?;
        let len = encode_window(window, temperature_c, buffer).map_err(StoreError::Window)?;
        let encoded = buffer.get(..len).ok_or(StoreError::Window(WindowError::BufferTooSmall))?;
        let first = WINDOW_KEY_BASE + slot * WINDOW_CHUNKS;
        if encoded.len() > WINDOW_CHUNK_LEN {
            self.store_chunk(first, &[])?;
        }
        for (c, chunk) in (0..WINDOW_CHUNKS).zip(encoded.chunks(WINDOW_CHUNK_LEN)).skip(1) {
            self.store_chunk(first + c, chunk)?;
        }
        self.store_chunk(first, encoded.get(..WINDOW_CHUNK_LEN.min(len)).unwrap_or_default())
    }

    fn store_chunk(&mut self, key: u8, chunk: &[u8]) -> Result<(), StoreError> {
        let stored = block_on(self.map.store_item(&mut self.buf.0, &key, &chunk)).ok_or(StoreError::Stalled)?;
        stored.map_err(store_error)
    }

    /// Commissioning window `slot` rebuilt into `out` ([`HealthStore::keep_window`]; `buffer` as
    /// there): `Ok(Some(temperature))` when the slot holds one, `Ok(None)` when it does not (never
    /// kept, or a keep cut in the middle).
    pub fn load_window<const W: usize>(
        &mut self,
        slot: u8,
        out: &mut ConditionedWindow<W>,
        buffer: &mut [u8],
    ) -> Result<Option<f32>, StoreError> {
        if slot >= WINDOW_SLOTS {
            return Err(StoreError::Window(WindowError::NotKeepable));
        }
        self.check()?;
        let mut len = usize::MAX;
        let mut filled = 0;
        for c in 0..WINDOW_CHUNKS {
            if filled >= len {
                break;
            }
            let key = WINDOW_KEY_BASE + slot * WINDOW_CHUNKS + c;
            let fetched = block_on(self.map.fetch_item::<&[u8]>(&mut self.buf.0, &key)).ok_or(StoreError::Stalled)?;
            let Some(chunk) = fetched.map_err(store_error)? else {
                return if c == 0 { Ok(None) } else { Err(StoreError::Window(WindowError::Length)) };
            };
            if c == 0 && chunk.is_empty() {
                return Ok(None);
            }
            let dst =
                buffer.get_mut(filled..filled + chunk.len()).ok_or(StoreError::Window(WindowError::BufferTooSmall))?;
            dst.copy_from_slice(chunk);
            filled += chunk.len();
            if c == 0 {
                let first = buffer.get(..filled).ok_or(StoreError::Window(WindowError::Length))?;
                len = encoded_len_of(first).map_err(StoreError::Window)?;
            }
        }
        let encoded = buffer.get(..len).ok_or(StoreError::Window(WindowError::Length))?;
        decode_window_into(encoded, out).map(Some).map_err(StoreError::Window)
    }

    fn load_key(&mut self, key: u8) -> Result<Option<HealthRecord>, StoreError> {
        self.check()?;
        let fetched = block_on(self.map.fetch_item::<&[u8]>(&mut self.buf.0, &key)).ok_or(StoreError::Stalled)?;
        match fetched.map_err(store_error)? {
            None => Ok(None),
            Some(bytes) => HealthRecord::decode(bytes).map(Some).map_err(StoreError::Record),
        }
    }

    fn save_key(&mut self, key: u8, record: &HealthRecord) -> Result<(), StoreError> {
        self.check()?;
        let stored =
            block_on(self.map.store_item(&mut self.buf.0, &key, &Encoded(record))).ok_or(StoreError::Stalled)?;
        stored.map_err(store_error)
    }

    /// Maintenance reset: erases the whole range, so the next load gives `Ok(None)` and the next
    /// flight runs cold. Only an explicit maintenance command calls it.
    pub fn reset(&mut self) -> Result<(), StoreError> {
        block_on(self.map.erase_all()).ok_or(StoreError::Stalled)?.map_err(store_error)?;
        self.checked = true;
        Ok(())
    }

    /// Gives the flash back (a test's power cycle: a new store over the same flash).
    pub fn into_flash(self) -> F {
        self.map.destroy().0.into_inner()
    }
}
