//! ema-monitor on a NUCLEO-F446RE (STM32F446RE, Cortex-M4F at 180 MHz): the phase currents from
//! three ADC pins at the control rate, the on-board identification, the health report over
//! defmt-rtt. No semihosting: the board runs without a debugger, and logs to RTT when one is
//! attached (`cargo run --release` in this folder, through `probe-rs run`).
//!
//! Numbered steps (the QEMU firmware's, `src/main.rs`, with a live ADC in place of the replay):
//! 1. start the independent watchdog ([`WATCHDOG_MS`]) first, so that every later hang resets,
//!    and log when the last reset came from it (the previous run ended in the safe state);
//! 2. clocks: 180 MHz from the 8 MHz HSE input, which the NUCLEO's ST-LINK drives (MCO, bypass);
//!    then the health record from flash sectors 6–7 ([`health_flash`]), erased first when the
//!    user button B1 (PC13) is held at start-up: the maintenance reset;
//! 3. ADC1 on PA0, PA1, PA4 (Arduino A0, A1, A2) for phases A, B, C behind the core's
//!    [`PhaseCurrentReader`], the start trigger on PA10 (Arduino D2, pulled down), and a
//!    [`Sampler`] over them: TIM2 interrupts every [`FRAME_PERIOD_US`] µs (10 kHz, the control rate
//!    of `EmaParams::NOMINAL`) and its handler ([`TIM2`]) reads one frame into the sampler's
//!    queue;
//! 4. thread mode conditions the queued frames ([`monitor::acquire`], sleeping with `wfi` between
//!    frames and feeding the watchdog at each wake-up): the frames before the trigger are dropped,
//!    then exactly the manoeuvre's frame count is recorded (8500 frames = 0.85 s); no trigger
//!    within [`TRIGGER_TIMEOUT_FRAMES`] or a full queue (overrun) refuses the run;
//! 5. identify the faults, warm from the health record's diagnosis when it holds one and no cold
//!    identification is due (`monitor::plan_start`), otherwise cold with the on-board PSO; one
//!    objective evaluation per
//!    [`Identification::step`], feeding the watchdog between steps and timing each step with the
//!    DWT cycle counter;
//! 6. log the health report and the fault vector's bits, append the flight to the health record
//!    and save it, then idle with the watchdog fed (a new run needs a reset).
//!
//! Safe state: a panic (panic-probe logs it, then `udf`) and any fault end in [`HardFault`], which
//! logs `FAILSAFE` and parks without feeding the watchdog, so the IWDG resets the chip within
//! [`WATCHDOG_MS`] (docs/board.md).
#![no_std]
#![no_main]

use defmt_rtt as _; // global defmt logger over RTT
use panic_probe as _; // panic → defmt message → `udf` → HardFault → park → watchdog reset

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::interrupt::Mutex;
use cortex_m::peripheral::{DWT, NVIC};
use cortex_m_rt::{entry, exception, ExceptionFrame};
use ema_monitor::acquisition::{
    manoeuvre_frames, AcquisitionConfig, Calibration, PhaseCurrentReader, Sampler, SamplerConfig, SamplerProducer,
    SAMPLER_QUEUE,
};
use ema_monitor::conditioning::MeasuredTrace;
use ema_monitor::health::{Abstain, HealthReport, Status};
use ema_monitor::monitor::{self, Identification, IdentifyConfig, ONBOARD_POPULATION, ONBOARD_WINDOW};
use ema_monitor::optimizer::Status as SearchStatus;
use ema_monitor::{report_log, EmaParams, Profile};
use stm32f4xx_hal::adc::config::{AdcConfig, Clock, SampleTime};
use stm32f4xx_hal::adc::Adc;
use stm32f4xx_hal::flash::LockedFlash;
use stm32f4xx_hal::gpio::{Analog, Input, PA0, PA1, PA10, PA4};
use stm32f4xx_hal::pac::{self, interrupt, ADC1, TIM2};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config;
use stm32f4xx_hal::timer::{CounterUs, Event, Flag};
use stm32f4xx_hal::watchdog::IndependentWatchdog;

/// The health record in flash sectors 6–7.
mod health_flash;

/// Independent-watchdog timeout. The longest thing done between two feeds is one objective
/// evaluation: 7.42e9 instructions over 1611 evaluations on the built-in trace is 4.6e6 on
/// average; taking 1e7 instructions for a full (not early-abandoned) evaluation at 1.6 cycles per
/// instruction, a step lasts at most about 90 ms at 180 MHz. 500 ms leaves a margin above 5, and
/// above 3 at the LSI's fastest (47 kHz against the nominal 32 kHz, datasheet).
const WATCHDOG_MS: u32 = 500;

