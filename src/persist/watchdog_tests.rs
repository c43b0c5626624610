//! The maintenance reset at start-up with the independent watchdog modelled: a virtual clock, the
//! board's flash (two 128 KiB sectors) whose sector erase and byte programming take their
//! datasheet maximum, a watchdog that resets the chip when the time since its last feed reaches
//! its timeout (a reset is a power cut at that instant, the erase in progress leaving its page
//! undefined), and the boot as the board runs it with the maintenance button held: the reset,
//! the load, the save of the flight's record, each with the watchdog fed as the operation starts.
//!
//! With the flash behind [`EraseGuarded`], whose guard feeds the watchdog around each page, and
//! the board's flash timeout, the reset completes in one boot; an erase of the whole range in one
//! call, or a timeout shorter than one page's erase, resets the chip mid-erase on every boot and
//! the maintenance reset never completes (the reset loop of issue #42).

use std::cell::RefCell;
use std::rc::Rc;

use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};

use super::tests::{is, record_after};
use super::*;
use crate::optimizer::rng::splitmix64_mix;

/// Maximum erase time of one 128 KiB sector at x8 parallelism, which stm32f4xx-hal programs with:
/// 4 s (STM32F446xC/E datasheet DS10693, "Flash memory programming", `tERASE128KB`, x8, max;
/// the figure `boards/nucleo-f446re/src/health_flash.rs` states).
const SECTOR_ERASE_MAX_US: u64 = 4_000_000;

/// Maximum programming time of one byte at x8 parallelism: 100 µs (the same table, `tPROG`, max).
const BYTE_PROGRAM_MAX_US: u64 = 100;

/// The watchdog's timeout while the board's flash operations run, the erase split into pages and
/// the watchdog fed around each: `FLASH_WATCHDOG_MS` of `boards/nucleo-f446re/src/health_flash.rs`,
/// 10 s, one sector erase at its maximum with a margin of 2.5, which also covers the LSI running
/// up to 47/32 = 1.47 times fast (1.7).
const FLASH_WATCHDOG_US: u64 = 10_000_000;

/// The LSI clock the watchdog counts, nominal and at its datasheet maximum (DS10693, LSI
/// oscillator characteristics: 32 kHz typical, 47 kHz max): a fast LSI expires the timeout early.
const LSI_NOMINAL_HZ: u64 = 32_000;
const LSI_MAX_HZ: u64 = 47_000;

/// The board's record range: sectors 6 and 7, two pages of 128 KiB.
const SECTOR: usize = 131_072;
type BoardFlash = RamFlash<2, SECTOR>;
const RANGE: core::ops::Range<u32> = 0..2 * SECTOR as u32;

/// Boots a test lets run before it calls the maintenance reset a loop.
const MAX_BOOTS: u32 = 5;

/// The chip as the flash and the watchdog see it: a virtual clock in microseconds and the
/// independent watchdog.
struct Chip {
    now_us: u64,
    last_feed_us: u64,
    /// The timeout as the LSI counts it: the nominal timeout scaled by nominal / actual LSI.
    timeout_us: u64,
    /// The watchdog reset the chip this boot; the flash does nothing more until the next boot.
    reset: bool,
    /// The longest time between two feeds that did not reset the chip.
    longest_gap_us: u64,
    /// Seed of the torn patterns a reset leaves.
    seed: u64,
}

impl Chip {
    fn new(timeout_us: u64, lsi_hz: u64, seed: u64) -> Rc<RefCell<Self>> {
        Rc::new(RefCell::new(Self {
            now_us: 0,
            last_feed_us: 0,
            timeout_us: timeout_us * LSI_NOMINAL_HZ / lsi_hz,
            reset: false,
            longest_gap_us: 0,
            seed,
        }))
    }

    /// A boot: the watchdog starts with the chip.
    fn boot(&mut self) {
        self.reset = false;
        self.last_feed_us = self.now_us;
    }

    fn feed(&mut self) {
        if !self.reset {
            self.longest_gap_us = self.longest_gap_us.max(self.now_us - self.last_feed_us);
            self.last_feed_us = self.now_us;
        }
    }

