//! On-target tests of the NUCLEO-F446RE board, on embedded-test: `cargo test --release` in
//! `boards/nucleo-f446re`, with the board on USB, flashes this binary once through probe-rs (the
//! runner of `.cargo/config.toml`), then resets the chip before each test and runs that test
//! alone; the test tells probe-rs its outcome over semihosting, and probe-rs prints one line per
//! test and the summary. Each test starts as the firmware does ([`init`]: the watchdog at 500 ms,
//! the reset flags read and cleared, the clocks at 180 MHz) and runs the board library's own code:
//!
//! - **simultaneous sampling** (`triple_adc.rs`, `dma_sampling.rs`): TIM2, ADC1–3 and DMA2 set up
//!   as `main.rs` sets them up, DMA2 stream 0's interrupt ticking the board's sampler; the ticks
//!   and the frames timed against the DWT cycle counter (both count the same 180 MHz, so a tick
//!   is exactly 18 000 cycles), no frame lost (`dma_sampling::LATE`), the raw codes 12-bit. With
//!   nothing wired to PA0, PA1 and PC0 the inputs float: their values are not tested.
//! - **the health record's store** (`health_flash.rs`) on sectors 6–7 through `EraseGuarded` and
//!   the board's watchdog: the maintenance reset, a record saved and loaded back bit for bit,
//!   then the remains of an interrupted erase (words of garbage programmed into the erased sector
//!   7, as the core's `persist::pages` describes them) recovered at the next load, the record kept.
//! - **the watchdog through a flash erase** (`watchdog.rs`): the timeouts read back from
//!   IWDG_PR and IWDG_RLR, both sectors erased at the flash's 10 s, the chip not reset.
//!
//! PA10 (the trigger) must be left unwired: the tests pull it up or down themselves. The store's
//! tests erase the health record, so the firmware's next start is a cold one, which commissions
//! the unit again (docs/board.md, "Bench procedure").
#![no_std]
#![no_main]

use defmt_rtt as _; // global defmt logger over RTT: embedded-test's lines and the tests'

#[embedded_test::tests(default_timeout = 30)]
mod tests {
    use core::cell::Cell;
    use core::ops::Range;
    use core::sync::atomic::Ordering;

    use cortex_m::peripheral::DWT;
    use ema_monitor::acquisition::{manoeuvre_frames, AcquisitionError, PhaseCurrents, SamplerConfig};
    use ema_monitor::health::HealthReport;
    use ema_monitor::persist::{EraseGuard, EraseGuarded, HealthRecord, KeptRecord, RecordOrigin, StoreError};
    use ema_monitor::trace::ADC_MAX;
    use ema_monitor::{FaultVector, Profile};
    use embedded_storage::nor_flash::NorFlash;
    use stm32f4xx_hal::flash::{FlashExt, LockedFlash};
    use stm32f4xx_hal::gpio::{Input, PA10};
    use stm32f4xx_hal::pac::{self, ADC1, ADC2, ADC3, ADC_COMMON, DMA2, FLASH, GPIOA, GPIOC, TIM2};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::rcc::Rcc;
    use stm32f4xx_hal::timer::CounterUs;

    use ema_monitor_nucleo_f446re::dma_sampling::{self, BoardSampler, Isr, ISR, LATE, TRIGGER_CONFIRM_TICKS};
    use ema_monitor_nucleo_f446re::health_flash::{self, FeedAndFlush, FLASH_WATCHDOG_MS, RECORD_RANGE};
    use ema_monitor_nucleo_f446re::rcc::{self, SYSCLK_HZ};
    use ema_monitor_nucleo_f446re::triple_adc::{self, Parts, SimultaneousReader, TripleAdc};
    use ema_monitor_nucleo_f446re::watchdog::{InForce, Watchdog};
    use ema_monitor_nucleo_f446re::{flash_control, safe_state, timestamp};
    use ema_monitor_nucleo_f446re::{FRAME_PERIOD_US, PARAMS, WATCHDOG_MS};

    /// Core cycles of one frame period: 100 µs at 180 MHz.
    const PERIOD_CYCLES: u32 = SYSCLK_HZ / 1_000_000 * FRAME_PERIOD_US;

