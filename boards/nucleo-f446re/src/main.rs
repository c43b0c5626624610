//! ema-monitor on a NUCLEO-F446RE (STM32F446RE, Cortex-M4F at 180 MHz): the phase currents from
//! three ADC pins at the control rate, flight after flight through the core's [`HealthMonitor`]
//! (the QEMU firmware's flight policy), each report over defmt-rtt (`cargo run --release` in this
//! folder runs it through `probe-rs run`) and as one line on USART2. Wiring only, of the board
//! library's modules and settings (`lib.rs`, which the on-target tests share):
//! 1. the independent watchdog first (`WATCHDOG_MS`, `watchdog.rs`, `safe_state.rs`), so that
//!    every later hang resets; the debug connection kept through `wfi` (`dbgmcu.rs`); clocks at
//!    180 MHz from the ST-LINK's 8 MHz, or from the HSI when it does not come (`rcc.rs`); the
//!    log's timestamps (`timestamp.rs`); the brown-out reset at level 3 (`flash_control.rs`);
//! 2. the health record from flash sectors 6–7 (`health_flash.rs`), erased first when the user
//!    button B1 (PC13) is held at start-up; a new record (the first start, or after that
//!    maintenance reset) commissions the unit over its first `COMMISSIONING_FLIGHTS` flights; a
//!    record that does not load is not saved over, and is loaded again before the next flight;
//! 3. ADC1–3 sampling PA0, PA1, PC0 (phases A, B, C) at one instant on TIM2's trigger every
//!    `FRAME_PERIOD_US`, DMA2 reading them and its interrupt ticking the sampler with the start
//!    trigger on PA10 (`triple_adc.rs`, `dma_sampling.rs`), the sensors' zero points measured
//!    before each trigger; the actuator's temperature on PB0; the report line on PA2
//!    (`report_uart.rs`);
//! 4. the flights (`flights.rs`): each acquired after the trigger (at most
//!    `TRIGGER_TIMEOUT_FRAMES` ticks away, else re-armed), identified with the watchdog fed
//!    before each step, reported, recorded and saved; then the sampler re-armed.
//!
//! A panic or fault ends in the safe state: logged `FAILSAFE`, parked without feeding the
//! watchdog, which resets the chip (docs/board.md). The panic handler (panic-probe) and the
//! global logger (defmt-rtt) are chosen here, not in the library, which the tests link with
//! their own.
#![no_std]
#![no_main]

use defmt_rtt as _; // global defmt logger over RTT
use panic_probe as _; // panic → defmt message → `udf` → HardFault → park → watchdog reset

use cortex_m_rt::entry;
use ema_monitor::acquisition::SamplerConfig;
use ema_monitor::flight::HealthMonitor;
#[cfg(feature = "commissioning")]
use ema_monitor::Tolerances;
use ema_monitor::{ModelEffects, Profile};
use static_cell::ConstStaticCell;
use stm32f4xx_hal::flash::LockedFlash;
use stm32f4xx_hal::gpio::{Input, PA10};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::timer::CounterUs;

use ema_monitor_nucleo_f446re::dma_sampling::{BoardSampler, Isr};
use ema_monitor_nucleo_f446re::safe_state::{failsafe, idle_failed, refused};
use ema_monitor_nucleo_f446re::triple_adc::{self, SimultaneousReader, TripleAdc};
use ema_monitor_nucleo_f446re::watchdog::Watchdog;
#[cfg(feature = "commissioning")]
use ema_monitor_nucleo_f446re::COMMISSIONING_FLIGHTS;
use ema_monitor_nucleo_f446re::{flash_control, FRAME_PERIOD_US, PARAMS, TRIGGER_TIMEOUT_FRAMES};
use ema_monitor_nucleo_f446re::{flights, health_flash, rcc, report_uart, safe_state, timestamp};

/// The sampler's queue and shared state (1.6 KB), built in its static at compile time: a
/// `cortex_m::singleton!` builds its value on the stack first.
static SAMPLER: ConstStaticCell<BoardSampler> = ConstStaticCell::new(BoardSampler::new());

/// `defmt::panic!` and friends: straight to the HardFault path (panic-probe's advice, so that the
/// message is not printed twice), which logs `FAILSAFE` and parks (`safe_state.rs`).
#[defmt::panic_handler]
fn defmt_panic() -> ! {
    panic_probe::hard_fault()
}

#[entry]
fn main() -> ! {
    let mut booted = boot();

    // 5. The sampler: DMA2's interrupt queues the frames, thread mode consumes them, sleeping
    //    (`wfi`) and feeding the watchdog while it waits; then the flights, one after another.
    let Some(sampler) = SAMPLER.try_take() else { failsafe("sampler already taken") };
    let config =
        SamplerConfig { frames: booted.board.monitor.frames(), trigger_timeout_frames: TRIGGER_TIMEOUT_FRAMES };
    let watchdog = booted.board.watchdog;
    let (producer, mut live) = sampler.split(booted.reader, config, || {
        cortex_m::asm::wfi();
        watchdog.feed();
    });
    let isr = Isr { producer, timer: booted.timer, trigger: booted.trigger };
    flights::run(&mut booted.board, isr, &mut live, config)
}

