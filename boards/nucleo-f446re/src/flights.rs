//! The flights, one after another with no reset: for each, the actuator's temperature, the
//! trigger released, the sampler armed, the manoeuvre acquired, the flight diagnosed and
//! reported (defmt log and the USART2 line), the record saved; then the sampler is re-armed.
//!
//! The health record is loaded at start-up (`health_flash::start`) and kept in RAM between
//! flights; each diagnosed flight is added to it and saved. A record that may not be saved (its
//! load failed, or the other unit's record it replaces was not archived: the core's
//! `persist::kept`) is loaded again before the next flight, so that a passing read error costs
//! one flight's record, never the stored history; the flight in between runs cold and its line
//! says `record=unreadable`.
//!
//! Nothing a flight can refuse stops the loop: a trigger that does not come within the timeout
//! re-arms quietly (a debug-level line), an acquisition or identification refused re-arms after
//! its log line. Only a lost interrupt state ends in the safe state.

use cortex_m::peripheral::DWT;
use ema_monitor::acquisition::{AcquisitionError, SamplerConfig, SamplerConsumer, TemperatureSensor};
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::ONBOARD_WINDOW;
use ema_monitor::flight::{Acquired, Flight, HealthMonitor};
use ema_monitor::persist::KeptRecord;
use ema_monitor::report_log;
use stm32f4xx_hal::flash::LockedFlash;
use stm32f4xx_hal::gpio::{Analog, Input, PA10, PB0};

use crate::dma_sampling::{self, Isr, LATE, TRIGGER_CONFIRM_TICKS};
use crate::rcc::{ClockSource, SYSCLK_HZ};
use crate::report_uart::{Line, ReportUart};
use crate::safe_state::{failsafe, WatchdogHooks};
use crate::watchdog::Watchdog;
use crate::{health_flash, FRAME_RATE_HZ, PARAMS};

/// The actuator's temperature sensor on PB0: a TMP36 (0.5 V at 0 °C, 10 mV/°C) on the 3.3 V
/// reference, read before each flight. An implausible or missing reading diagnoses the flight at
/// the parameters' 20 °C.
const TEMPERATURE_SENSOR: TemperatureSensor = TemperatureSensor::TMP36_3V3;

/// Polls of the temperature conversion before it counts as unavailable (one conversion takes
/// 3 µs; the HAL's blocking read returns it on the first).
const TEMPERATURE_POLLS: u32 = 100;

/// How long the trigger must read low before the sampler is re-armed (ms): a trigger still held
/// from the last flight would otherwise start the next acquisition at once.
const TRIGGER_RELEASE_MS: u32 = 10;

/// Interval of the log line while the trigger stays high (ms).
const TRIGGER_STUCK_LOG_MS: u32 = 10_000;

/// What the flights run on besides the sampler.
pub struct Board<'a> {
    /// The monitor: parameters, manoeuvre, identification settings, commissioning.
    pub monitor: HealthMonitor<'static>,
    /// The health record, loaded at start-up and added to by each flight, with whether it may
    /// be saved.
    pub record: KeptRecord,
    /// The flash of the record and of the commissioning windows.
    pub flash: LockedFlash,
    /// The watchdog.
    pub watchdog: &'a Watchdog,
    /// The report line's USART (`None` when it could not be set up: the log alone reports).
    pub uart: Option<ReportUart>,
    /// The temperature input, read through ADC1 between acquisitions.
    pub temperature_pin: PB0<Analog>,
    /// The oscillator the clocks run from, for the report line.
    pub clock: ClockSource,
}

