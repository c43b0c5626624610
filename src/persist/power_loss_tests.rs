//! Power loss as a NOR flash suffers it: a cut tears the word being written (a random subset of
//! the bits its write was clearing) and leaves the page being erased undefined
//! ([`RamFlash::set_tearing`]). First the tearing itself, then one sweep per store operation the
//! firmwares run (`save`, `reset`, `archive`, `keep_window`): the power cut at every word written
//! and at [`ERASE_POINTS`] points through every page erased, for [`SEEDS`] torn patterns each,
//! then power on, what a load gives, and the next boot's operation.

use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};

use super::flash::RAM_FLASH_WORD;
use super::store::MAX_KEPT_SAMPLES;
use super::tests::{is, record_after};
use super::*;
use crate::conditioning::ConditionedWindow;
use crate::optimizer::rng::splitmix64_mix;

/// Seeds of the torn patterns at each cut point.
const SEEDS: [u64; 3] = [0x5EED_0001, 0x5EED_0002, 0x5EED_0003];

/// Cut points through each page an operation erases (its first byte, its last, and evenly
/// between): the page's share of erased bytes follows the point.
const ERASE_POINTS: usize = 33;

// ---- the tearing itself ----------------------------------------------------------------------

/// A write cut in its third word: the two words before are written, the words after untouched,
/// and the third holds only bits of the old word and the new one, each bit it was clearing
/// cleared or not at random: over the seeds, a torn word is neither always the old word nor
/// always the new one, nor a byte prefix of it.
#[test]
fn a_cut_write_tears_its_word_into_a_random_subset_of_the_bits_it_clears() {
    let old: [u8; 16] =
        [0xF0, 0xFF, 0x3C, 0xFF, 0xFF, 0xAA, 0xFF, 0x0F, 0xFE, 0xEF, 0x77, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF];
    let new: [u8; 16] =
        [0x00, 0x0F, 0x14, 0x81, 0x22, 0x00, 0x7E, 0x0C, 0x10, 0x01, 0x40, 0x00, 0x12, 0x34, 0x56, 0x78];
    let (mut partial, mut unchanged, mut complete, mut mixed_bytes) = (0, 0, 0, 0);
    for s in 0..64u64 {
        let mut flash = RamFlash::<2, 256>::new();
        flash.write(0, &old).unwrap();
        flash.set_tearing(Some(splitmix64_mix(s)));
        flash.cut_power_after(8 + (s % 4) as u32); // a byte of the third word
        assert_eq!(flash.write(0, &new), Err(RamFlashError::PowerLoss));
        let got: Vec<u8> = (0..16).map(|i| flash.byte(i).unwrap()).collect();
        for i in 0..8 {
            assert_eq!(got[i], old[i] & new[i], "seed {s}: byte {i} written");
        }
        for i in 12..16 {
            assert_eq!(got[i], old[i], "seed {s}: byte {i} untouched");
        }
        for i in 8..12 {
            // only bits the write was clearing may be cleared, and no bit is set
            let clearing = old[i] & !new[i];
            assert_eq!(got[i] | clearing, old[i], "seed {s}: byte {i}");
        }
        let word = &got[8..12];
        let (old_word, new_word): (Vec<u8>, Vec<u8>) = (8..12).map(|i| (old[i], old[i] & new[i])).unzip();
        if word == old_word.as_slice() {
            unchanged += 1;
        } else if word == new_word.as_slice() {
            complete += 1;
        } else {
            partial += 1;
        }
        // a byte prefix would leave every byte old or new: a torn word has bytes that are neither
        mixed_bytes += (8..12).filter(|&i| got[i] != old[i] && got[i] != old[i] & new[i]).count();
    }
    assert!(partial > 50, "torn words: {partial} partial, {unchanged} unchanged, {complete} complete");
    assert!(mixed_bytes > 50, "bytes neither old nor written: {mixed_bytes}");
    let mut flash = RamFlash::<2, 256>::new();
    flash.write(0, &old).unwrap();
    flash.cut_power_after(9);
    assert!(flash.write(0, &new).is_err());
    assert_eq!(flash.byte(8), Some(old[8] & new[8]), "a clean cut keeps the byte prefix");
    assert_eq!(flash.byte(9), Some(old[9]));
}