/// Steps 1–4: the watchdog, clocks, health record, sampling hardware and monitor. Not inlined:
/// the set-up's temporaries (the peripherals' handles, the record and monitor before they move
/// into the board) stay out of `main`'s frame, under which every flight runs.
#[inline(never)]
fn boot() -> Booted {
    // 1. Watchdog first: from here on, a hang resets the chip.
    let Some(dp) = pac::Peripherals::take() else { failsafe("device peripherals already taken") };
    let Some(watchdog) = cortex_m::singleton!(: Watchdog = safe_state::start_watchdog(dp.IWDG, &dp.DBGMCU, &dp.RCC))
    else {
        failsafe("watchdog already taken")
    };
    let watchdog: &'static Watchdog = watchdog;

    let Some(mut cp) = cortex_m::Peripherals::take() else { failsafe("core peripherals already taken") };

    // Clocks: 8 MHz HSE (ST-LINK MCO, bypass) or 16 MHz HSI → PLL → 180 MHz; APB1 45, APB2 90 MHz.
    let (mut rcc, clock) = rcc::freeze(dp.RCC, watchdog);
    cp.DCB.enable_trace();
    cp.DWT.enable_cycle_counter();
    if !timestamp::start(dp.TIM5, &mut rcc) {
        defmt::warn!("log timestamps off: TIM5's clock is not a whole number of MHz");
    }
    flash_control::ensure_brown_out_level3(&dp.FLASH, watchdog);

    // 2. Health record; B1 (PC13, low when pressed) held at start-up is the maintenance reset.
    let gpioc = dp.GPIOC.split(&mut rcc);
    let maintenance = gpioc.pc13.into_floating_input().is_low();
    let mut flash = LockedFlash::new(dp.FLASH);
    let mut record = health_flash::start(&mut flash, watchdog, maintenance);

    // 3. ADC1–3 on PA0/PA1/PC0 at one instant on TIM2's trigger, read by DMA2, PB0 through
    //    ADC1 between acquisitions; the trigger on PA10; TIM2 at the frame period; USART2 on PA2.
    let temperature_pin = dp.GPIOB.split(&mut rcc).pb0.into_analog();
    let gpioa = dp.GPIOA.split(&mut rcc);
    let pins = (gpioa.pa0.into_analog(), gpioa.pa1.into_analog(), gpioc.pc0.into_analog());
    let trigger = gpioa.pa10.into_pull_down_input();
    let mut timer = dp.TIM2.counter_us(&mut rcc);
    if timer.start(FRAME_PERIOD_US.micros()).is_err() {
        defmt::error!("TIM2 refused the {=u32} us period", FRAME_PERIOD_US);
        idle_failed(watchdog)
    }
    let adc1 = triple_adc::hal_adc1(dp.ADC1, &mut rcc);
    let parts = triple_adc::Parts { adc1, adc2: dp.ADC2, adc3: dp.ADC3, common: dp.ADC_COMMON, dma2: dp.DMA2 };
    let reader = match SimultaneousReader::new(TripleAdc::new(parts, pins, &mut timer, &mut rcc)) {
        Ok(r) => r,
        Err(e) => refused("acquisition config refused", e, watchdog),
    };
    let uart = report_uart::ReportUart::new(dp.USART2, gpioa.pa2, &mut rcc);
    if uart.is_none() {
        defmt::error!("USART2 refused 115200 8N1: no report line, the log alone reports");
    }

    // 4. The monitor, commissioning each new record in the commissioning image; a record of
    //    other parameters or another unit is archived.
    let monitor = HealthMonitor::onboard(PARAMS, &Profile::STANDARD, ModelEffects::NONE);
    #[cfg(feature = "commissioning")]
    let monitor = monitor.and_then(|m| m.with_commissioning(COMMISSIONING_FLIGHTS, Tolerances::TYPICAL));
    defmt::info!("image: {=str}", if cfg!(feature = "commissioning") { "commissioning" } else { "flight" });
    let monitor = match monitor {
        Ok(m) => m,
        Err(e) => refused("monitor refused", e, watchdog),
    };
    health_flash::adopt(&mut flash, watchdog, &monitor, &mut record);

    let board = flights::Board { monitor, record, flash, watchdog, uart, temperature_pin, clock };
    Booted { board, reader, timer, trigger }
}

/// What [`boot`] sets up: the board the flights run on, and the sampling hardware the sampler
/// takes. Used in place, field by field, so that `main`'s frame holds the board once.
struct Booted {
    board: flights::Board<'static>,
    reader: SimultaneousReader,
    timer: CounterUs<pac::TIM2>,
    trigger: PA10<Input>,
}
