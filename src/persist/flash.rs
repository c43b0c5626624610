//! Flash plumbing of the health store: the blocking-to-async adapter [`Blocking`], the executor
//! [`block_on`] that drives `sequential-storage`'s futures, and [`RamFlash`], a NOR flash in RAM
//! with erase counters and power-loss, bit-flip and read-fault injection (QEMU's `mps2-an386` has
//! no writable flash model, and the tests need a flash that can fail on purpose).
//!
//! **Power-loss model.** A cut planned with [`RamFlash::cut_power_after`] stops the operation at
//! a byte. By default the cut is clean: the bytes before it are done, the rest untouched. With
//! [`RamFlash::set_tearing`] the cut is what a NOR flash whose supply fails leaves: the word being
//! programmed holds a random subset of the bits its write was clearing (programming only clears
//! bits, and a cell cut mid-pulse may or may not have flipped), and the page being erased is
//! undefined: each byte is its old value, `0xFF`, its old value with random bits set (a cell
//! part-way erased) or a random byte, in shares that follow how far the erase had got. The
//! patterns come from the seed, so a failing cut replays.
//!
//! **Why an adapter and a hand-written executor.** Flash HALs implement the blocking
//! `embedded_storage::nor_flash::NorFlash` (stm32f4xx-hal's `UnlockedFlash` does);
//! `sequential-storage` drives the async `embedded_storage_async::nor_flash::NorFlash`. [`Blocking`]
//! wraps the first as the second: each async call does the blocking call and is ready at its first
//! poll, so every future of the store completes at its first poll as well. [`block_on`] therefore
//! needs no waker that wakes anything: it polls with `core::task::Waker::noop` (safe code, no
//! dependency; the crate forbids `unsafe`), and gives up after [`POLL_LIMIT`] polls instead of
//! spinning forever, so a future that never completes is an error value, not a hang.

use core::future::Future;
use core::pin::pin;
use core::task::{Context, Poll, Waker};

use embedded_storage::nor_flash as blocking;
use embedded_storage_async::nor_flash as nor;

use crate::optimizer::rng::splitmix64;

/// Polls [`block_on`] makes before it gives up. With a [`Blocking`] flash the first poll completes.
pub const POLL_LIMIT: u32 = 16;

/// Runs `future` to completion on the calling thread: `Some(output)`, or `None` when it is still
/// pending after [`POLL_LIMIT`] polls (a flash driver that waits for an interrupt would need a
/// real executor).
pub fn block_on<F: Future>(future: F) -> Option<F::Output> {
    let mut future = pin!(future);
    let mut cx = Context::from_waker(Waker::noop());
    for _ in 0..POLL_LIMIT {
        if let Poll::Ready(output) = future.as_mut().poll(&mut cx) {
            return Some(output);
        }
    }
    None
}

/// A blocking `embedded_storage` NOR flash seen through the async `embedded_storage_async` traits:
/// every call does the blocking operation and is ready at once.
#[derive(Debug)]
pub struct Blocking<F>(pub F);

impl<F> Blocking<F> {
    /// The wrapped flash.
    pub fn inner(&self) -> &F {
        &self.0
    }

    /// The wrapped flash, mutably.
    pub fn inner_mut(&mut self) -> &mut F {
        &mut self.0
    }

    /// Gives the wrapped flash back.
    pub fn into_inner(self) -> F {
        self.0
    }
}

impl<F: blocking::ErrorType> nor::ErrorType for Blocking<F> {
    type Error = F::Error;
}

impl<F: blocking::ReadNorFlash> nor::ReadNorFlash for Blocking<F> {
    const READ_SIZE: usize = F::READ_SIZE;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.0.read(offset, bytes)
    }

    fn capacity(&self) -> usize {
        self.0.capacity()
    }
}

impl<F: blocking::NorFlash> nor::NorFlash for Blocking<F> {
    const WRITE_SIZE: usize = F::WRITE_SIZE;
    const ERASE_SIZE: usize = F::ERASE_SIZE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        self.0.erase(from, to)
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        self.0.write(offset, bytes)
    }
}

impl<F: blocking::MultiwriteNorFlash> nor::MultiwriteNorFlash for Blocking<F> {}