/// An erase cut in its second page: the first page is erased, the pages after untouched, and the
/// second holds old bytes, `0xFF`, half-erased bytes (old bits kept, some set) and other bytes,
/// not a clean prefix, with a share of erased bytes that follows the cut's point in the page.
/// The same seed gives the same page.
#[test]
fn a_cut_erase_leaves_its_page_undefined() {
    const PAGE: usize = 1024;
    let mut base = RamFlash::<3, PAGE>::new();
    let image: Vec<u8> = (0..3 * PAGE).map(|i| splitmix64_mix(i as u64) as u8 & 0x7E).collect();
    base.write(0, &image).unwrap();
    let mut kinds = [0usize; 4]; // old, 0xFF, half-erased, other
    for (k, at) in [0, PAGE / 4, PAGE / 2, 3 * PAGE / 4, PAGE - 1].into_iter().enumerate() {
        for s in 0..4u64 {
            let mut flash = base.clone();
            flash.set_tearing(Some(splitmix64_mix(100 * k as u64 + s)));
            flash.cut_power_after((PAGE + at) as u32);
            assert_eq!(flash.erase(0, 3 * PAGE as u32), Err(RamFlashError::PowerLoss));
            assert!((0..PAGE).all(|i| flash.byte(i) == Some(0xFF)), "the first page is erased");
            assert!((2 * PAGE..3 * PAGE).all(|i| flash.byte(i) == Some(image[i])), "the third is untouched");
            let page: Vec<u8> = (PAGE..2 * PAGE).map(|i| flash.byte(i).unwrap()).collect();
            let old = &image[PAGE..2 * PAGE];
            let erased = page.iter().filter(|&&b| b == 0xFF).count();
            let kept = page.iter().zip(old).filter(|(b, o)| b == o).count();
            let half = page.iter().zip(old).filter(|(&b, &o)| b != o && b != 0xFF && b & o == o).count();
            kinds[0] += kept;
            kinds[1] += erased;
            kinds[2] += half;
            kinds[3] += PAGE - kept - erased - half;
            // the erased share follows the erase's progress
            let progress = at as f64 / PAGE as f64;
            let share = erased as f64 / PAGE as f64;
            assert!((share - progress).abs() < 0.08, "cut at {at}: erased share {share:.2}");
            if at == 0 {
                assert!(kept > 0 && erased < PAGE / 50, "a cut as the erase starts leaves old bytes");
            }
            let mut again = base.clone();
            again.set_tearing(Some(splitmix64_mix(100 * k as u64 + s)));
            again.cut_power_after((PAGE + at) as u32);
            let _ = again.erase(0, 3 * PAGE as u32);
            assert!((0..3 * PAGE).all(|i| again.byte(i) == flash.byte(i)), "the same seed replays");
        }
    }
    assert!(kinds.iter().all(|&n| n > 200), "old, erased, half-erased, other bytes: {kinds:?}");
    // not a clean prefix: some cut leaves an erased byte after an old one
    let mut flash = base.clone();
    flash.set_tearing(Some(7));
    flash.cut_power_after((PAGE / 2) as u32);
    let _ = flash.erase(PAGE as u32, 2 * PAGE as u32);
    let page: Vec<u8> = (PAGE..2 * PAGE).map(|i| flash.byte(i).unwrap()).collect();
    let first_old = page.iter().zip(&image[PAGE..]).position(|(b, o)| b == o).unwrap();
    assert!(page[first_old..].contains(&0xFF), "an erased byte after an old one");
    // without tearing, a cut erase leaves an erased prefix
    let mut flash = base.clone();
    flash.cut_power_after((PAGE + 10) as u32);
    let _ = flash.erase(0, 3 * PAGE as u32);
    assert!((PAGE..PAGE + 10).all(|i| flash.byte(i) == Some(0xFF)));
    assert!((PAGE + 10..2 * PAGE).all(|i| flash.byte(i) == Some(image[i])));
}

// ---- the sweeps --------------------------------------------------------------------------------

/// One store operation, run on any flash (the recording pass and the cut runs).
trait Operation {
    fn run<F: NorFlash>(&self, store: &mut HealthStore<F>) -> Result<(), StoreError>;
}

