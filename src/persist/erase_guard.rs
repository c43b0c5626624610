//! [`EraseGuarded`]: a NOR flash whose erases go one page at a time, with the caller's
//! [`EraseGuard`] around each page.
//!
//! An erase of a microcontroller's own flash stalls the core for as long as the page takes (on
//! the STM32F446, up to 4 s for a 128 KiB sector at byte parallelism). A watchdog must outlast
//! the longest single page, not the whole range an erase call asks for: `sequential-storage` and a
//! maintenance reset may erase several pages in one call. [`EraseGuarded`] splits every erase into
//! its pages and calls [`EraseGuard::before_page_erase`] (feed the watchdog) before each and
//! [`EraseGuard::after_page_erase`] (feed it again, flush a data cache that may hold the page's old
//! contents) after each, whether the page erase succeeded or not. Reads and writes go straight
//! through.

use embedded_storage::nor_flash::{ErrorType, MultiwriteNorFlash, NorFlash, ReadNorFlash};

/// What runs around each page erase of an [`EraseGuarded`] flash.
pub trait EraseGuard {
    /// Just before the page at `offset` is erased (e.g. feed the watchdog).
    fn before_page_erase(&mut self, offset: u32);

    /// Just after the page at `offset` was erased, or failed to (e.g. feed the watchdog again,
    /// flush the data cache).
    fn after_page_erase(&mut self, offset: u32);
}

/// `flash` with every erase split into its pages, `guard` called around each.
#[derive(Debug)]
pub struct EraseGuarded<F, G> {
    flash: F,
    guard: G,
}

impl<F, G> EraseGuarded<F, G> {
    /// Wraps `flash`, erasing through `guard`.
    pub const fn new(flash: F, guard: G) -> Self {
        Self { flash, guard }
    }

    /// The flash and the guard back.
    pub fn into_parts(self) -> (F, G) {
        (self.flash, self.guard)
    }

    /// The guard.
    pub const fn guard(&self) -> &G {
        &self.guard
    }
}

impl<F: ErrorType, G> ErrorType for EraseGuarded<F, G> {
    type Error = F::Error;
}

impl<F: ReadNorFlash, G> ReadNorFlash for EraseGuarded<F, G> {
    const READ_SIZE: usize = F::READ_SIZE;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.flash.read(offset, bytes)
    }

    fn capacity(&self) -> usize {
        self.flash.capacity()
    }
}

impl<F: NorFlash, G: EraseGuard> NorFlash for EraseGuarded<F, G> {
    const WRITE_SIZE: usize = F::WRITE_SIZE;
    const ERASE_SIZE: usize = F::ERASE_SIZE;

    /// Erases `from..to` page by page. A range that is not page-aligned goes to the inner flash
    /// whole, which refuses it with its own error.
    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let page = u32::try_from(F::ERASE_SIZE).unwrap_or(u32::MAX).max(1);
        if !from.is_multiple_of(page) || !to.is_multiple_of(page) || to <= from {
            return self.flash.erase(from, to);
        }
        let mut start = from;
        while start < to {
            let end = start.saturating_add(page);
            self.guard.before_page_erase(start);
            let result = self.flash.erase(start, end);
            self.guard.after_page_erase(start);
            result?;
            start = end;
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        self.flash.write(offset, bytes)
    }
}

impl<F: MultiwriteNorFlash, G: EraseGuard> MultiwriteNorFlash for EraseGuarded<F, G> {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::persist::flash::{RamFlash, RamFlashError};

    /// Records the order of the guard's calls.
    #[derive(Default)]
    struct Log {
        calls: heapless::Vec<(bool, u32), 16>,
    }

    impl EraseGuard for Log {
        fn before_page_erase(&mut self, offset: u32) {
            self.calls.push((true, offset)).unwrap();
        }
        fn after_page_erase(&mut self, offset: u32) {
            self.calls.push((false, offset)).unwrap();
        }
    }

    #[test]
    fn a_range_is_erased_page_by_page_inside_the_guard() {
        let mut inner = RamFlash::<4, 256>::default();
        inner.write(0, &[0; 1024]).unwrap();
        let mut flash = EraseGuarded::new(inner, Log::default());
        flash.erase(256, 1024).unwrap();
        let calls = &flash.guard().calls;
        assert_eq!(
            calls.as_slice(),
            &[(true, 256), (false, 256), (true, 512), (false, 512), (true, 768), (false, 768)]
        );
        let (mut inner, _) = flash.into_parts();
        let mut bytes = [0u8; 1024];
        inner.read(0, &mut bytes).unwrap();
        assert!(bytes[..256].iter().all(|&b| b == 0));
        assert!(bytes[256..].iter().all(|&b| b == 0xFF));
        assert_eq!(inner.erase_counts(), &[0, 1, 1, 1]);
    }

    #[test]
    fn a_failed_page_still_closes_the_guard_and_stops_the_erase() {
        let mut inner = RamFlash::<4, 256>::default();
        inner.cut_power_after(300); // the first page, then 44 bytes of the second
        let mut flash = EraseGuarded::new(inner, Log::default());
        assert_eq!(flash.erase(0, 1024), Err(RamFlashError::PowerLoss));
        assert_eq!(flash.guard().calls.as_slice(), &[(true, 0), (false, 0), (true, 256), (false, 256)]);
    }

    #[test]
    fn a_misaligned_range_is_refused_by_the_inner_flash_without_the_guard() {
        let mut flash = EraseGuarded::new(RamFlash::<4, 256>::default(), Log::default());
        assert_eq!(flash.erase(10, 256), Err(RamFlashError::NotAligned));
        assert!(flash.guard().calls.is_empty());
    }
}