/// Write granularity of [`RamFlash`]: one 32-bit word, as many MCU flashes program.
pub const RAM_FLASH_WORD: usize = 4;

/// Why a [`RamFlash`] operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RamFlashError {
    /// Offset or length not a multiple of the write (or erase) size.
    NotAligned,
    /// The range runs past the end of the flash.
    OutOfBounds,
    /// The injected power loss cut the operation; the flash does nothing more until
    /// [`RamFlash::power_on`].
    PowerLoss,
    /// An injected read fault ([`RamFlash::fail_reads_after`]): the read gives no bytes, as a
    /// flash whose read path (ECC, bus) reports an error does.
    ReadFault,
}

impl blocking::NorFlashError for RamFlashError {
    fn kind(&self) -> blocking::NorFlashErrorKind {
        match self {
            RamFlashError::NotAligned => blocking::NorFlashErrorKind::NotAligned,
            RamFlashError::OutOfBounds => blocking::NorFlashErrorKind::OutOfBounds,
            RamFlashError::PowerLoss | RamFlashError::ReadFault => blocking::NorFlashErrorKind::Other,
        }
    }
}

/// A NOR flash of `PAGES` erase pages of `PAGE` bytes, held in RAM.
///
/// NOR semantics: an erase sets a page to `0xFF`; a write can only clear bits (the new byte is
/// the old one AND the written one), in words of [`RAM_FLASH_WORD`] bytes; reads are by byte.
///
/// Fault injection, for the power-loss and corruption tests: [`RamFlash::cut_power_after`] lets
/// the next `n` bytes of writes and erases through (each erased or written byte counts one) and
/// then cuts the power, so an operation stops midway; the cut is clean (the bytes done so far in
/// place, the rest untouched) or, after [`RamFlash::set_tearing`], tears the word being written
/// and leaves the page being erased undefined (the module's power-loss model).
/// [`RamFlash::flip`] changes stored bits behind the store's back. [`RamFlash::fail_reads_after`]
/// makes reads fail on demand (once, a few times, or from then on), the contents untouched: a
/// transient or lasting read error, for the tests of what a failed load may do to the record.
/// [`RamFlash::erase_counts`] gives the erases per page, for the wear figures.
#[derive(Clone, Debug)]
pub struct RamFlash<const PAGES: usize, const PAGE: usize> {
    pages: [[u8; PAGE]; PAGES],
    erases: [u32; PAGES],
    /// Bytes still let through before the power cut; `None` = no cut planned.
    budget: Option<u32>,
    powered: bool,
    /// Bytes written or erased since creation (the cut points of a power-loss sweep).
    touched: u32,
    /// SplitMix64 state of the torn patterns; `None` = clean cuts.
    tearing: Option<u64>,
    /// Read calls since creation.
    reads: u32,
    /// Read calls still let through before the injected read faults start.
    reads_before_fault: u32,
    /// Read calls that fail once the faults start (`u32::MAX`: every one from then on).
    failing_reads: u32,
}

impl<const PAGES: usize, const PAGE: usize> Default for RamFlash<PAGES, PAGE> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const PAGES: usize, const PAGE: usize> RamFlash<PAGES, PAGE> {
    /// Capacity in bytes.
    pub const CAPACITY: usize = PAGES * PAGE;

    /// A fully erased flash, powered, with no cut planned.
    pub const fn new() -> Self {
        Self {
            pages: [[0xFF; PAGE]; PAGES],
            erases: [0; PAGES],
            budget: None,
            powered: true,
            touched: 0,
            tearing: None,
            reads: 0,
            reads_before_fault: 0,
            failing_reads: 0,
        }
    }

    /// Cuts the power after the next `bytes` written or erased bytes.
    pub fn cut_power_after(&mut self, bytes: u32) {
        self.budget = Some(bytes);
    }

    /// `Some(seed)`: from now on a power cut tears the word being written and leaves the page
    /// being erased undefined, in patterns drawn from `seed` (the module's power-loss model);
    /// `None`: clean cuts at a byte, the default.
    pub fn set_tearing(&mut self, seed: Option<u64>) {
        self.tearing = seed;
    }