/// Runs flight after flight: `isr` is the sampling interrupt's state (disarmed), `live` the sampler's
/// thread-mode half, `config` each acquisition's settings.
pub fn run<W: FnMut()>(
    board: &mut Board<'_>,
    mut isr: Isr,
    live: &mut SamplerConsumer<'_, W>,
    config: SamplerConfig,
) -> ! {
    let mut announce = true;
    loop {
        let temperature =
            TEMPERATURE_SENSOR.read(isr.producer.source_mut(), &mut board.temperature_pin, &PARAMS, TEMPERATURE_POLLS);
        wait_released(&isr.trigger, board.watchdog);
        if let Err(e) = dma_sampling::arm(isr) {
            defmt::error!("simultaneous sampling did not start: {}", e);
            failsafe("sampling hardware stuck")
        }
        if announce {
            defmt::info!("actuator temperature: {}", temperature);
            defmt::info!(
                "waiting for the trigger (PA10 high for {=usize} ticks, at most {=u32} frames), then {=u32} frames at {=u32} Hz",
                TRIGGER_CONFIRM_TICKS + 1,
                config.trigger_timeout_frames,
                config.frames,
                FRAME_RATE_HZ
            );
        }
        let mut trace = ConditionedWindow::<ONBOARD_WINDOW>::new();
        let acquired = board.monitor.acquire(live, &mut trace, FRAME_RATE_HZ as f32);
        isr = dma_sampling::disarm().unwrap_or_else(|| failsafe("sampler interrupt state lost"));
        announce = match (live.outcome(), acquired) {
            (Err(AcquisitionError::NoTrigger { waited_frames }), _) => {
                defmt::debug!("no trigger in {=u32} frames: re-armed", waited_frames);
                false
            }
            (Err(e), _) => {
                defmt::warn!("acquisition stopped: {}; re-arming", e);
                true
            }
            (Ok(_), Err(e)) => {
                defmt::warn!("acquisition refused: {}; re-arming", e);
                true
            }
            (Ok(_), Ok(mut acquired)) => {
                // the frames came at TIM2's rate unless one was lost between two interrupts
                acquired.late_frames = LATE.load(core::sync::atomic::Ordering::Relaxed);
                acquired.temperature_c = temperature.celsius_or_nan();
                defmt::info!(
                    "trigger after {=u32} frames; frames read: {=u32}, window samples: {=usize}",
                    live.waited_frames(),
                    live.frames_read(),
                    trace.len()
                );
                board.fly(&trace, &acquired);
                true
            }
        };
        if !isr.producer.rearm(live, config) {
            failsafe("sampler halves of two samplers")
        }
    }
}

impl Board<'_> {
    /// One acquired flight: the record loaded again when it may not be saved, then the flight
    /// diagnosed, reported (log, then the USART2 line), added to the record and saved when the
    /// record may be.
    fn fly(&mut self, trace: &ConditionedWindow<ONBOARD_WINDOW>, acquired: &Acquired) {
        if self.record.needs_load() {
            self.reload();
        }
        defmt::info!(
            "refused frames: {=u32} (longest run {=u32}), held at the last good frame; late frames: {=u32}",
            acquired.summary.refused,
            acquired.summary.longest_refused_run,
            acquired.late_frames
        );
        let mut hooks = WatchdogHooks::new(self.watchdog, &mut self.flash);
        let flight = match self.monitor.diagnose_kept(trace, acquired, &mut self.record, &mut hooks) {
            Ok(f) => f,
            Err(e) => {
                defmt::error!("identification refused: {}; re-arming", e);
                return;
            }
        };
        report_log::log_flight(&flight);
        self.send_line(&flight, acquired.late_frames);
        health_flash::save(&mut self.flash, self.watchdog, &self.record);
        defmt::info!("ema-monitor: OK (flight {=u32}); re-arming", flight.number);
    }

    /// The record loaded again from flash (and adopted). Not inlined: the loaded record's
    /// temporaries stay out of [`Board::fly`]'s frame, which the identification runs above.
    #[inline(never)]
    fn reload(&mut self) {
        self.record = health_flash::load(&mut self.flash, self.watchdog);
        health_flash::adopt(&mut self.flash, self.watchdog, &self.monitor, &mut self.record);
    }

    /// Sends `flight`'s report line on USART2 (logged). Not inlined: the line's 512-byte buffer
    /// lives in this frame alone, not in [`Board::fly`]'s beside the identification's stack.
    #[inline(never)]
    fn send_line(&mut self, flight: &Flight, late_frames: u32) {
        let Some(uart) = self.uart.as_mut() else { return };
        match uart.send(&Line::of(flight, late_frames, self.clock, self.record.origin()), self.watchdog) {
            Ok(bytes) => defmt::info!("report line sent on USART2 ({=usize} bytes)", bytes),
            Err(e) => defmt::error!("report line not sent: {}", e),
        }
    }
}

/// Returns once the trigger has read low for [`TRIGGER_RELEASE_MS`] in a row, feeding the
/// watchdog; logs while it stays high (the flight-control computer still holds it, or the input
/// is stuck high).
fn wait_released(trigger: &PA10<Input>, watchdog: &Watchdog) {
    let (mut low_ms, mut high_ms) = (0u32, 0u32);
    while low_ms < TRIGGER_RELEASE_MS {
        watchdog.feed();
        if trigger.is_high() {
            low_ms = 0;
            high_ms = high_ms.saturating_add(1);
            if high_ms % TRIGGER_STUCK_LOG_MS == 1 {
                defmt::warn!("trigger still high ({=u32} s): waiting for its release to re-arm", high_ms / 1000);
            }
        } else {
            low_ms += 1;
        }
        pause_ms(1);
    }
}

/// Busy-waits `ms` milliseconds on the DWT cycle counter.
fn pause_ms(ms: u32) {
    let start = DWT::cycle_count();
    let cycles = ms.saturating_mul(SYSCLK_HZ / 1000);
    while DWT::cycle_count().wrapping_sub(start) < cycles {}
}
