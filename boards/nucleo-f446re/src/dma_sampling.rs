//! DMA2 stream 0's interrupt: one frame into the sampler per simultaneous conversion, with the
//! start trigger's level, and a count of the frames lost between two interrupts, over the
//! simultaneous reader (`triple_adc.rs`): TIM2 keeps the period, its update starts the three
//! ADCs, and the frame's arrival in memory interrupts.
//!
//! Each frame raises stream 0's half-transfer or transfer-complete interrupt about 3.2 µs after
//! TIM2's update (`triple_adc.rs`); the handler acknowledges the DMA flags, counts a lost frame
//! when both halves completed since the last interrupt or an overrun stopped the transfers, reads
//! the trigger (PA10) and ticks the sampler's producer, which takes the frame through the core's
//! checks. The sampling instants are TIM2's, whatever the handler's latency: a handler that runs
//! late delays the frame's queueing, not its sample, and only a frame overwritten before it was
//! taken counts. An ADC overrun stops the DMA requests, so no DMA interrupt would follow it: the
//! ADC interrupt (ADC_CR1.OVRIE, RM0390 §13.12) masks itself and pends stream 0's handler,
//! which reports the frame missing and restarts the sampling.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::interrupt::Mutex;
use cortex_m::peripheral::NVIC;
use ema_monitor::acquisition::{Sampler, SamplerProducer, SAMPLER_QUEUE};
use stm32f4xx_hal::gpio::{Input, PA10};
use stm32f4xx_hal::pac::{self, interrupt, TIM2};
use stm32f4xx_hal::timer::CounterUs;

use crate::triple_adc::{SamplingError, SimultaneousReader};

/// The reader of the simultaneous frames.
pub type Reader = SimultaneousReader;

/// The trigger's glitch filter: ticks it must stay high after its first high tick before it
/// counts, so 5 ticks (0.5 ms) in all; the recording still starts at the first of them (the
/// core's `Sampler`). A pulse shorter than that, a spike coupled into the line, starts nothing.
pub const TRIGGER_CONFIRM_TICKS: usize = 4;

/// The board's sampler: [`SAMPLER_QUEUE`] slots, the trigger filtered.
pub type BoardSampler = Sampler<SAMPLER_QUEUE, TRIGGER_CONFIRM_TICKS>;

/// What DMA2 stream 0's interrupt handler owns while an acquisition runs.
pub struct Isr {
    /// The sampler's interrupt half, owning the reader (and through it the ADCs and DMA2).
    pub producer: SamplerProducer<'static, Reader, TRIGGER_CONFIRM_TICKS>,
    /// TIM2, counting the control period; its update is the ADCs' trigger. Held, not read: the
    /// owner keeps anything else from reconfiguring it.
    #[allow(dead_code)]
    pub timer: CounterUs<TIM2>,
    /// The start trigger: PA10 (Arduino D2), pulled down, driven high by the flight-control
    /// computer when it starts the manoeuvre's command.
    pub trigger: PA10<Input>,
}

/// The handlers' state, handed over by `arm` and taken back by `disarm` (a critical section on
/// either side).
pub static ISR: Mutex<RefCell<Option<Isr>>> = Mutex::new(RefCell::new(None));

/// Frames lost between two interrupts (the recording is then no longer one frame per tick).
pub static LATE: AtomicU32 = AtomicU32::new(0);

/// A frame in memory (half or whole buffer), a DMA error, or an overrun handed over by `ADC`:
/// one tick of the sampler, with the trigger's level.
#[interrupt]
fn DMA2_STREAM0() {
    cortex_m::interrupt::free(|cs| {
        if let Some(isr) = ISR.borrow(cs).borrow_mut().as_mut() {
            let lost = isr.producer.source().adc().acknowledge().lost_frames();
            if lost > 0 {
                LATE.fetch_add(lost, Ordering::Relaxed);
            }
            let trigger = isr.trigger.is_high();
            isr.producer.tick(trigger);
            if isr.producer.source().adc().stalled() && !isr.producer.ended() {
                NVIC::pend(pac::Interrupt::DMA2_STREAM0); // no interrupt would come: try again
            }
        } else {
            NVIC::mask(pac::Interrupt::DMA2_STREAM0);
        }
    });
}

/// An ADC overrun (ADC1, 2 or 3): the DMA requests have stopped, so stream 0's handler is pended
/// to report the frame and restart; the overrun interrupt stays masked until then.
#[interrupt]
fn ADC() {
    cortex_m::interrupt::free(|cs| {
        if let Some(isr) = ISR.borrow(cs).borrow().as_ref() {
            isr.producer.source().adc().mask_overrun();
            NVIC::pend(pac::Interrupt::DMA2_STREAM0);
        } else {
            NVIC::mask(pac::Interrupt::ADC);
        }
    });
}

/// Hands `isr` to the interrupts and starts the sampling (`TripleAdc::start`: a new
/// acquisition), the count of lost frames at 0. When the sampling does not start, the
/// interrupts stay masked and `disarm` takes the state back.
pub fn arm(isr: Isr) -> Result<(), SamplingError> {
    LATE.store(0, Ordering::Relaxed);
    NVIC::mask(pac::Interrupt::DMA2_STREAM0);
    NVIC::mask(pac::Interrupt::ADC);
    let started = cortex_m::interrupt::free(|cs| {
        let mut slot = ISR.borrow(cs).borrow_mut();
        let isr = slot.insert(isr);
        isr.producer.source().adc().start()
    });
    started?;
    // pends left from an earlier acquisition go; a flag raised since `start` pends again
    NVIC::unpend(pac::Interrupt::DMA2_STREAM0);
    NVIC::unpend(pac::Interrupt::ADC);
    // SAFETY: the handlers only touch `ISR`, through a critical section.
    unsafe {
        NVIC::unmask(pac::Interrupt::DMA2_STREAM0);
        NVIC::unmask(pac::Interrupt::ADC);
    }
    Ok(())
}

/// Stops the interrupts and the sampling and takes the state back (`None` if it was lost).
pub fn disarm() -> Option<Isr> {
    NVIC::mask(pac::Interrupt::DMA2_STREAM0);
    NVIC::mask(pac::Interrupt::ADC);
    let isr = cortex_m::interrupt::free(|cs| ISR.borrow(cs).take())?;
    isr.producer.source().adc().stop();
    NVIC::unpend(pac::Interrupt::DMA2_STREAM0);
    NVIC::unpend(pac::Interrupt::ADC);
    Some(isr)
}
