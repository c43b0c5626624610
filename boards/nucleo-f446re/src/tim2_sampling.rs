//! TIM2's interrupt: one frame into the sampler per control period, with the start trigger's
//! level, and a count of the ticks whose handler overran the period. Armed for each acquisition
//! and disarmed after it, so that thread mode has the producer, the timer and the trigger in
//! hand between flights.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::interrupt::Mutex;
use cortex_m::peripheral::NVIC;
use ema_monitor::acquisition::{AcquisitionConfig, Calibration, ConfigError};
use ema_monitor::acquisition::{PhaseCurrentReader, Sampler, SamplerProducer, SAMPLER_QUEUE};
use stm32f4xx_hal::adc::config::{AdcConfig, Clock, SampleTime};
use stm32f4xx_hal::adc::Adc;
use stm32f4xx_hal::gpio::{Analog, Input, PA0, PA1, PA10, PA4};
use stm32f4xx_hal::pac::{self, interrupt, ADC1, TIM2};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Rcc;
use stm32f4xx_hal::timer::{CounterUs, Event, Flag};

/// The reader of the three phase pins.
pub type Reader = PhaseCurrentReader<Adc<ADC1>, PA0<Analog>, PA1<Analog>, PA4<Analog>, ADC1>;

/// The trigger's glitch filter: ticks it must stay high after its first high tick before it
/// counts, so 5 ticks (0.5 ms) in all; the recording still starts at the first of them (the
/// core's `Sampler`). A pulse shorter than that, a spike coupled into the line, starts nothing.
pub const TRIGGER_CONFIRM_TICKS: usize = 4;

/// The board's sampler: [`SAMPLER_QUEUE`] slots, the trigger filtered.
pub type BoardSampler = Sampler<SAMPLER_QUEUE, TRIGGER_CONFIRM_TICKS>;

/// What TIM2's interrupt handler owns while an acquisition runs.
pub struct Isr {
    /// The sampler's interrupt half, owning the phase reader.
    pub producer: SamplerProducer<'static, Reader, TRIGGER_CONFIRM_TICKS>,
    /// TIM2, counting the control period.
    pub timer: CounterUs<TIM2>,
    /// The start trigger: PA10 (Arduino D2), pulled down, driven high by the flight-control
    /// computer when it starts the manoeuvre's command.
    pub trigger: PA10<Input>,
}

/// The handler's state, handed over by `arm` and taken back by `disarm` (a critical section on
/// either side).
pub static ISR: Mutex<RefCell<Option<Isr>>> = Mutex::new(RefCell::new(None));

/// Ticks whose handler ran past the next update (the frames are then no longer evenly spaced).
pub static LATE: AtomicU32 = AtomicU32::new(0);

/// TIM2 update, every `FRAME_PERIOD_US`: one frame into the sampler, with the trigger's level.
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

/// The phase-current reader on ADC1 and `pins` (PA0, PA1, PA4: phases A, B, C). ADC clock
/// 90/4 = 22.5 MHz (≤ 36 MHz); 56 + 12 cycles = 3 µs per conversion, 9 µs per frame, well inside
/// the 100 µs period. The sensors' gains are the nominal ones (±20 A over the 12-bit range); their
/// zero points are measured on the frames before each trigger (`AcquisitionConfig::SELF_CALIBRATED`),
/// so no offset is compiled in. The HAL converts the phases in turn, [`PHASE_SKEW_US`] apart,
/// which the sum rule accounts for.
pub fn phase_reader(adc: Adc<ADC1>, pins: (PA0<Analog>, PA1<Analog>, PA4<Analog>)) -> Result<Reader, ConfigError> {
    let config = AcquisitionConfig::SELF_CALIBRATED.with_phase_skew_us(PHASE_SKEW_US);
    PhaseCurrentReader::new(adc, pins, Calibration::NOMINAL, config)
}

/// When each phase is converted after phase A's start: the HAL's one-shot read reconfigures the
/// ADC and converts one channel per call, about 5 µs apart at this clock, its overhead included.
pub const PHASE_SKEW_US: [f32; 3] = [0.0, 5.0, 10.0];

/// ADC1, clocked at 90/4 = 22.5 MHz with 56-cycle samples: the phase reader's and, before it, the
/// temperature input's.
pub fn adc1(adc1: ADC1, rcc: &mut Rcc) -> Adc<ADC1> {
    let config = AdcConfig::default().clock(Clock::Pclk2_div_4).default_sample_time(SampleTime::Cycles_56);
    Adc::new(adc1, true, config, rcc)
}

/// Hands `isr` to TIM2's interrupt and starts it, the count of late ticks at 0.
pub fn arm(mut isr: Isr) {
    LATE.store(0, Ordering::Relaxed);
    isr.timer.clear_flags(Flag::Update);
    isr.timer.listen(Event::Update);
    cortex_m::interrupt::free(|cs| ISR.borrow(cs).replace(Some(isr)));
    // SAFETY: the handler only touches `ISR`, through a critical section.
    unsafe { NVIC::unmask(pac::Interrupt::TIM2) };
}

/// Stops TIM2's interrupt and takes its state back (`None` if it was lost).
pub fn disarm() -> Option<Isr> {
    NVIC::mask(pac::Interrupt::TIM2);
    let mut isr = cortex_m::interrupt::free(|cs| ISR.borrow(cs).take())?;
    isr.timer.unlisten(Event::Update);
    Some(isr)
}