    /// How far a run of ticks or frames may end from its expected time: a quarter of a period
    /// (25 µs). The timer and the cycle counter count the same clock, so what varies is only the
    /// interrupt's and thread mode's latency; a frame lost or added moves the end by a period.
    const SLACK_CYCLES: u32 = PERIOD_CYCLES / 4;

    /// Ticks of the rest-frame test: 10 000, one second at 10 kHz.
    const REST_TICKS: u32 = 10_000;

    /// A 128 KiB sector (sectors 6 and 7 hold the record).
    const SECTOR: u32 = 0x2_0000;

    /// Sector 6's offsets: the store's first page.
    const SECTOR_6: Range<u32> = RECORD_RANGE.start..RECORD_RANGE.start + SECTOR;

    /// Sector 7's offsets: the store's second page.
    const SECTOR_7: Range<u32> = RECORD_RANGE.start + SECTOR..RECORD_RANGE.end;

    /// What every test starts from: the firmware's own start and the peripherals the tests use.
    struct Bench {
        /// The IWDG at the flight's 500 ms, as `safe_state::start_watchdog` leaves it.
        watchdog: Watchdog,
        /// The clocks at 180 MHz (`rcc::freeze`); RCC_CSR for the reset flags.
        rcc: Rcc,
        /// The flash interface.
        flash: FLASH,
        /// PA0, PA1 (phases A, B), PA10 (the trigger).
        gpioa: GPIOA,
        /// PC0 (phase C).
        gpioc: GPIOC,
        /// ADC1.
        adc1: ADC1,
        /// ADC2.
        adc2: ADC2,
        /// ADC3.
        adc3: ADC3,
        /// The ADCs' common registers.
        adc_common: ADC_COMMON,
        /// DMA2 (stream 0).
        dma2: DMA2,
        /// TIM2, the frame period.
        tim2: TIM2,
    }

    /// Before each test, after probe-rs's reset: as `main.rs` starts, the watchdog first
    /// (500 ms, frozen while the probe halts the core, the reset flags logged and cleared), the
    /// clocks at 180 MHz from the ST-LINK's 8 MHz or the HSI, the DWT cycle counter, the log's
    /// timestamps.
    #[init]
    fn init() -> Bench {
        let dp = pac::Peripherals::take().expect("the device peripherals, taken once");
        let watchdog = safe_state::start_watchdog(dp.IWDG, &dp.DBGMCU, &dp.RCC);
        let mut cp = cortex_m::Peripherals::take().expect("the core peripherals, taken once");
        let (mut rcc, _clock) = rcc::freeze(dp.RCC, &watchdog);
        cp.DCB.enable_trace();
        cp.DWT.enable_cycle_counter();
        timestamp::start(dp.TIM5, &mut rcc);
        Bench {
            watchdog,
            rcc,
            flash: dp.FLASH,
            gpioa: dp.GPIOA,
            gpioc: dp.GPIOC,
            adc1: dp.ADC1,
            adc2: dp.ADC2,
            adc3: dp.ADC3,
            adc_common: dp.ADC_COMMON,
            dma2: dp.DMA2,
            tim2: dp.TIM2,
        }
    }

    /// The sampling hardware as `main.rs` sets it up (TIM2 every 100 µs, its update ADC1's
    /// trigger; ADC1–3 on PA0, PA1, PC0; the simultaneous reader), the trigger input pulled up
    /// (`high`: it reads high from the first tick) or down (it never rises).
    fn sampling(bench: Bench, high: bool) -> (Watchdog, SimultaneousReader, CounterUs<TIM2>, PA10<Input>) {
        let Bench { watchdog, mut rcc, gpioa, gpioc, adc1, adc2, adc3, adc_common, dma2, tim2, .. } = bench;
        let gpioa = gpioa.split(&mut rcc);
        let gpioc = gpioc.split(&mut rcc);
        let pins = (gpioa.pa0.into_analog(), gpioa.pa1.into_analog(), gpioc.pc0.into_analog());
        let trigger = if high { gpioa.pa10.into_pull_up_input() } else { gpioa.pa10.into_pull_down_input() };
        let mut timer = tim2.counter_us(&mut rcc);
        assert!(timer.start(FRAME_PERIOD_US.micros()).is_ok(), "TIM2 takes the 100 us period");
        let adc1 = triple_adc::hal_adc1(adc1, &mut rcc);
        let parts = Parts { adc1, adc2, adc3, common: adc_common, dma2 };
        let reader = SimultaneousReader::new(TripleAdc::new(parts, pins, &mut timer, &mut rcc));
        let Ok(reader) = reader else { panic!("the acquisition settings are refused") };
        (watchdog, reader, timer, trigger)
    }

