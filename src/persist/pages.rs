//! The store's pages checked for the remains of an interrupted erase before the first operation
//! after power-up ([`check_pages`]).
//!
//! **Why.** An erase cut by a power loss leaves its page undefined: old bytes, `0xFF` and random
//! bits mixed over the whole page, not a clean prefix (`docs/persistence.md`, "Power-loss
//! model"). `sequential-storage` 8 reads a page's state from its first and last read words alone
//! and trusts the rest. An undefined page that reads *open* is written into, and the item lands
//! on garbage: the save returns `Ok` and is lost. One that reads *partially open* beside the
//! real one makes the map lose the current record and refuse every later save as corrupt. One
//! that reads *closed* after the partially open page makes the crate's repair take it for a
//! migration cut midway: it erases the partially open page, which holds the items just migrated,
//! and migrates again from the garbage. The pages the crate erases are the page after the one
//! being filled (recycled once its live items are copied) and every page of a maintenance reset;
//! the items of such a page are either copied already or meant to go, so its remains can be
//! erased.
//!
//! **What a page the crate wrote looks like** (its "Inner workings"): a start marker word and an
//! end marker word (a page reads *marked* at either end when that read word has at least four zero
//! bits), between them items one after the other from the start, each an 8-byte header (data
//! CRC-32, length, CRC-16 of the length) and its data padded to the word, then erased bytes. The
//! crate writes an item only where the walk over the headers stops (the first word-aligned header
//! slot that is all `0xFF`), so every byte after that point is erased, and the walk steps over
//! few bytes that are not headers (a header torn by an earlier cut: at most one header's length
//! each). The check:
//!
//! 1. a page whose start reads unmarked holds no items (the crate marks a page before it writes
//!    one): erased when a byte of it is not `0xFF`;
//! 2. of several pages that read partially open (the crate keeps one), the one kept has its bytes
//!    after the walk's stop erased, then its end marker word erased, then the fewest bytes the
//!    walk steps over; the others are erased;
//! 3. the partially open page, when a byte after its walk's stop is not erased and the page after
//!    it is: closed (its end marker written), so that the next item goes to the next page and
//!    nothing written lands on that byte. A bit flipped in the erased tail of the page being
//!    filled is repaired this way without losing an item;
//! 4. the page after the partially open one, when it reads closed but a byte after its walk's
//!    stop is not erased or the walk steps over more than [`STRAY_LIMIT`] bytes: erased (it is
//!    the recycled page, its live items already in the partially open one).
//!
//! A page that reads closed elsewhere is left as it is: its items are read through their CRCs,
//! and its valid ones are migrated when its turn comes. A page the crate would read as a
//! half-done erase (start unmarked, end marked) falls under rule 1. The check reads the whole
//! range once; it writes only to repair.

use core::ops::Range;

use embedded_storage::nor_flash::NorFlash;

/// Bytes of an item header.
const HEADER_LEN: u32 = 8;

/// Bytes the walk over a page's headers may step over (not a header, or a header whose length
/// runs past the page) on a page the crate wrote: eight headers torn by earlier cuts.
pub const STRAY_LIMIT: u32 = 8 * HEADER_LEN;

/// The crate's word: the larger of the write and the read size.
const fn word<F: NorFlash>() -> u32 {
    let w = if F::WRITE_SIZE > F::READ_SIZE { F::WRITE_SIZE } else { F::READ_SIZE };
    w as u32
}

const fn round_up(n: u32, to: u32) -> u32 {
    match to {
        0 => n,
        _ => n.div_ceil(to).saturating_mul(to),
    }
}

/// `sequential-storage` 8's CRC-16 of an item's length (its `crc16`: polynomial 0x1a2e
/// reflected, initial 0xFFFF, final XOR 0xFFFF, never 0xFFFF).
fn length_crc(bytes: [u8; 2]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    for byte in bytes {
        crc ^= u16::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0x1a2e } else { crc >> 1 };
        }
    }
    match crc ^ 0xFFFF {
        0xFFFF => 0xFFFE,
        other => other,
    }
}

/// What the checks need of one page.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Page {
    start: u32,
    start_marked: bool,
    end_marked: bool,
    /// Where the walk over the headers stops (the crate's next item's place).
    stop: u32,
    /// Bytes the walk stepped over that were not headers.
    stray: u32,
    /// Every byte from the walk's stop to the end marker word is `0xFF`.
    tail_erased: bool,
    /// The end marker word is all `0xFF`.
    end_word_erased: bool,
}