    /// Lets `us` of flash time pass, or as much as the watchdog lets through before it resets
    /// the chip (when the time since the last feed reaches the timeout); returns the time let
    /// through.
    fn spend(&mut self, us: u64) -> u64 {
        let left = (self.last_feed_us + self.timeout_us).saturating_sub(self.now_us);
        if us < left {
            self.now_us += us;
            us
        } else {
            self.now_us += left;
            self.reset = true;
            left
        }
    }
}

/// The board's flash on the virtual clock: each erased page costs [`SECTOR_ERASE_MAX_US`], each
/// written byte [`BYTE_PROGRAM_MAX_US`], reads are free; a watchdog reset mid-operation cuts it
/// at that instant with [`RamFlash::set_tearing`]'s torn word or undefined page.
struct TimedFlash<'f> {
    flash: &'f mut BoardFlash,
    chip: Rc<RefCell<Chip>>,
}

impl TimedFlash<'_> {
    /// Runs `op` on the flash after `cost_us` of flash time for `bytes` bytes, cut where the
    /// watchdog resets the chip.
    fn timed(
        &mut self,
        cost_us: u64,
        bytes: u32,
        op: impl FnOnce(&mut BoardFlash) -> Result<(), RamFlashError>,
    ) -> Result<(), RamFlashError> {
        let mut chip = self.chip.borrow_mut();
        if chip.reset {
            return Err(RamFlashError::PowerLoss);
        }
        let through = chip.spend(cost_us);
        if chip.reset {
            let done = (u128::from(through) * u128::from(bytes) / u128::from(cost_us.max(1))) as u32;
            chip.seed = splitmix64_mix(chip.seed);
            self.flash.set_tearing(Some(chip.seed));
            self.flash.cut_power_after(done.min(bytes.saturating_sub(1)));
        }
        drop(chip);
        op(self.flash)
    }
}

impl ErrorType for TimedFlash<'_> {
    type Error = RamFlashError;
}

impl ReadNorFlash for TimedFlash<'_> {
    const READ_SIZE: usize = BoardFlash::READ_SIZE;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        if self.chip.borrow().reset {
            return Err(RamFlashError::PowerLoss);
        }
        self.flash.read(offset, bytes)
    }
    fn capacity(&self) -> usize {
        BoardFlash::CAPACITY
    }
}

impl NorFlash for TimedFlash<'_> {
    const WRITE_SIZE: usize = BoardFlash::WRITE_SIZE;
    const ERASE_SIZE: usize = BoardFlash::ERASE_SIZE;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let pages = u64::from(to.saturating_sub(from)) / SECTOR as u64;
        self.timed(pages * SECTOR_ERASE_MAX_US, to.saturating_sub(from), |f| f.erase(from, to))
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let len = bytes.len() as u32;
        self.timed(u64::from(len) * BYTE_PROGRAM_MAX_US, len, |f| f.write(offset, bytes))
    }
}

/// The board's erase guard: the watchdog fed before and after each page.
struct Feed(Rc<RefCell<Chip>>);

impl EraseGuard for Feed {
    fn before_page_erase(&mut self, _offset: u32) {
        self.0.borrow_mut().feed();
    }
    fn after_page_erase(&mut self, _offset: u32) {
        self.0.borrow_mut().feed();
    }
}

/// How the store reaches the flash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Wiring {
    /// Behind [`EraseGuarded`] with [`Feed`]: the board's wiring.
    Guarded,
    /// Straight: an erase of the range is one call, the watchdog fed only as the operation starts.
    Unsplit,
}

/// One operation of the boot, on any flash.
trait Step {
    fn run<F: NorFlash>(&self, store: &mut HealthStore<F>) -> Result<(), StoreError>;
}

struct Reset;
impl Step for Reset {
    fn run<F: NorFlash>(&self, store: &mut HealthStore<F>) -> Result<(), StoreError> {
        store.reset()
    }
}

/// The load at start-up: any result lets the boot go on (a cold start), as on the board.
struct Load;
impl Step for Load {
    fn run<F: NorFlash>(&self, store: &mut HealthStore<F>) -> Result<(), StoreError> {
        let _ = store.load();
        Ok(())
    }
}