/// Period of one ADC frame: 100 µs, the control period of `EmaParams::NOMINAL` (10 kHz).
const FRAME_PERIOD_US: u32 = 100;

/// Ticks the sampler waits for the start trigger before refusing the run (10 s).
const TRIGGER_TIMEOUT_FRAMES: u32 = 100_000;

/// The core clock, for converting DWT cycles to seconds.
const SYSCLK_HZ: u32 = 180_000_000;

#[entry]
fn main() -> ! {
    // 1. Watchdog first: from here on, a hang resets the chip.
    let Some(dp) = pac::Peripherals::take() else { failsafe("device peripherals already taken") };
    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    watchdog.stop_on_debug(&dp.DBGMCU, true); // a core halted by the probe is not reset
    watchdog.start(WATCHDOG_MS.millis());
    defmt::info!("ema-monitor on NUCLEO-F446RE: watchdog {=u32} ms", WATCHDOG_MS);
    // A reset by the watchdog means the previous run ended in the safe state (or hung): say so.
    if dp.RCC.csr().read().wdgrstf().bit_is_set() {
        defmt::warn!("reset by the watchdog: the previous run ended in the safe state or hung");
    }
    dp.RCC.csr().modify(|_, w| w.rmvf().set_bit()); // clear the reset flags for the next boot
    let Some(mut cp) = cortex_m::Peripherals::take() else { failsafe("core peripherals already taken") };

    // 2. Clocks: 8 MHz HSE (ST-LINK MCO, bypass) → PLL → 180 MHz; APB1 45 MHz, APB2 90 MHz.
    let mut rcc = dp
        .RCC
        .freeze(Config::hse(8.MHz()).bypass_hse_oscillator().sysclk(SYSCLK_HZ.Hz()).pclk1(45.MHz()).pclk2(90.MHz()));
    defmt::info!(
        "clocks: sysclk {=u32} Hz, pclk1 {=u32} Hz, pclk2 {=u32} Hz",
        rcc.clocks.sysclk().raw(),
        rcc.clocks.pclk1().raw(),
        rcc.clocks.pclk2().raw()
    );
    cp.DCB.enable_trace();
    cp.DWT.enable_cycle_counter();

    // 2b. Health record; B1 (PC13, low when pressed) held at start-up is the maintenance reset.
    let maintenance = dp.GPIOC.split(&mut rcc).pc13.into_floating_input().is_low();
    let mut flash = LockedFlash::new(dp.FLASH);
    let mut record = health_flash::start(&mut flash, &mut watchdog, maintenance);

    // 3. ADC1 on PA0/PA1/PA4, ADC clock 90/4 = 22.5 MHz (≤ 36 MHz); 56 + 12 cycles = 3 µs per
    //    conversion, 9 µs per frame, well inside the 100 µs period.
    let gpioa = dp.GPIOA.split(&mut rcc);
    let pins = (gpioa.pa0.into_analog(), gpioa.pa1.into_analog(), gpioa.pa4.into_analog());
    let adc_config = AdcConfig::default().clock(Clock::Pclk2_div_4).default_sample_time(SampleTime::Cycles_56);
    let adc = Adc::new(dp.ADC1, true, adc_config, &mut rcc);
    // Nominal sensors (±20 A over the 12-bit range, zero at mid-scale): a real front end gives
    // its measured offsets and gains to `Calibration::new`.
    let reader = match PhaseCurrentReader::new(adc, pins, Calibration::NOMINAL, AcquisitionConfig::DEFAULT) {
        Ok(r) => r,
        Err(e) => {
            defmt::error!("acquisition config refused: {}", e);
            idle_failed(watchdog)
        }
    };
    let trigger = gpioa.pa10.into_pull_down_input();
    let mut timer = dp.TIM2.counter_us(&mut rcc);
    if timer.start(FRAME_PERIOD_US.micros()).is_err() {
        defmt::error!("TIM2 refused the {=u32} us period", FRAME_PERIOD_US);
        idle_failed(watchdog)
    }

    // 4. Arm the sampler: TIM2's interrupt reads the frames, thread mode consumes them.
    let Some(sampler) = cortex_m::singleton!(: Sampler<SAMPLER_QUEUE> = Sampler::new()) else {
        failsafe("sampler already taken")
    };
    let frames = manoeuvre_frames(&Profile::STANDARD, &EmaParams::NOMINAL);
    let config = SamplerConfig { frames, trigger_timeout_frames: TRIGGER_TIMEOUT_FRAMES };
    let (producer, mut live) = sampler.split(reader, config, || {
        cortex_m::asm::wfi();
        watchdog.feed();
    });
    timer.listen(Event::Update);
    cortex_m::interrupt::free(|cs| ISR.borrow(cs).replace(Some(Isr { producer, timer, trigger })));
    // SAFETY: the handler only touches `ISR`, through a critical section.
    unsafe { NVIC::unmask(pac::Interrupt::TIM2) };
    defmt::info!(
        "waiting for the trigger (PA10 high, at most {=u32} frames), then {=u32} frames at {=u32} Hz",
        TRIGGER_TIMEOUT_FRAMES,
        frames,
        1_000_000 / FRAME_PERIOD_US
    );
    let mut trace = MeasuredTrace::<ONBOARD_WINDOW>::new();
    let acquired = monitor::acquire(&mut live, &mut trace);
    NVIC::mask(pac::Interrupt::TIM2);
    let Some(Isr { mut timer, .. }) = cortex_m::interrupt::free(|cs| ISR.borrow(cs).take()) else {
        failsafe("sampler interrupt state lost")
    };
    timer.unlisten(Event::Update);
    // the consumer's last use: its wait hook gives the watchdog back
    let (outcome, waited, read) = (live.outcome(), live.waited_frames(), live.frames_read());
    if let Err(e) = outcome {
        defmt::error!("acquisition stopped: {}", e);
        idle_failed(watchdog)
    }
    let acquired = match acquired {
        Ok(summary) => summary,
        Err(e) => {
            defmt::error!("acquisition stopped: {}", e);
            idle_failed(watchdog)
        }
    };
    let late = LATE.load(Ordering::Relaxed);
    defmt::info!(
        "trigger after {=u32} frames; frames read: {=u32}, window samples: {=usize}",
        waited,
        read,
        trace.len()
    );
    defmt::info!(
        "refused frames: {=u32} (longest run {=u32}), held at the last good frame; late frames: {=u32}",
        acquired.refused,
        acquired.longest_refused_run,
        late
    );
    // The frames came at the timer's rate unless a tick's handler overran its period.
    let rate_hz = (1_000_000 / FRAME_PERIOD_US) as f32;
    let rate_ok = late == 0 && monitor::rate_matches(rate_hz, &EmaParams::NOMINAL);

    // 5. Identification, the watchdog fed between evaluations: warm from the record's diagnosis
    //    unless a cold one is due (no record, after maintenance, periodically, after a poor fit).
    let prior = record.has_prior().then(|| record.k().0);
    let last_needs_cold = record.status().is_some_and(|s| matches!(s, Status::Inconclusive(_)));
    let start =
        monitor::plan_start(prior.as_ref(), record.flights_since_cold(), last_needs_cold, &IdentifyConfig::onboard());
    let warm = start == monitor::Start::Warm;
    defmt::info!("identification start: {}", start);
    let (report, timing) = match identify(&trace, &mut watchdog, if warm { prior.as_ref() } else { None }) {
        Ok(done) => done,
        Err(e) => {
            defmt::error!("identification refused: {}", e);
            idle_failed(watchdog)
        }
    };
    defmt::info!(
        "identification: {=u64} cycles ({=u32} ms at {=u32} Hz), longest step {=u32} cycles (watchdog {=u32} ms)",
        timing.total_cycles,
        (timing.total_cycles / u64::from(SYSCLK_HZ / 1000)) as u32,
        SYSCLK_HZ,
        timing.longest_step_cycles,
        WATCHDOG_MS
    );

    // 6. Report, then idle.
    let report = report.with_acquisition(&acquired);
    let report = if rate_ok { report } else { report.abstaining(Status::Inconclusive(Abstain::RateMismatch)) };
    report_log::log_report(&report);
    health_flash::save(&mut flash, &mut watchdog, &mut record, &report, !warm);
    defmt::info!("ema-monitor: OK");
    loop {
        wait_tick(&mut timer);
        watchdog.feed();
    }
}