/// A NOR flash that logs the writes and erases it passes on: the operation's cut points.
struct Recorder<'f, F> {
    flash: &'f mut F,
    /// (erase?, offset, length)
    log: Vec<(bool, u32, u32)>,
}

impl<F: ErrorType> ErrorType for Recorder<'_, F> {
    type Error = F::Error;
}

impl<F: ReadNorFlash> ReadNorFlash for Recorder<'_, F> {
    const READ_SIZE: usize = F::READ_SIZE;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.flash.read(offset, bytes)
    }
    fn capacity(&self) -> usize {
        self.flash.capacity()
    }
}

impl<F: NorFlash> NorFlash for Recorder<'_, F> {
    const WRITE_SIZE: usize = F::WRITE_SIZE;
    const ERASE_SIZE: usize = F::ERASE_SIZE;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        self.log.push((true, from, to - from));
        self.flash.erase(from, to)
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        self.log.push((false, offset, bytes.len() as u32));
        self.flash.write(offset, bytes)
    }
}

/// The byte budgets that cut `op` on `base` at each of its points: the first byte of every word
/// written (the cut tears that word) and [`ERASE_POINTS`] bytes through every page erased.
fn cut_points<const N: usize, const P: usize>(base: &RamFlash<N, P>, op: &impl Operation) -> Vec<u32> {
    let mut flash = base.clone();
    let mut recorder = Recorder { flash: &mut flash, log: Vec::new() };
    {
        let mut store = HealthStore::new(&mut recorder, 0..RamFlash::<N, P>::CAPACITY as u32).unwrap();
        op.run(&mut store).expect("the operation completes without a cut");
    }
    let mut points = Vec::new();
    let mut spent = 0u32;
    for &(erase, _, len) in &recorder.log {
        if erase {
            for page in (0..len).step_by(P) {
                for j in 0..ERASE_POINTS {
                    points.push(spent + page + (j * (P - 1) / (ERASE_POINTS - 1)) as u32);
                }
            }
        } else {
            points.extend((0..len).step_by(RAM_FLASH_WORD).map(|w| spent + w));
        }
        spent += len;
    }
    points
}

/// Runs `op` on a copy of `base` cut at each point with each seed, powers on and hands the
/// flash to `check` (with a label for its messages); returns the number of cut runs.
fn sweep<const N: usize, const P: usize>(
    base: &RamFlash<N, P>,
    op: &impl Operation,
    mut check: impl FnMut(RamFlash<N, P>, &str),
) -> usize {
    let points = cut_points(base, op);
    for &cut in &points {
        for &seed in &SEEDS {
            let mut flash = base.clone();
            flash.set_tearing(Some(splitmix64_mix(seed ^ u64::from(cut))));
            flash.cut_power_after(cut);
            {
                let mut store = HealthStore::new(&mut flash, 0..RamFlash::<N, P>::CAPACITY as u32).unwrap();
                assert!(op.run(&mut store).is_err(), "cut {cut} seed {seed:#x}: a cut operation fails");
            }
            assert!(flash.is_off());
            flash.power_on();
            check(flash, &format!("cut at byte {cut} ({} points), seed {seed:#x}", points.len()));
        }
    }
    points.len() * SEEDS.len()
}

fn open<const N: usize, const P: usize>(flash: RamFlash<N, P>) -> HealthStore<RamFlash<N, P>> {
    HealthStore::new(flash, 0..RamFlash::<N, P>::CAPACITY as u32).unwrap()
}

struct Save(HealthRecord);
impl Operation for Save {
    fn run<F: NorFlash>(&self, store: &mut HealthStore<F>) -> Result<(), StoreError> {
        store.save(&self.0)
    }
}

struct Reset;
impl Operation for Reset {
    fn run<F: NorFlash>(&self, store: &mut HealthStore<F>) -> Result<(), StoreError> {
        store.reset()
    }
}

struct Archive(HealthRecord);
impl Operation for Archive {
    fn run<F: NorFlash>(&self, store: &mut HealthStore<F>) -> Result<(), StoreError> {
        store.archive(&self.0)
    }
}

/// The sweeps' commissioning window: 600 block means, kept as four chunks (three full, one short),
/// so that a keep crosses pages on the small flash of the sweep.
type Window = ConditionedWindow<600>;