struct Reader<'f, F> {
    flash: &'f mut F,
}

impl<F: NorFlash> Reader<'_, F> {
    /// Reads `buf.len()` bytes at `at` (`buf.len()` a multiple of the read size).
    fn read(&mut self, at: u32, buf: &mut [u8]) -> Result<(), F::Error> {
        self.flash.read(at, buf)
    }

    /// Whether the first read word at `at` has at least four zero bits (the crate's marker rule).
    fn marked(&mut self, at: u32) -> Result<bool, F::Error> {
        let mut buf = [0xFF; 32];
        let n = F::READ_SIZE.clamp(1, buf.len());
        let slice = buf.get_mut(..n).unwrap_or_default();
        self.read(at, slice)?;
        Ok(slice.iter().map(|b| b.count_zeros()).sum::<u32>() >= 4)
    }

    /// Whether every byte of `from..to` is `0xFF` (both multiples of the word).
    fn erased(&mut self, from: u32, to: u32) -> Result<bool, F::Error> {
        let mut buf = [0u8; 32];
        let mut at = from;
        while at < to {
            let n = (to - at).min(buf.len() as u32);
            let slice = buf.get_mut(..n as usize).unwrap_or_default();
            self.read(at, slice)?;
            if slice.iter().any(|&b| b != 0xFF) {
                return Ok(false);
            }
            at += n;
        }
        Ok(true)
    }

    /// The page at `start`, as the checks see it.
    fn page(&mut self, start: u32, size: u32) -> Result<Page, F::Error> {
        let w = word::<F>();
        let end = start.saturating_add(size);
        let data_end = end.saturating_sub(w);
        let header_len = round_up(HEADER_LEN, w);
        let start_marked = self.marked(start)?;
        let end_marked = self.marked(end.saturating_sub(F::READ_SIZE as u32))?;
        let mut at = start.saturating_add(w);
        let mut stray = 0u32;
        let mut header = [0u8; 32];
        loop {
            if at.saturating_add(header_len) > data_end {
                break;
            }
            let h = header.get_mut(..header_len as usize).unwrap_or_default();
            self.read(at, h)?;
            if h.iter().all(|&b| b == 0xFF) {
                break;
            }
            let (len, crc) = match h {
                [_, _, _, _, l0, l1, c0, c1, ..] => ([*l0, *l1], u16::from_le_bytes([*c0, *c1])),
                _ => ([0xFF, 0xFF], 0xFFFF),
            };
            let next = at.saturating_add(header_len).saturating_add(round_up(u32::from(u16::from_le_bytes(len)), w));
            if length_crc(len) == crc && next <= data_end {
                at = next;
            } else {
                stray = stray.saturating_add(w);
                at = at.saturating_add(w);
            }
        }
        let tail_erased = self.erased(at.min(data_end), data_end)?;
        let end_word_erased = self.erased(data_end, end)?;
        Ok(Page { start, start_marked, end_marked, stop: at, stray, tail_erased, end_word_erased })
    }
}

/// Most pages of a store's range ([`super::HealthStore::new`] refuses a larger one): the check
/// keeps what it needs of each page on the stack.
pub const MAX_PAGES: usize = 16;

/// What [`check_pages`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PageRepair {
    /// Pages erased as the remains of an interrupted erase.
    pub erased: u32,
    /// Partially open pages closed because a byte after their last item is not erased.
    pub closed: u32,
}