    /// The raw codes of the frame the DMA completed last, looked at from thread mode each time it
    /// wakes while the sampler runs (whatever the frame checks make of them).
    struct CodeWatch {
        /// Frames looked at.
        looks: Cell<u32>,
        /// The highest code seen.
        highest: Cell<u16>,
    }

    impl CodeWatch {
        const fn new() -> Self {
            Self { looks: Cell::new(0), highest: Cell::new(0) }
        }

        /// Looks at the last frame in DMA2's buffer, through the interrupt's state.
        fn look(&self) {
            let codes = cortex_m::interrupt::free(|cs| {
                ISR.borrow(cs).borrow().as_ref().map(|isr| isr.producer.source().adc().last_codes())
            });
            if let Some(codes) = codes {
                self.note(codes);
            }
        }

        fn note(&self, codes: [u16; 3]) {
            self.looks.set(self.looks.get() + 1);
            self.highest.set(codes.into_iter().fold(self.highest.get(), u16::max));
        }
    }

    /// Ticks before the trigger: with PA10 pulled down the trigger never rises, every tick reads
    /// a rest frame, and the acquisition ends with `NoTrigger` after exactly [`REST_TICKS`]
    /// ticks, (REST_TICKS − 1) to REST_TICKS periods after it was armed (the first tick comes at
    /// TIM2's next update); no frame lost, every code 12-bit.
    #[test]
    #[timeout(10)]
    fn adc_rest_ticks_every_100_us(bench: Bench) {
        let (watchdog, reader, timer, trigger) = sampling(bench, false);
        let watch = CodeWatch::new();
        let sampler = cortex_m::singleton!(: BoardSampler = BoardSampler::new()).expect("one sampler");
        let config = SamplerConfig { frames: 100, trigger_timeout_frames: REST_TICKS };
        let (producer, mut live) = sampler.split(reader, config, || {
            cortex_m::asm::wfi();
            watchdog.feed();
            watch.look();
        });
        assert!(dma_sampling::arm(Isr { producer, timer, trigger }).is_ok(), "the sampling starts");
        let armed = DWT::cycle_count();
        let end = live.read_frame();
        let elapsed = DWT::cycle_count().wrapping_sub(armed);
        assert!(dma_sampling::disarm().is_some(), "the interrupt's state comes back");
        let late = LATE.load(Ordering::Relaxed);
        defmt::info!(
            "adc rest ticks: {} after {=u32} cycles ({=u32} us), late {=u32}, {=u32} frames looked at, highest code {=u16}",
            live.outcome(),
            elapsed,
            elapsed / (SYSCLK_HZ / 1_000_000),
            late,
            watch.looks.get(),
            watch.highest.get()
        );
        assert!(matches!(end, Err(AcquisitionError::EndOfData)), "no frame before the trigger");
        assert_eq!(
            live.outcome(),
            Err(AcquisitionError::NoTrigger { waited_frames: REST_TICKS }),
            "one tick per frame"
        );
        assert_eq!(late, 0, "no frame lost between two interrupts");
        assert!(elapsed >= (REST_TICKS - 1) * PERIOD_CYCLES, "the ticks come no faster than TIM2's 100 us");
        assert!(elapsed <= REST_TICKS * PERIOD_CYCLES + SLACK_CYCLES, "the ticks come no slower than TIM2's 100 us");
        assert!(watch.looks.get() >= REST_TICKS / 2, "thread mode woke for the ticks");
        assert!(watch.highest.get() <= ADC_MAX, "12-bit codes");
    }