fn window(phase: f32) -> Window {
    ConditionedWindow::from_samples((0..600).map(|j| 4.0 * libm::sinf(0.013 * j as f32 + phase) + 4.5)).unwrap()
}

const WINDOW_BUFFER: usize = window::window_encoded_len(MAX_KEPT_SAMPLES);

struct Keep(u8, f32);
impl Operation for Keep {
    fn run<F: NorFlash>(&self, store: &mut HealthStore<F>) -> Result<(), StoreError> {
        store.keep_window(self.0, &window(self.1), self.1, &mut [0u8; WINDOW_BUFFER])
    }
}

/// A flash of `N` pages of `P` bytes holding the saves of `record_after(1..=n)`, and, when
/// `archived`, [`archived`] kept after the first.
fn saved<const N: usize, const P: usize>(n: u32, archived: bool) -> RamFlash<N, P> {
    let mut s = open(RamFlash::<N, P>::new());
    for i in 1..=n {
        s.save(&record_after(i)).unwrap();
        if i == 1 && archived {
            s.archive(&self::archived()).unwrap();
        }
    }
    s.into_flash()
}

/// The record the save sweeps keep archived: an item that is saved once and migrated each time
/// its page is recycled.
fn archived() -> HealthRecord {
    record_after(77)
}

/// The save sweep on `N` pages of `P` bytes, with a record archived after the first save, for
/// each count of earlier saves in `earlier`: returns the cut runs and how many left the new
/// record complete.
fn torn_saves<const N: usize, const P: usize>(earlier: core::ops::RangeInclusive<u32>) -> (usize, usize) {
    let (mut runs, mut new_after_cut) = (0, 0);
    let archive = archived();
    for n in earlier {
        let old = (n > 0).then(|| record_after(n));
        let kept = (n > 0).then_some(&archive);
        let new = record_after(n + 1);
        runs += sweep(&saved::<N, P>(n, true), &Save(new.clone()), |flash, at| {
            let mut s = open(flash);
            let loaded = s.load();
            if is(&loaded, Some(&new)) {
                new_after_cut += 1;
            } else {
                assert!(is(&loaded, old.as_ref()), "{N} pages, n {n}, {at}: loaded {loaded:?}");
            }
            assert!(is(&s.load_archive(), kept), "{N} pages, n {n}, {at}: the archive");
            let next = record_after(n + 2);
            s.save(&next).unwrap_or_else(|e| panic!("{N} pages, n {n}, {at}: the next save: {e:?}"));
            let mut s = open(s.into_flash());
            assert!(is(&s.load(), Some(&next)), "{N} pages, n {n}, {at}: the next save loads");
            assert!(is(&s.load_archive(), kept), "{N} pages, n {n}, {at}: the archive after the next save");
        });
    }
    (runs, new_after_cut)
}

/// A power cut at every point of a save, torn words and undefined pages, with a record archived
/// after the first save (an item that only migrates): on four pages of 2 KiB (a record and the
/// archive fill one) and on two pages of 4 KiB, as the board's range (every page change there
/// migrates the current record and the archive and erases the page they came from), each after
/// 0 to 9 earlier saves (the first save, pages filling, page changes with the erase of the page
/// after, the wrap to page 0): the load gives the old record or the new one and the archive; the
/// next boot's save completes and loads, and the archive is still there.
#[test]
fn a_torn_save_leaves_the_old_or_the_new_record_and_the_next_save_works() {
    let (four, new4) = torn_saves::<4, 2048>(0..=9);
    let (two, new2) = torn_saves::<2, 4096>(0..=9);
    println!("torn saves: {four} cut runs on 4 pages, {two} on 2, the new record complete after {}", new4 + new2);
    assert!(four > 3 * 10 * 200 && two > 3 * 10 * 200);
}