struct Save(HealthRecord);
impl Step for Save {
    fn run<F: NorFlash>(&self, store: &mut HealthStore<F>) -> Result<(), StoreError> {
        store.save(&self.0)
    }
}

/// One operation as the board's `with_store` runs it: the watchdog fed (set to the flash
/// timeout), a store over the flash, the operation; `false` when it failed or the watchdog reset
/// the chip.
fn step(flash: &mut BoardFlash, chip: &Rc<RefCell<Chip>>, wiring: Wiring, op: &impl Step) -> bool {
    chip.borrow_mut().feed();
    let timed = TimedFlash { flash, chip: chip.clone() };
    let done = match wiring {
        Wiring::Guarded => op.run(&mut HealthStore::new(EraseGuarded::new(timed, Feed(chip.clone())), RANGE).unwrap()),
        Wiring::Unsplit => op.run(&mut HealthStore::new(timed, RANGE).unwrap()),
    };
    done.is_ok() && !chip.borrow().reset
}

/// Boots with the maintenance button held until one completes its reset, load and save of
/// `record`, at most [`MAX_BOOTS`]: the boots run and whether the last completed.
fn maintenance_boots(
    flash: &mut BoardFlash,
    chip: &Rc<RefCell<Chip>>,
    wiring: Wiring,
    record: &HealthRecord,
) -> (u32, bool) {
    for boot in 1..=MAX_BOOTS {
        chip.borrow_mut().boot();
        flash.power_on();
        if step(flash, chip, wiring, &Reset)
            && step(flash, chip, wiring, &Load)
            && step(flash, chip, wiring, &Save(record.clone()))
        {
            return (boot, true);
        }
        assert!(chip.borrow().reset, "boot {boot}: an operation failed without a watchdog reset");
    }
    (MAX_BOOTS, false)
}

/// The board's flash after `saves` flights (150 records fill a 128 KiB page here).
fn flown(saves: u32) -> Box<BoardFlash> {
    let mut flash = Box::new(BoardFlash::new());
    for i in 1..=saves {
        HealthStore::new(&mut *flash, RANGE).unwrap().save(&record_after(i % 40)).unwrap();
    }
    flash
}

/// With the board's wiring and flash timeout (10 s, nominal and with the LSI at its fastest, which
/// expires it after 6.8 s), the maintenance reset completes in one boot whatever the flash held
/// (nothing, a few records, a page and a half of them): the longest time between two feeds is one
/// sector's erase, and the next start loads the record the boot saved.
#[test]
fn the_maintenance_reset_completes_in_one_boot_with_the_erase_split_into_pages() {
    for lsi in [LSI_NOMINAL_HZ, LSI_MAX_HZ] {
        for (k, saves) in [0u32, 3, 220].into_iter().enumerate() {
            let mut flash = flown(saves);
            let chip = Chip::new(FLASH_WATCHDOG_US, lsi, k as u64);
            let record = record_after(1);
            let (boots, done) = maintenance_boots(&mut flash, &chip, Wiring::Guarded, &record);
            assert!(done && boots == 1, "LSI {lsi} Hz, {saves} saves: {boots} boots");
            let chip = chip.borrow();
            assert_eq!(chip.longest_gap_us, SECTOR_ERASE_MAX_US, "LSI {lsi} Hz, {saves} saves");
            assert!(chip.longest_gap_us < chip.timeout_us);
            assert!(chip.now_us >= 2 * SECTOR_ERASE_MAX_US, "both sectors erased");
            assert!(is(&HealthStore::new(&mut *flash, RANGE).unwrap().load(), Some(&record)));
        }
    }
}