    /// The manoeuvre's frames: with PA10 pulled up the trigger counts at the fifth tick (the
    /// glitch filter), the recording starts with the first, and exactly the manoeuvre's 8500
    /// frames arrive in thread mode, one per period after the filter's burst: the last arrives
    /// (8500 − 5) periods after the fifth, within a quarter of a period; no two arrive in one
    /// period or two periods apart, none is lost or refused by the hardware (`Missing`, `Adc`),
    /// every code 12-bit. The frame checks may refuse the floating inputs' frames: those still
    /// take their period.
    #[test]
    #[timeout(10)]
    fn adc_frames_every_100_us(bench: Bench) {
        let frames = manoeuvre_frames(&Profile::STANDARD, &PARAMS);
        let burst = TRIGGER_CONFIRM_TICKS as u32 + 1;
        let (watchdog, reader, timer, trigger) = sampling(bench, true);
        let watch = CodeWatch::new();
        let sampler = cortex_m::singleton!(: BoardSampler = BoardSampler::new()).expect("one sampler");
        let config = SamplerConfig { frames, trigger_timeout_frames: 1_000 };
        let (producer, mut live) = sampler.split(reader, config, || {
            cortex_m::asm::wfi();
            watchdog.feed();
            watch.look();
        });
        assert!(dma_sampling::arm(Isr { producer, timer, trigger }).is_ok(), "the sampling starts");
        let (mut arrived, mut refused, mut hardware) = (0u32, 0u32, 0u32);
        let (mut first, mut previous) = (0u32, 0u32);
        let (mut shortest, mut longest) = (u32::MAX, 0u32);
        loop {
            let sample = live.read_frame();
            let now = DWT::cycle_count();
            match sample {
                Err(AcquisitionError::EndOfData) => break,
                Ok(frame) => watch.note(frame.codes),
                Err(AcquisitionError::Missing { .. } | AcquisitionError::Adc { .. }) => hardware += 1,
                Err(_) => refused += 1,
            }
            arrived += 1;
            if arrived == burst {
                first = now;
            } else if arrived > burst {
                let gap = now.wrapping_sub(previous);
                shortest = shortest.min(gap);
                longest = longest.max(gap);
            }
            previous = now;
        }
        assert!(dma_sampling::disarm().is_some(), "the interrupt's state comes back");
        let late = LATE.load(Ordering::Relaxed);
        let span = previous.wrapping_sub(first);
        let expected = (frames - burst) * PERIOD_CYCLES;
        let rate_mhz = u64::from(frames - burst) * u64::from(SYSCLK_HZ) * 1000 / u64::from(span.max(1));
        defmt::info!(
            "adc frames: {} ({=u32} arrived, {=u32} refused by the checks, {=u32} by the hardware), late {=u32}; {=u32} cycles for {=u32} periods ({=u32} expected): {=u64} mHz; gaps {=u32}..{=u32} cycles; highest code {=u16}",
            live.outcome(),
            arrived,
            refused,
            hardware,
            late,
            span,
            frames - burst,
            expected,
            rate_mhz,
            shortest,
            longest,
            watch.highest.get()
        );
        assert_eq!(live.outcome(), Ok(frames), "the manoeuvre's frames, no overrun");
        assert_eq!(
            (arrived, live.frames_read(), live.waited_frames()),
            (frames, frames, 0),
            "from the first high tick"
        );
        assert_eq!((late, hardware), (0, 0), "no frame lost or missing");
        assert!(span.abs_diff(expected) <= SLACK_CYCLES, "one frame per 100 us");
        assert!(shortest >= PERIOD_CYCLES / 2 && longest <= PERIOD_CYCLES * 3 / 2, "one frame per period");
        assert!(watch.looks.get() >= frames / 2, "the frames' codes looked at");
        assert!(watch.highest.get() <= ADC_MAX, "12-bit codes");
    }