/// The reset sweep on `N` pages, after each count of saves in `counts`: returns the cut runs and
/// how many left the old record.
fn torn_resets<const N: usize>(counts: &[u32]) -> (usize, usize) {
    let (mut runs, mut old_after_cut) = (0, 0);
    for &n in counts {
        let old = record_after(n);
        runs += sweep(&saved::<N, 2048>(n, false), &Reset, |flash, at| {
            let mut s = open(flash.clone());
            let loaded = s.load();
            if is(&loaded, Some(&old)) {
                old_after_cut += 1;
            } else {
                assert!(is(&loaded, None), "{N} pages, n {n}, {at}: loaded {loaded:?}");
            }
            // the button still held: the maintenance reset again
            let mut s = open(flash.clone());
            s.reset().unwrap_or_else(|e| panic!("{N} pages, n {n}, {at}: the next reset: {e:?}"));
            assert_eq!(s.load(), Ok(None), "{N} pages, n {n}, {at}");
            s.save(&record_after(40)).unwrap_or_else(|e| panic!("{N} pages, n {n}, {at}: save after the reset: {e:?}"));
            assert!(is(&open(s.into_flash()).load(), Some(&record_after(40))), "{N} pages, n {n}, {at}");
            // the button released: the next flight's save
            let mut s = open(flash);
            s.save(&record_after(41)).unwrap_or_else(|e| panic!("{N} pages, n {n}, {at}: the next save: {e:?}"));
            assert!(is(&open(s.into_flash()).load(), Some(&record_after(41))), "{N} pages, n {n}, {at}");
        });
    }
    (runs, old_after_cut)
}

/// A power cut at every point of a maintenance reset (the whole range erased, page by page), on
/// four pages and on two: the load gives the old record or none; the next boot's maintenance
/// reset completes and leaves none, and a save after it loads; without the maintenance command,
/// the next save completes and loads.
#[test]
fn a_torn_reset_leaves_the_old_record_or_none_and_the_next_boot_works() {
    let (four, old4) = torn_resets::<4>(&[1, 3, 6]);
    let (two, old2) = torn_resets::<2>(&[1, 2, 5]);
    println!("torn resets: {four} cut runs on 4 pages, {two} on 2, the old record left after {}", old4 + old2);
    assert_eq!(four, 3 * 4 * ERASE_POINTS * SEEDS.len());
    assert_eq!(two, 3 * 2 * ERASE_POINTS * SEEDS.len());
    assert!(old4 + old2 > 0 && old4 + old2 < four + two);
}

/// The archive sweep on `N` pages of `P` bytes, after each count of saves in `counts`, with and
/// without a record archived before: returns the cut runs.
fn torn_archives<const N: usize, const P: usize>(counts: &[u32]) -> usize {
    let mut runs = 0;
    for &n in counts {
        for earlier in [false, true] {
            let mut base = saved::<N, P>(n, false);
            let old_archive = earlier.then(|| record_after(100 + n));
            if let Some(a) = &old_archive {
                let mut s = open(base);
                s.archive(a).unwrap();
                base = s.into_flash();
            }
            let current = record_after(n);
            let new_archive = record_after(200 + n);
            let known =
                |a: &Result<Option<HealthRecord>, StoreError>| is(a, Some(&new_archive)) || is(a, old_archive.as_ref());
            runs += sweep(&base, &Archive(new_archive.clone()), |flash, at| {
                let mut s = open(flash);
                let loaded = s.load();
                assert!(is(&loaded, Some(&current)), "{N} pages, n {n}, {at}: the current record {loaded:?}");
                let archived = s.load_archive();
                assert!(known(&archived), "{N} pages, n {n}, {at}: archive {archived:?}");
                let next = record_after(n + 1);
                s.save(&next).unwrap_or_else(|e| panic!("{N} pages, n {n}, {at}: the next save: {e:?}"));
                let mut s = open(s.into_flash());
                assert!(is(&s.load(), Some(&next)), "{N} pages, n {n}, {at}: the next save loads");
                assert!(known(&s.load_archive()), "{N} pages, n {n}, {at}: archive after the save");
            });
        }
    }
    runs
}

/// A power cut at every point of an archive (the first one, and one that replaces an archived
/// record), on four pages of 2 KiB and on two of 4 KiB, at several positions in the page cycle:
/// the current record is untouched, the archive reads as the old archived record (or none,
/// before the first) or the new one; the next save completes and loads, with the archive still
/// the old or new one.
#[test]
fn a_torn_archive_leaves_the_current_record_and_the_old_or_new_archive() {
    let four = torn_archives::<4, 2048>(&[1, 2, 4, 7]);
    let two = torn_archives::<2, 4096>(&[1, 3, 5, 8]);
    println!("torn archives: {four} cut runs on 4 pages, {two} on 2");
    assert!(four > 3 * 8 * 200 && two > 3 * 8 * 200);
}