/// After the maintenance boot, 160 ordinary boots (load, then save), with the board's wiring and
/// timeout and the LSI at its fastest: every one completes, the one whose save fills the first
/// sector included (it migrates the record and erases the other sector inside the save), and the
/// longest time between two feeds stays one sector's erase.
#[test]
fn every_boot_of_a_flight_series_completes_page_changes_included() {
    let mut flash = flown(0);
    let chip = Chip::new(FLASH_WATCHDOG_US, LSI_MAX_HZ, 5);
    assert_eq!(maintenance_boots(&mut flash, &chip, Wiring::Guarded, &record_after(1)), (1, true));
    let erases = flash.erase_counts().iter().sum::<u32>();
    for flight in 2..=161 {
        chip.borrow_mut().boot();
        flash.power_on();
        assert!(step(&mut flash, &chip, Wiring::Guarded, &Load), "flight {flight}");
        assert!(step(&mut flash, &chip, Wiring::Guarded, &Save(record_after(flight % 40))), "flight {flight}");
    }
    assert!(flash.erase_counts().iter().sum::<u32>() > erases, "a save changed page and erased");
    assert_eq!(chip.borrow().longest_gap_us, SECTOR_ERASE_MAX_US);
    assert!(is(&HealthStore::new(&mut *flash, RANGE).unwrap().load(), Some(&record_after(161 % 40))));
}

/// Runs [`MAX_BOOTS`] maintenance boots that must each be reset by the watchdog mid-erase (of the
/// maintenance reset's range) after `erased_before_reset` whole sectors, for three seeds of the
/// undefined pages, then as many through [`maintenance_boots`]; then the board's wiring and
/// timeout on the flash the loop left: the maintenance reset completes in one boot, so the loop
/// is the watchdog's, not the store's.
fn assert_reset_loop(wiring: Wiring, timeout_us: u64, lsi: u64, erased_before_reset: u64) {
    for seed in [11u64, 12, 13] {
        let mut flash = flown(5);
        let chip = Chip::new(timeout_us, lsi, seed);
        let mut boot_started = 0;
        for boot in 1..=MAX_BOOTS {
            chip.borrow_mut().boot();
            boot_started = chip.borrow().now_us;
            flash.power_on();
            let reset_done = step(&mut flash, &chip, wiring, &Reset);
            assert!(!reset_done, "{wiring:?}, seed {seed}, boot {boot}: the maintenance reset completed");
            let c = chip.borrow();
            assert!(c.reset, "{wiring:?}, seed {seed}, boot {boot}: not the watchdog");
            assert_eq!(
                c.now_us - boot_started,
                c.timeout_us,
                "{wiring:?}, seed {seed}, boot {boot}: reset at the timeout"
            );
            assert!(flash.is_off(), "{wiring:?}, seed {seed}, boot {boot}: cut mid-erase");
        }
        // how far the erase got before each reset: the same on every boot
        let erased = (chip.borrow().now_us - boot_started) * SECTOR as u64 / SECTOR_ERASE_MAX_US;
        assert_eq!(
            erased / SECTOR as u64,
            erased_before_reset,
            "{wiring:?}, seed {seed}: sectors erased before the reset"
        );
        let (boots, done) = maintenance_boots(&mut flash, &chip, wiring, &record_after(1));
        assert!(!done && boots == MAX_BOOTS, "{wiring:?}, seed {seed}: the loop ended");
        chip.borrow_mut().timeout_us = FLASH_WATCHDOG_US * LSI_NOMINAL_HZ / lsi;
        let (boots, done) = maintenance_boots(&mut flash, &chip, Wiring::Guarded, &record_after(9));
        assert!(done && boots == 1, "{wiring:?}, seed {seed}: the board's wiring after the loop");
        assert!(is(&HealthStore::new(&mut *flash, RANGE).unwrap().load(), Some(&record_after(9))));
    }
}

/// The harness has teeth: the same 10 s timeout with the range erased in one call (two sectors,
/// 8 s at their maximum) and the LSI at its fastest (the watchdog expires after 6.8 s) resets the
/// chip in the second sector's erase on every boot; the maintenance reset never completes.
#[test]
fn an_unsplit_erase_of_the_range_resets_the_chip_on_every_boot() {
    assert_reset_loop(Wiring::Unsplit, FLASH_WATCHDOG_US, LSI_MAX_HZ, 1);
}

/// The same with the erase split into pages but a timeout below one sector's erase (3 s): reset
/// in the first sector's erase on every boot.
#[test]
fn a_timeout_below_one_sector_erase_resets_the_chip_on_every_boot() {
    assert_reset_loop(Wiring::Guarded, 3_000_000, LSI_NOMINAL_HZ, 0);
}