    /// A record after `flights` flights of slowly growing friction and backlash (the core's
    /// store tests' records).
    fn record_after(flights: u32) -> HealthRecord {
        let mut r = HealthRecord::new();
        for f in 0..flights {
            let x = 0.01 * f as f32;
            let k = [x, 0.5 * x, 0.0, 0.02, 0.0, 0.01, 0.5, 0.5 + 0.1 * x];
            r.new_flight(&HealthReport::new(FaultVector(k), &PARAMS, 0.01, 100, 10, None), f % 5 == 0);
        }
        r.set_evidence([0.5 * flights as f32, -1.0, 0.25, 0.0, 3.0], flights);
        r
    }

    /// `true` when `loaded` is `expected`, bit for bit: its fields and its encoding.
    fn same(loaded: &Result<Option<HealthRecord>, StoreError>, expected: &HealthRecord) -> bool {
        let Ok(Some(record)) = loaded else { return false };
        let mut a = [0u8; HealthRecord::ENCODED_LEN];
        let mut b = [0u8; HealthRecord::ENCODED_LEN];
        record.same_bits(expected) && record.encode(&mut a).is_ok() && expected.encode(&mut b).is_ok() && a == b
    }

    /// The store's load, through the board's path (the watchdog at the flash's timeout, each
    /// sector erase guarded, the pages checked first).
    fn load(flash: &mut LockedFlash, watchdog: &Watchdog) -> Result<Option<HealthRecord>, StoreError> {
        health_flash::with_store(flash, watchdog, |s| s.load())
    }

    /// The store's save, through the board's path.
    fn save(flash: &mut LockedFlash, watchdog: &Watchdog, record: &HealthRecord) -> Result<(), StoreError> {
        health_flash::with_store(flash, watchdog, |s| s.save(record))
    }

    /// Every byte of `sector` reads `0xFF`.
    fn erased(flash: &LockedFlash, sector: &Range<u32>) -> bool {
        let bytes = flash.read().get(sector.start as usize..sector.end as usize).unwrap_or_default();
        !bytes.is_empty() && bytes.iter().all(|&b| b == 0xFF)
    }

    /// Programs `word` (little-endian) at `offset`, bypassing the store, and flushes the data
    /// cache so that the next read sees it.
    fn program(flash: &mut LockedFlash, offset: u32, word: u32) {
        assert!(flash.unlocked().program(offset as usize, word.to_le_bytes().iter()).is_ok(), "programmed");
        flash_control::flush_data_cache();
    }

    /// The remains of an erase of sector 7 cut by a power loss, as words (offset in the sector,
    /// value) programmed into the erased sector (the core's `persist::pages`, rules 1, 4 and 2):
    /// a page that reads open (its first byte erased) with stray words in it; one that reads
    /// closed (its first and last bytes marked: at least four zero bits) after the partially
    /// open page 6, which the crate alone would take for a migration cut midway and repair by
    /// erasing page 6, the record's; one that reads partially open beside page 6.
    const CUT_ERASES: [(&str, &[(u32, u32)]); 3] = [
        (
            "open page, stray words",
            &[(0x100, 0x5A3C_96E1), (0x4000, 0x0F1E_2D3C), (0x1_0000, 0xC3A5_0000), (0x1_FF00, 0x1234_5678)],
        ),
        (
            "page reading closed",
            &[(0, 0x0F1E_2D3C), (0x800, 0x5A3C_96E1), (0x1_2340, 0x1234_5678), (SECTOR - 4, 0xC3A5_0000)],
        ),
        ("page reading partially open", &[(0, 0x0F1E_2D3C), (0x800, 0x5A3C_96E1), (0x1_2340, 0x1234_5678)]),
    ];