/// The reader of the three phase pins.
type Reader = PhaseCurrentReader<Adc<ADC1>, PA0<Analog>, PA1<Analog>, PA4<Analog>, ADC1>;

/// What TIM2's interrupt handler owns while an acquisition runs.
struct Isr {
    producer: SamplerProducer<'static, Reader>,
    timer: CounterUs<TIM2>,
    /// The start trigger: PA10 (Arduino D2), pulled down, driven high by the flight-control
    /// computer when it starts the manoeuvre's command.
    trigger: PA10<Input>,
}

/// The handler's state, handed over by `main` (a critical section on either side).
static ISR: Mutex<RefCell<Option<Isr>>> = Mutex::new(RefCell::new(None));

/// Ticks whose handler ran past the next update (the frames are then no longer evenly spaced).
static LATE: AtomicU32 = AtomicU32::new(0);

/// TIM2 update, every [`FRAME_PERIOD_US`]: one frame into the sampler, with the trigger's level.
#[interrupt]
fn TIM2() {
    cortex_m::interrupt::free(|cs| {
        if let Some(isr) = ISR.borrow(cs).borrow_mut().as_mut() {
            isr.timer.clear_flags(Flag::Update);
            let trigger = isr.trigger.is_high();
            isr.producer.tick(trigger);
            if isr.timer.flags().contains(Flag::Update) {
                LATE.fetch_add(1, Ordering::Relaxed);
            }
        }
    });
}