/// Checks the pages of `range` (erase-page aligned, two to [`MAX_PAGES`] pages) for the remains
/// of an interrupted erase, and erases or closes them (module doc).
pub fn check_pages<F: NorFlash>(flash: &mut F, range: Range<u32>) -> Result<PageRepair, F::Error> {
    let size = u32::try_from(F::ERASE_SIZE).unwrap_or(u32::MAX).max(1);
    let count = ((range.end.saturating_sub(range.start)) / size).min(MAX_PAGES as u32) as usize;
    let mut pages = [None::<Page>; MAX_PAGES];
    let mut repair = PageRepair::default();
    for (i, slot) in pages.iter_mut().enumerate().take(count) {
        let start = range.start.saturating_add(size.saturating_mul(i as u32));
        *slot = Some(Reader { flash: &mut *flash }.page(start, size)?);
    }
    // 1: an unmarked page holds no items: erased unless it is erased already
    for slot in pages.iter_mut().take(count) {
        if let Some(p) = *slot {
            if !p.start_marked {
                let erased = Reader { flash: &mut *flash }.erased(p.start, p.start.saturating_add(size))?;
                if !erased {
                    flash.erase(p.start, p.start.saturating_add(size))?;
                    repair.erased += 1;
                }
                *slot = None;
            }
        }
    }
    // 2: one partially open page, the one that looks most like a page the crate wrote
    let partial = |p: &Option<Page>| matches!(p, Some(q) if !q.end_marked);
    let keep = pages
        .iter()
        .take(count)
        .enumerate()
        .filter_map(|(i, p)| p.filter(|_| partial(p)).map(|q| (i, (!q.tail_erased, !q.end_word_erased, q.stray))))
        .min_by_key(|&(_, score)| score)
        .map(|(i, _)| i);
    for (i, slot) in pages.iter_mut().enumerate().take(count) {
        if partial(slot) && Some(i) != keep {
            if let Some(p) = slot.take() {
                flash.erase(p.start, p.start.saturating_add(size))?;
                repair.erased += 1;
            }
        }
    }
    let Some(i) = keep else { return Ok(repair) };
    let next = (i + 1) % count.max(1);
    // 3: the partially open page written past its last item, the page after it erased
    if let (Some(p), Some(None)) = (pages.get(i).copied().flatten(), pages.get(next)) {
        if !p.tail_erased {
            let w = word::<F>();
            let zeros = [0u8; 32];
            let end_word = p.start.saturating_add(size).saturating_sub(w);
            flash.write(end_word, zeros.get(..w as usize).unwrap_or_default())?;
            repair.closed += 1;
        }
    }
    // 4: the page after it, closed but not as the crate closes a page
    if let Some(p) = pages.get(next).copied().flatten() {
        if p.end_marked && (!p.tail_erased || p.stray > STRAY_LIMIT) {
            flash.erase(p.start, p.start.saturating_add(size))?;
            repair.erased += 1;
        }
    }
    Ok(repair)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conditioning::ConditionedWindow;
    use crate::optimizer::rng::splitmix64;
    use crate::persist::store::MAX_KEPT_SAMPLES;
    use crate::persist::tests::{is, record_after};
    use crate::persist::{window_encoded_len, HealthStore, RamFlash};

    fn page_of<const N: usize, const P: usize>(flash: &mut RamFlash<N, P>, i: usize) -> Page {
        Reader { flash }.page((i * P) as u32, P as u32).unwrap()
    }

    fn image<const N: usize, const P: usize>(flash: &RamFlash<N, P>) -> Vec<u8> {
        (0..N * P).map(|i| flash.byte(i).unwrap()).collect()
    }

    /// The walk reads a record's item as the crate wrote it: its length, its length's CRC-16,
    /// its end where the next item goes.
    #[test]
    fn the_walk_reads_the_items_the_crate_writes() {
        let mut flash = RamFlash::<2, 2048>::new();
        HealthStore::new(&mut flash, 0..4096).unwrap().save(&record_after(2)).unwrap();
        let header: Vec<u8> = (4..12).map(|i| flash.byte(i).unwrap()).collect();
        assert_eq!(u16::from_le_bytes([header[4], header[5]]), 857, "key and record");
        assert_eq!(length_crc([header[4], header[5]]), u16::from_le_bytes([header[6], header[7]]));
        let page = page_of(&mut flash, 0);
        assert_eq!((page.stop, page.stray), (4 + 8 + 860, 0), "marker word, header, data to the word");
        assert!(page.start_marked && !page.end_marked && page.tail_erased && page.end_word_erased);
        let open = page_of(&mut flash, 1);
        assert!(!open.start_marked && !open.end_marked && open.tail_erased);
    }

    /// Random sequences of the store's operations (saves, archives, window keeps, resets; four
    /// seeds) on three geometries: after every operation the check finds nothing to repair and
    /// leaves every byte as it was.
    #[test]
    fn pages_the_crate_wrote_are_never_repaired() {
        fn run<const N: usize, const P: usize>(seed: u64) -> usize {
            let window = |n: usize, phase: f32| {
                ConditionedWindow::<600>::from_samples((0..n).map(|j| 1.5 + libm::sinf(0.02 * j as f32 + phase)))
                    .unwrap()
            };
            let mut buffer = vec![0u8; window_encoded_len(MAX_KEPT_SAMPLES)];
            let mut state = seed;
            let mut flash = RamFlash::<N, P>::new();
            let range = 0..(N * P) as u32;
            let mut checks = 0;
            for step in 0..120u32 {
                {
                    let mut s = HealthStore::new(&mut flash, range.clone()).unwrap();
                    match splitmix64(&mut state) % 16 {
                        0 => s.reset().unwrap(),
                        1 => s.archive(&record_after(step)).unwrap(),
                        2 if N >= 8 => {
                            let n = [100, 600][(step % 2) as usize];
                            s.keep_window((step % 2) as u8, &window(n, step as f32), 1.0, &mut buffer).unwrap()
                        }
                        _ => s.save(&record_after(step)).unwrap(),
                    }
                }
                let before = image(&flash);
                let mut copy = flash.clone();
                assert_eq!(check_pages(&mut copy, range.clone()), Ok(PageRepair::default()), "{N}×{P}, step {step}");
                assert!(image(&copy) == before, "{N}×{P}, step {step}: the check wrote");
                checks += 1;
            }
            checks
        }
        let mut checks = 0;
        for seed in [1u64, 2, 3, 4] {
            checks += run::<4, 2048>(seed) + run::<2, 4096>(seed) + run::<8, 2048>(seed);
        }
        assert_eq!(checks, 4 * 3 * 120);
    }

    /// A bit flipped in the erased tail of the page being filled: the page is closed, nothing is
    /// lost, and the next save goes to the next page and loads; a second check finds nothing.
    /// (Erasing the page would lose the current record; writing into it would lose the save.)
    #[test]
    fn a_flipped_bit_after_the_last_item_closes_the_page_and_loses_nothing() {
        for (bit, at) in [(0x01u8, 1500usize), (0x80, 2040), (0x10, 900)] {
            let mut s = HealthStore::new(RamFlash::<4, 2048>::new(), 0..8192).unwrap();
            s.save(&record_after(1)).unwrap();
            s.archive(&record_after(50)).unwrap();
            s.save(&record_after(2)).unwrap(); // page 1: the archive's page is full
            let mut flash = s.into_flash();
            let p = page_of(&mut flash, 1);
            assert!(p.start_marked && !p.end_marked && (2048 + at) as u32 >= p.stop, "{at}: after the last item");
            flash.flip(2048 + at, bit);
            assert_eq!(check_pages(&mut flash, 0..8192), Ok(PageRepair { erased: 0, closed: 1 }), "{at}");
            assert!(page_of(&mut flash, 1).end_marked, "{at}: closed");
            let mut s = HealthStore::new(flash, 0..8192).unwrap();
            assert!(is(&s.load(), Some(&record_after(2))), "{at}");
            assert!(is(&s.load_archive(), Some(&record_after(50))), "{at}");
            s.save(&record_after(3)).unwrap();
            let mut flash = s.into_flash();
            assert_eq!(check_pages(&mut flash, 0..8192), Ok(PageRepair::default()), "{at}");
            let mut s = HealthStore::new(flash, 0..8192).unwrap();
            assert!(is(&s.load(), Some(&record_after(3))), "{at}");
            assert!(is(&s.load_archive(), Some(&record_after(50))), "{at}");
        }
    }

    /// A byte that is not `0xFF` in a page that reads open (its start unmarked): the page is
    /// erased, and what the store holds stays.
    #[test]
    fn a_stray_byte_in_an_open_page_is_erased() {
        let mut s = HealthStore::new(RamFlash::<4, 2048>::new(), 0..8192).unwrap();
        s.save(&record_after(4)).unwrap();
        let mut flash = s.into_flash();
        flash.flip(3 * 2048 + 700, 0x24);
        assert_eq!(check_pages(&mut flash, 0..8192), Ok(PageRepair { erased: 1, closed: 0 }));
        assert!((3 * 2048..4 * 2048).all(|i| flash.byte(i) == Some(0xFF)));
        assert!(is(&HealthStore::new(flash, 0..8192).unwrap().load(), Some(&record_after(4))));
    }
}
