//! ema-monitor on a NUCLEO-F446RE (STM32F446RE, Cortex-M4F at 180 MHz): the phase currents from
//! three ADC pins at the control rate, one flight through the core's [`HealthMonitor`] (the
//! QEMU firmware's flight policy), the report over defmt-rtt (`cargo run --release` in this
//! folder runs it through `probe-rs run`). Wiring only:
//! 1. the independent watchdog first ([`WATCHDOG_MS`], `watchdog.rs`, `safe_state.rs`), so that
//!    every later hang resets; clocks at 180 MHz from the ST-LINK's 8 MHz; the health record from
//!    flash sectors 6–7 (`health_flash.rs`), erased first when the user button B1 (PC13) is held
//!    at start-up; a new record commissions the unit over its first [`COMMISSIONING_FLIGHTS`];
//! 2. the actuator's temperature on PB0 (a TMP36-type sensor), read once; ADC1 on PA0, PA1, PA4
//!    (phases A, B, C) behind the core's `PhaseCurrentReader`, the start trigger on PA10, and
//!    TIM2's interrupt reading one frame per [`FRAME_PERIOD_US`] into the sampler
//!    (`tim2_sampling.rs`); thread mode acquires the manoeuvre's frames after the trigger (at
//!    most [`TRIGGER_TIMEOUT_FRAMES`] ticks away), sleeping with `wfi` and feeding the watchdog;
//! 3. the flight: planned from the record, identified one objective evaluation per step with the
//!    watchdog fed and each step timed by the DWT cycle counter (`WatchdogHooks`), reported with
//!    its uncertainty, recorded with its pooled evidence; the record saved; then idle, fed.
//!
//! A panic or fault ends in the safe state: `FAILSAFE`, then the watchdog's reset (docs/board.md).
#![no_std]
#![no_main]

use defmt_rtt as _; // global defmt logger over RTT
use panic_probe as _; // panic → defmt message → `udf` → HardFault → park → watchdog reset

use core::sync::atomic::Ordering;

use cortex_m_rt::entry;
use ema_monitor::acquisition::{Sampler, SamplerConfig, TemperatureSensor, SAMPLER_QUEUE};
use ema_monitor::conditioning::MeasuredTrace;
use ema_monitor::flight::HealthMonitor;
use ema_monitor::monitor::ONBOARD_WINDOW;
use ema_monitor::{report_log, EmaParams, ModelEffects, Profile, Tolerances};
use stm32f4xx_hal::flash::LockedFlash;
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config;

/// FLASH_ACR: the data cache flush.
mod flash_control;
/// The health record in flash sectors 6–7.
mod health_flash;
/// Failure and the safe state.
mod safe_state;
/// TIM2's interrupt: one frame per control period into the sampler.
mod tim2_sampling;
/// The independent watchdog.
mod watchdog;

use safe_state::{failsafe, idle_failed, refused, WatchdogHooks};
use tim2_sampling::{wait_tick, Isr, LATE};

/// Independent-watchdog timeout. The longest thing done between two feeds is one objective
/// evaluation: at most about 1.2e7 instructions at `opt-level = "s"` (a full model run), about
/// 105 ms at 1.6 cycles per instruction and 180 MHz: 500 ms leaves a margin above 4, and above 3
/// at the LSI's fastest (47 kHz against 32 kHz).
const WATCHDOG_MS: u32 = 500;

/// Period of one ADC frame: 100 µs, the control period of `EmaParams::NOMINAL` (10 kHz).
const FRAME_PERIOD_US: u32 = 100;

/// The frame rate, 10 kHz.
const FRAME_RATE_HZ: u32 = 1_000_000 / FRAME_PERIOD_US;

/// Ticks the sampler waits for the start trigger before refusing the run (10 s).
const TRIGGER_TIMEOUT_FRAMES: u32 = 100_000;

/// The actuator's parameters.
const PARAMS: EmaParams = EmaParams::NOMINAL;

/// Flights of the commissioning a new record starts with (`docs/commissioning.md`).
const COMMISSIONING_FLIGHTS: u8 = 3;

/// The actuator's temperature sensor on PB0: a TMP36 (0.5 V at 0 °C, 10 mV/°C) on the 3.3 V
/// reference. An implausible or missing reading diagnoses the flight at the parameters' 20 °C.
const TEMPERATURE_SENSOR: TemperatureSensor = TemperatureSensor::TMP36_3V3;

/// Polls of the temperature conversion before it counts as unavailable (one takes 3 µs).
const TEMPERATURE_POLLS: u32 = 100;

/// The core clock, for converting DWT cycles to seconds.
const SYSCLK_HZ: u32 = 180_000_000;