/// Blocks until TIM2's next update (a busy wait in thread mode; the counter itself keeps the
/// period, so the wait does not drift).
fn wait_tick(timer: &mut CounterUs<TIM2>) {
    while timer.wait().is_err() {}
}

/// Cycle counts of the identification (DWT, 32-bit, so each step is read separately: a step
/// lasts far less than the 23.8 s wrap at 180 MHz).
struct StepTiming {
    total_cycles: u64,
    longest_step_cycles: u32,
}

/// The on-board identification (monitor model of the paper + PSO, `IdentifyConfig::onboard`), one
/// evaluation per step, the watchdog fed before each.
#[inline(never)]
fn identify(
    trace: &MeasuredTrace<ONBOARD_WINDOW>,
    watchdog: &mut IndependentWatchdog,
    prior: Option<&[f32; 8]>,
) -> Result<(HealthReport, StepTiming), monitor::MonitorError> {
    let config = IdentifyConfig { prior: prior.copied(), ..IdentifyConfig::onboard() };
    let mut id: Identification<'_, ONBOARD_WINDOW, ONBOARD_POPULATION> =
        Identification::new(trace, EmaParams::NOMINAL, Profile::STANDARD, &config)?;
    let mut timing = StepTiming { total_cycles: 0, longest_step_cycles: 0 };
    loop {
        watchdog.feed();
        let start = DWT::cycle_count();
        let status = id.step();
        let cycles = DWT::cycle_count().wrapping_sub(start);
        timing.total_cycles += u64::from(cycles);
        timing.longest_step_cycles = timing.longest_step_cycles.max(cycles);
        if let SearchStatus::Done(_) = status {
            break;
        }
    }
    Ok((id.report(), timing))
}

// ---- failure and safe state --------------------------------------------------------------------

/// A refused configuration or recording: no report (`ema-monitor: FAILED`), but the firmware
/// itself is sound, so it idles with the watchdog fed every 100 ms (timed by the DWT cycle
/// counter, so no timer is needed).
fn idle_failed(mut watchdog: IndependentWatchdog) -> ! {
    defmt::error!("ema-monitor: FAILED (no health report)");
    loop {
        watchdog.feed();
        let start = DWT::cycle_count();
        while DWT::cycle_count().wrapping_sub(start) < SYSCLK_HZ / 10 {}
    }
}

/// Logs a failure that leaves the firmware's state unknown, then parks (see [`park`]).
fn failsafe(what: &str) -> ! {
    defmt::error!("FAILSAFE: {=str}: monitor output invalid", what);
    park()
}

/// The safe state: interrupts off, the core asleep, the watchdog no longer fed, so the IWDG
/// resets the chip within [`WATCHDOG_MS`]. The monitor gives no report rather than a wrong one.
fn park() -> ! {
    cortex_m::interrupt::disable();
    loop {
        cortex_m::asm::wfi();
    }
}

/// A panic (panic-probe logs its message, then executes `udf`), a stack overflow (flip-link: the
/// stack hits the bottom of RAM) or any other fault: log the status and park.
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!(
        "FAILSAFE: panic or hard fault at pc {=u32:#010x}: monitor output invalid, parked until the watchdog resets",
        frame.pc()
    );
    park()
}

/// `defmt::panic!` and friends: straight to the HardFault path (panic-probe's advice, so that the
/// message is not printed twice).
#[defmt::panic_handler]
fn defmt_panic() -> ! {
    panic_probe::hard_fault()
}