    /// The maintenance reset (the firmware's start with B1 held) erases both sectors and gives a
    /// fresh record; a saved record loads back bit for bit; the next flight's save through the
    /// firmware's own `health_flash::save` replaces it, and the firmware's start-up load gives
    /// it; a record whose load failed is not saved over it; the watchdog is back at the flight's
    /// 500 ms after each store operation.
    #[test]
    #[timeout(60)]
    fn flash_store_round_trip(bench: Bench) {
        let Bench { watchdog, flash, .. } = bench;
        let mut flash = LockedFlash::new(flash);
        let mut kept = health_flash::start(&mut flash, &watchdog, true);
        assert_eq!(kept.origin(), RecordOrigin::Empty, "none stored after the maintenance reset");
        assert!(kept.record().same_bits(&HealthRecord::new()), "a fresh record after the maintenance reset");
        assert!(erased(&flash, &SECTOR_6) && erased(&flash, &SECTOR_7), "both sectors erased");
        assert_eq!(load(&mut flash, &watchdog), Ok(None), "none stored");
        let first = record_after(7);
        assert_eq!(save(&mut flash, &watchdog, &first), Ok(()));
        assert!(same(&load(&mut flash, &watchdog), &first), "the record loads back bit for bit");
        assert!(erased(&flash, &SECTOR_7), "one record in sector 6 alone");
        let second = record_after(8);
        *kept.record_mut() = second;
        health_flash::save(&mut flash, &watchdog, &kept);
        assert!(same(&load(&mut flash, &watchdog), &second), "the newest record loads");
        let at_start = health_flash::start(&mut flash, &watchdog, false);
        assert_eq!(at_start.origin(), RecordOrigin::Loaded);
        assert!(at_start.record().same_bits(&second), "the start-up load gives the newest record");
        // a record whose load failed is not saved over the stored one
        health_flash::save(&mut flash, &watchdog, &KeptRecord::from_load(Err(StoreError::Corrupt)));
        assert!(same(&load(&mut flash, &watchdog), &second), "a withheld save leaves the record");
        assert_eq!(watchdog.in_force().map(|f| f.timeout_ms), Ok(WATCHDOG_MS), "the flight's timeout set back");
        defmt::info!("flash store: maintenance reset, 2 records saved and loaded back bit for bit");
    }

    /// After each of [`CUT_ERASES`] left in sector 7 beside a record in sector 6, the next load
    /// (a new store: its first operation checks the pages) gives the record last saved, bit for
    /// bit, and leaves sector 7 erased again; the next save works and loads back.
    #[test]
    #[timeout(120)]
    fn flash_store_recovers_from_cut_erases(bench: Bench) {
        let Bench { watchdog, flash, .. } = bench;
        let mut flash = LockedFlash::new(flash);
        health_flash::start(&mut flash, &watchdog, true);
        let mut newest = record_after(7);
        assert_eq!(save(&mut flash, &watchdog, &newest), Ok(()));
        for ((name, words), flights) in CUT_ERASES.into_iter().zip(8..) {
            assert!(erased(&flash, &SECTOR_7), "sector 7 erased before the cut");
            for &(offset, word) in words {
                program(&mut flash, SECTOR_7.start + offset, word);
            }
            assert!(!erased(&flash, &SECTOR_7), "the remains are in sector 7");
            let loaded = load(&mut flash, &watchdog);
            assert!(same(&loaded, &newest), "the load gives the record last saved, bit for bit");
            assert!(erased(&flash, &SECTOR_7), "the page check erased the remains");
            let next = record_after(flights);
            assert_eq!(save(&mut flash, &watchdog, &next), Ok(()), "the next save works");
            assert!(same(&load(&mut flash, &watchdog), &next), "and loads back");
            defmt::info!("flash store: {=str}: recovered, record of {=u32} flights kept", name, newest.flights());
            newest = next;
        }
    }