#[entry]
fn main() -> ! {
    // 1. Watchdog first: from here on, a hang resets the chip.
    let Some(dp) = pac::Peripherals::take() else { failsafe("device peripherals already taken") };
    let watchdog = safe_state::start_watchdog(dp.IWDG, &dp.DBGMCU, &dp.RCC);
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
    let mut record = health_flash::start(&mut flash, &watchdog, maintenance);

    // 3. The actuator's temperature on PB0 (ADC1_IN8), read once; then ADC1 on PA0/PA1/PA4
    //    behind the core's reader (`tim2_sampling::phase_reader`).
    let mut adc = tim2_sampling::adc1(dp.ADC1, &mut rcc);
    let mut temperature_pin = dp.GPIOB.split(&mut rcc).pb0.into_analog();
    let temperature = TEMPERATURE_SENSOR.read(&mut adc, &mut temperature_pin, &PARAMS, TEMPERATURE_POLLS);
    defmt::info!("actuator temperature: {}", temperature);
    let gpioa = dp.GPIOA.split(&mut rcc);
    let pins = (gpioa.pa0.into_analog(), gpioa.pa1.into_analog(), gpioa.pa4.into_analog());
    let reader = match tim2_sampling::phase_reader(adc, pins) {
        Ok(r) => r,
        Err(e) => refused("acquisition config refused", e, &watchdog),
    };
    let trigger = gpioa.pa10.into_pull_down_input();
    let mut timer = dp.TIM2.counter_us(&mut rcc);
    if timer.start(FRAME_PERIOD_US.micros()).is_err() {
        defmt::error!("TIM2 refused the {=u32} us period", FRAME_PERIOD_US);
        idle_failed(&watchdog)
    }

    // 4. Arm the sampler: TIM2's interrupt reads the frames, thread mode consumes them.
    let Some(sampler) = cortex_m::singleton!(: Sampler<SAMPLER_QUEUE> = Sampler::new()) else {
        failsafe("sampler already taken")
    };
    let monitor = match HealthMonitor::onboard(PARAMS, Profile::STANDARD, ModelEffects::NONE)
        .and_then(|m| m.with_commissioning(COMMISSIONING_FLIGHTS, Tolerances::TYPICAL))
    {
        Ok(m) => m,
        Err(e) => refused("monitor refused", e, &watchdog),
    };
    let record_kept = match monitor.adopt(&mut record) {
        Some(old) => health_flash::archive(&mut flash, &watchdog, &old),
        None => true,
    };
    let frames = monitor.frames();
    let config = SamplerConfig { frames, trigger_timeout_frames: TRIGGER_TIMEOUT_FRAMES };
    let (producer, mut live) = sampler.split(reader, config, || {
        cortex_m::asm::wfi();
        watchdog.feed();
    });
    tim2_sampling::arm(Isr { producer, timer, trigger });
    defmt::info!(
        "waiting for the trigger (PA10 high, at most {=u32} frames), then {=u32} frames at {=u32} Hz",
        TRIGGER_TIMEOUT_FRAMES,
        frames,
        FRAME_RATE_HZ
    );
    let mut trace = MeasuredTrace::<ONBOARD_WINDOW>::new();
    let acquired = monitor.acquire(&mut live, &mut trace, FRAME_RATE_HZ as f32);
    let Some(mut timer) = tim2_sampling::disarm() else { failsafe("sampler interrupt state lost") };
    // the consumer's last use: its wait hook gives the watchdog back
    let (outcome, waited, read) = (live.outcome(), live.waited_frames(), live.frames_read());
    if let Err(e) = outcome {
        refused("acquisition stopped", e, &watchdog)
    }
    let mut acquired = match acquired {
        Ok(a) => a,
        Err(e) => refused("acquisition stopped", e, &watchdog),
    };
    // The frames came at the timer's rate unless a tick's handler overran its period.
    acquired.late_frames = LATE.load(Ordering::Relaxed);
    acquired.temperature_c = temperature.celsius_or_nan();
    defmt::info!(
        "trigger after {=u32} frames; frames read: {=u32}, window samples: {=usize}",
        waited,
        read,
        trace.len()
    );
    defmt::info!(
        "refused frames: {=u32} (longest run {=u32}), held at the last good frame; late frames: {=u32}",
        acquired.summary.refused,
        acquired.summary.longest_refused_run,
        acquired.late_frames
    );

    // 5. The flight, the watchdog fed between evaluations.
    let mut hooks = WatchdogHooks::new(&watchdog, &mut flash);
    let flight = match monitor.diagnose(&trace, &acquired, &mut record, &mut hooks) {
        Ok(f) => f,
        Err(e) => refused("identification refused", e, &watchdog),
    };

    // 6. Report, record, then idle.
    report_log::log_flight(&flight);
    if record_kept {
        health_flash::save(&mut flash, &watchdog, &record);
    }
    defmt::info!("ema-monitor: OK");
    loop {
        wait_tick(&mut timer);
        watchdog.feed();
    }
}