/// The window sweep on `N` pages of `P` bytes, after each count of saves in `counts`, into an
/// empty slot and into one that holds an earlier window: returns the cut runs and how many left
/// the slot reading as empty.
fn torn_keeps<const N: usize, const P: usize>(counts: &[u32]) -> (usize, usize) {
    let (mut runs, mut empty) = (0, 0);
    let same = |a: &Window, b: &Window| {
        a.len() == b.len() && a.current_a().zip(b.current_a()).all(|(x, y)| x.to_bits() == y.to_bits())
    };
    let slot = 1;
    for &saves in counts {
        for earlier in [false, true] {
            let mut s = open(saved::<N, P>(saves, false));
            let old = earlier.then(|| {
                s.keep_window(slot, &window(0.3), -5.0, &mut [0u8; WINDOW_BUFFER]).unwrap();
                window(0.3)
            });
            let base = s.into_flash();
            let current = record_after(saves);
            let new = window(1.7);
            runs += sweep(&base, &Keep(slot, 1.7), |flash, at| {
                let at = format!("{N} pages, saves {saves}, {at}");
                let mut s = open(flash);
                assert!(is(&s.load(), Some(&current)), "{at}: the record {:?}", s.load());
                let mut buffer = [0u8; WINDOW_BUFFER];
                let mut out = Window::new();
                match s.load_window(slot, &mut out, &mut buffer) {
                    Ok(Some(t)) if t == 1.7 => assert!(same(&out, &new), "{at}: a wrong window"),
                    Ok(Some(t)) if t == -5.0 && old.is_some() => {
                        assert!(old.as_ref().is_some_and(|w| same(&out, w)), "{at}: a wrong window")
                    }
                    Ok(Some(t)) => panic!("{at}: a window at {t} °C"),
                    Ok(None) => empty += 1,
                    Err(e) => panic!("{at}: the slot unreadable: {e:?}"),
                }
                s.keep_window(slot, &new, 1.7, &mut buffer).unwrap_or_else(|e| panic!("{at}: the next keep: {e:?}"));
                let next = record_after(saves + 1);
                s.save(&next).unwrap_or_else(|e| panic!("{at}: the next save: {e:?}"));
                let mut s = open(s.into_flash());
                assert_eq!(s.load_window(slot, &mut out, &mut buffer), Ok(Some(1.7)), "{at}");
                assert!(same(&out, &new), "{at}: the next keep reads back");
                assert!(is(&s.load(), Some(&next)), "{at}: the next save loads");
            });
        }
    }
    (runs, empty)
}

/// A power cut at every point of a commissioning window's keep (four chunks), into an empty slot
/// and into a slot that holds an earlier window of the same length (a flight kept again after a
/// cut before its record was saved), on eight pages of 2 KiB at two positions in the page cycle:
/// the slot reads back bit for bit (the new window, or the one it held) or as empty, never as
/// other samples and never unreadable; the record is untouched; the next boot's keep completes
/// and reads back, and its save loads.
#[test]
fn a_torn_window_keep_reads_back_bit_for_bit_or_empty() {
    let (runs, empty) = torn_keeps::<8, 2048>(&[1, 9]);
    println!("torn window keeps on 8 pages: {runs} cut runs, the slot empty after {empty}");
    assert!(runs > 3 * 4 * 500 && empty > runs / 2);
}

/// The same on two pages of 8 KiB, as the board's range, after five saves (the keep into the
/// slot holding an earlier window recycles a page: the record and the window's chunks migrate,
/// the page they came from is erased).
#[test]
fn a_torn_window_keep_on_two_pages_reads_back_bit_for_bit_or_empty() {
    let (runs, empty) = torn_keeps::<2, 8192>(&[5]);
    println!("torn window keeps on 2 pages: {runs} cut runs, the slot empty after {empty}");
    assert!(runs > 3 * 2 * 500 && empty > runs / 2);
}