    /// Lets the next `ok` read calls through, then fails the `failing` read calls after them with
    /// [`RamFlashError::ReadFault`] (`u32::MAX`: every read from then on, until the next call);
    /// `fail_reads_after(0, 0)` cancels. Writes and erases are not affected, and nothing stored
    /// changes.
    pub fn fail_reads_after(&mut self, ok: u32, failing: u32) {
        self.reads_before_fault = ok;
        self.failing_reads = failing;
    }

    /// Read calls since creation (a sweep of read faults over every read of an operation).
    pub fn reads(&self) -> u32 {
        self.reads
    }

    /// Counts one read call; `Err` when an injected read fault takes it.
    fn read_fault(&mut self) -> Result<(), RamFlashError> {
        self.reads = self.reads.wrapping_add(1);
        if self.reads_before_fault > 0 {
            self.reads_before_fault -= 1;
            return Ok(());
        }
        match self.failing_reads {
            0 => Ok(()),
            u32::MAX => Err(RamFlashError::ReadFault),
            n => {
                self.failing_reads = n - 1;
                Err(RamFlashError::ReadFault)
            }
        }
    }

    /// Restores the power (the contents stay as the cut left them) and cancels a planned cut.
    pub fn power_on(&mut self) {
        self.powered = true;
        self.budget = None;
    }

    /// `true` when an injected power cut has happened and [`RamFlash::power_on`] has not run since.
    pub fn is_off(&self) -> bool {
        !self.powered
    }

    /// Bytes written or erased since creation.
    pub fn touched_bytes(&self) -> u32 {
        self.touched
    }

    /// Erases done on each page since creation.
    pub fn erase_counts(&self) -> &[u32; PAGES] {
        &self.erases
    }

    /// XORs the byte at `offset` with `mask` (a bit flip or a corrupted byte); `false` when
    /// `offset` is outside the flash.
    pub fn flip(&mut self, offset: usize, mask: u8) -> bool {
        match self.byte_mut(offset) {
            Some(b) => {
                *b ^= mask;
                true
            }
            None => false,
        }
    }

    /// The byte at `offset`.
    pub fn byte(&self, offset: usize) -> Option<u8> {
        self.pages.get(offset / PAGE.max(1)).and_then(|p| p.get(offset % PAGE.max(1))).copied()
    }

    fn byte_mut(&mut self, offset: usize) -> Option<&mut u8> {
        self.pages.get_mut(offset / PAGE.max(1)).and_then(|p| p.get_mut(offset % PAGE.max(1)))
    }

    /// Lets one byte of a write or erase through, or cuts the power.
    fn spend(&mut self) -> Result<(), RamFlashError> {
        if !self.powered {
            return Err(RamFlashError::PowerLoss);
        }
        match self.budget {
            Some(0) => {
                self.powered = false;
                self.budget = None;
                Err(RamFlashError::PowerLoss)
            }
            Some(n) => {
                self.budget = Some(n - 1);
                self.touched = self.touched.wrapping_add(1);
                Ok(())
            }
            None => {
                self.touched = self.touched.wrapping_add(1);
                Ok(())
            }
        }
    }

    /// The next torn pattern: 64 random bits from the tearing seed's stream.
    fn draw(&mut self) -> u64 {
        match self.tearing.as_mut() {
            Some(state) => splitmix64(state),
            None => 0,
        }
    }

    /// The word at `at` as a write of `new` cut mid-pulse leaves it: each bit the write was
    /// clearing is cleared or not, at random; `old` is the word before the write.
    fn tear_word(&mut self, at: usize, old: &[u8], new: &[u8]) {
        let bits = self.draw().to_le_bytes();
        for (i, ((&o, &n), &r)) in old.iter().zip(new).zip(bits.iter()).enumerate() {
            if let Some(b) = self.byte_mut(at + i) {
                *b = o & !(o & !n & r);
            }
        }
    }