    /// The test's erase guard: the board's own ([`FeedAndFlush`]: the watchdog fed around each
    /// sector, the data cache flushed after it), with the timeout in force read back before each
    /// sector and each sector's erase timed by the DWT cycle counter.
    struct TimedGuard<'a> {
        board: FeedAndFlush<'a>,
        watchdog: &'a Watchdog,
        started: u32,
        sectors: u32,
        longest_cycles: u32,
        in_force: [Option<InForce>; 2],
    }

    impl EraseGuard for TimedGuard<'_> {
        fn before_page_erase(&mut self, offset: u32) {
            if let Some(slot) = self.in_force.get_mut(self.sectors as usize) {
                *slot = self.watchdog.in_force().ok();
            }
            self.board.before_page_erase(offset);
            self.started = DWT::cycle_count();
        }

        fn after_page_erase(&mut self, offset: u32) {
            let cycles = DWT::cycle_count().wrapping_sub(self.started);
            self.board.after_page_erase(offset);
            self.sectors += 1;
            self.longest_cycles = self.longest_cycles.max(cycles);
        }
    }

    /// RCC_CSR.WDGRSTF: the IWDG reset the chip since the flags were last cleared.
    fn reset_by_watchdog(rcc: &Rcc) -> bool {
        rcc.csr().read().wdgrstf().bit_is_set()
    }

    /// The timeouts `set_timeout_ms` sets are those IWDG_PR and IWDG_RLR hold once PVU and RVU
    /// clear (500 ms: /4, 3999; 8 s: /64, 3999; 10 s: /128, 2499); with the flash's 10 s in force
    /// (read back before each sector), both record sectors, written to first, are erased through
    /// `EraseGuarded` and the board's guard, each within the timeout even at the LSI's fastest;
    /// the flight's 500 ms is set back; and WDGRSTF, cleared at the start, still reads clear at the
    /// end: the watchdog did not reset the chip (a reset in the middle would restart it, and
    /// probe-rs would stop the run at the second request for the test's command line).
    #[test]
    #[timeout(30)]
    fn watchdog_fed_through_both_sector_erases(bench: Bench) {
        let Bench { watchdog, rcc, flash, .. } = bench;
        assert!(!reset_by_watchdog(&rcc), "WDGRSTF cleared at the start");
        let flight = InForce { prescaler: 0, reload: 3999, timeout_ms: 500 };
        assert_eq!(watchdog.in_force(), Ok(flight), "the flight's 500 ms from the start");
        for (ms, prescaler, reload) in [(8_000, 4, 3999), (FLASH_WATCHDOG_MS, 5, 2499)] {
            assert_eq!(watchdog.set_timeout_ms(ms), Ok(ms));
            assert_eq!(watchdog.in_force(), Ok(InForce { prescaler, reload, timeout_ms: ms }), "in force");
        }
        let mut flash = LockedFlash::new(flash);
        program(&mut flash, SECTOR_6.start + 0x80, 0x0000_0000);
        program(&mut flash, SECTOR_7.start + 0x80, 0x0000_0000);
        assert!(!erased(&flash, &SECTOR_6) && !erased(&flash, &SECTOR_7), "both sectors written to");
        let guard = TimedGuard {
            board: FeedAndFlush::new(&watchdog),
            watchdog: &watchdog,
            started: 0,
            sectors: 0,
            longest_cycles: 0,
            in_force: [None; 2],
        };
        let mut guarded = EraseGuarded::new(flash.unlocked(), guard);
        let erase = guarded.erase(RECORD_RANGE.start, RECORD_RANGE.end);
        let (unlocked, timed) = guarded.into_parts();
        drop(unlocked); // locks the flash again
        let longest_ms = timed.longest_cycles / (SYSCLK_HZ / 1000);
        defmt::info!(
            "watchdog at {=u32} ms: {=u32} sectors erased, the longest in {=u32} ms (flight timeout {=u32} ms); in force before each: {}",
            FLASH_WATCHDOG_MS,
            timed.sectors,
            longest_ms,
            WATCHDOG_MS,
            timed.in_force
        );
        assert!(erase.is_ok(), "the erase succeeds");
        assert_eq!(timed.sectors, 2, "one sector at a time");
        let flash_timeout = Some(InForce { prescaler: 5, reload: 2499, timeout_ms: FLASH_WATCHDOG_MS });
        assert_eq!(timed.in_force, [flash_timeout; 2], "the flash's timeout in force before each sector");
        assert!(longest_ms < FLASH_WATCHDOG_MS * 32 / 47, "each sector within 10 s at the LSI's fastest, 47 kHz");
        assert!(erased(&flash, &SECTOR_6) && erased(&flash, &SECTOR_7), "both sectors erased");
        assert_eq!(watchdog.set_timeout_ms(WATCHDOG_MS), Ok(WATCHDOG_MS));
        assert_eq!(watchdog.in_force(), Ok(flight), "the flight's timeout set back");
        assert!(!reset_by_watchdog(&rcc), "no reset by the watchdog");
    }
}