    /// Page `page` as an erase cut after `done` of its bytes leaves it: each byte its old value,
    /// `0xFF`, its old value with random bits set, or a random byte. The erased share is the
    /// erase's progress; the half-erased and random shares are drawn for each cut, so that some
    /// cuts leave a page of old bytes with a few changed, others a page nearly erased with a few
    /// old or random bytes left, others an even mix.
    fn undefine_page(&mut self, page: usize, done: usize) {
        const ONE: u64 = 1 << 16;
        let erased = (done as u64).saturating_mul(ONE) / (PAGE.max(1) as u64);
        let shares = self.draw();
        let rest = ONE.saturating_sub(erased);
        let half = (shares & 0xFFFF) * (rest / 2) / ONE;
        let random = ((shares >> 16) & 0xFFFF) * (rest / 2) / ONE;
        for i in 0..PAGE {
            let x = self.draw();
            let u = x & 0xFFFF;
            let r = (x >> 16) as u8;
            if let Some(b) = self.pages.get_mut(page).and_then(|p| p.get_mut(i)) {
                *b = if u < erased {
                    0xFF
                } else if u < erased + half {
                    *b | r
                } else if u < erased + half + random {
                    r
                } else {
                    *b
                };
            }
        }
    }

    fn range(offset: u32, len: usize, align: usize) -> Result<(usize, usize), RamFlashError> {
        let start = offset as usize;
        if !start.is_multiple_of(align) || !len.is_multiple_of(align) {
            return Err(RamFlashError::NotAligned);
        }
        match start.checked_add(len) {
            Some(end) if end <= Self::CAPACITY => Ok((start, end)),
            _ => Err(RamFlashError::OutOfBounds),
        }
    }
}

impl<const PAGES: usize, const PAGE: usize> blocking::ErrorType for RamFlash<PAGES, PAGE> {
    type Error = RamFlashError;
}

impl<const PAGES: usize, const PAGE: usize> blocking::ReadNorFlash for RamFlash<PAGES, PAGE> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        let (start, _) = Self::range(offset, bytes.len(), 1)?;
        self.read_fault()?;
        for (i, b) in bytes.iter_mut().enumerate() {
            *b = self.byte(start + i).ok_or(RamFlashError::OutOfBounds)?;
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        Self::CAPACITY
    }
}

impl<const PAGES: usize, const PAGE: usize> blocking::NorFlash for RamFlash<PAGES, PAGE> {
    const WRITE_SIZE: usize = RAM_FLASH_WORD;
    const ERASE_SIZE: usize = PAGE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let len = (to as usize).checked_sub(from as usize).ok_or(RamFlashError::OutOfBounds)?;
        let (start, end) = Self::range(from, len, PAGE.max(1))?;
        let mut page_start = start;
        while page_start < end {
            let page = page_start / PAGE.max(1);
            if let Some(count) = self.erases.get_mut(page) {
                *count = count.saturating_add(1);
            }
            let was_on = self.powered;
            let mut done = 0;
            let cut = loop {
                if done == PAGE {
                    break None;
                }
                if let Err(e) = self.spend() {
                    break Some(e);
                }
                done += 1;
            };
            match cut {
                None => {
                    if let Some(p) = self.pages.get_mut(page) {
                        p.fill(0xFF);
                    }
                }
                Some(e) => {
                    if was_on && self.tearing.is_some() {
                        self.undefine_page(page, done);
                    } else if let Some(p) = self.pages.get_mut(page) {
                        p.iter_mut().take(done).for_each(|b| *b = 0xFF);
                    }
                    return Err(e);
                }
            }
            page_start += PAGE;
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let (start, _) = Self::range(offset, bytes.len(), RAM_FLASH_WORD)?;
        for (w, word) in bytes.chunks(RAM_FLASH_WORD).enumerate() {
            let at = start + w * RAM_FLASH_WORD;
            let mut old = [0xFF; RAM_FLASH_WORD];
            for (i, o) in old.iter_mut().enumerate() {
                *o = self.byte(at + i).unwrap_or(0xFF);
            }
            for (i, &new) in word.iter().enumerate() {
                let was_on = self.powered;
                if let Err(e) = self.spend() {
                    if was_on && self.tearing.is_some() {
                        self.tear_word(at, &old, word);
                    }
                    return Err(e);
                }
                if let Some(b) = self.byte_mut(at + i) {
                    *b &= new;
                }
            }
        }
        Ok(())
    }
}

/// Writing a word twice (clearing more bits) is allowed: the AND semantics above.
impl<const PAGES: usize, const PAGE: usize> blocking::MultiwriteNorFlash for RamFlash<PAGES, PAGE> {}
