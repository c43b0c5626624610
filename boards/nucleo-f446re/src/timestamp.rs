//! The defmt log's timestamps: microseconds since [`start`], from TIM5 (RM0390, "General-purpose
//! timers (TIM2 to TIM5)"), a 32-bit timer counting at 1 MHz, widened to 64 bits by counting its
//! overflows (one every 71.6 minutes).
//!
//! The count of overflows is TIM5's update flag (TIMx_SR.UIF), taken in whichever comes first:
//! TIM5's update interrupt, or a timestamp read. Both run in a critical section (defmt-rtt's logger
//! holds one while it formats the header), so neither sees the flag the other is clearing. A
//! read takes the counter, then the flag, then the counter again: with the flag set, the second
//! count is after the overflow and goes with the incremented high word; without it, the first
//! count is before any overflow and goes with the old one.

use core::cell::RefCell;

use cortex_m::interrupt::{CriticalSection, Mutex};
use cortex_m::peripheral::NVIC;
use stm32f4xx_hal::pac::{self, interrupt, TIM5};
use stm32f4xx_hal::rcc::{Enable, Rcc, Reset};

/// The clock: TIM5 and its overflows so far.
struct Clock {
    /// The running timer, owned: nothing else touches TIM5.
    tim: TIM5,
    /// Overflows of its 32-bit counter: the timestamp's high word.
    high: u32,
}

/// The clock, handed over by [`start`]; `None` before.
static CLOCK: Mutex<RefCell<Option<Clock>>> = Mutex::new(RefCell::new(None));

defmt::timestamp!("{=u64:us}", micros());

/// Starts TIM5 at 1 MHz from its kernel clock (APB1's timer clock, 90 MHz, divided by 90) as a
/// free-running 32-bit counter (ARR = 0xFFFF_FFFF) with its update interrupt, and makes it the
/// log's clock; log lines before it carry 0. `false` (the log stays at 0) when the timer clock
/// is not a whole number of MHz below 65 536 MHz.
pub fn start(tim: TIM5, rcc: &mut Rcc) -> bool {
    let timer_hz = rcc.clocks.timclk1().raw();
    let Some(prescaler) = (timer_hz / 1_000_000).checked_sub(1).filter(|_| timer_hz % 1_000_000 == 0) else {
        return false;
    };
    TIM5::enable(rcc);
    TIM5::reset(rcc);
    let Ok(prescaler) = u16::try_from(prescaler) else { return false };
    tim.psc().write(|w| w.psc().set(prescaler));
    tim.arr().write(|w| w.arr().set(u32::MAX));
    // load the prescaler now (an update event), then drop the flag that event sets
    tim.egr().write(|w| w.ug().set_bit());
    tim.sr().write(|w| w.uif().clear_bit());
    tim.dier().write(|w| w.uie().set_bit());
    tim.cr1().write(|w| w.cen().set_bit());
    cortex_m::interrupt::free(|cs| CLOCK.borrow(cs).replace(Some(Clock { tim, high: 0 })));
    // SAFETY: TIM5's handler only takes `CLOCK`, in a critical section.
    unsafe { NVIC::unmask(pac::Interrupt::TIM5) };
    true
}

/// Microseconds since [`start`] (0 before it, and in the impossible case of a nested read).
pub fn micros() -> u64 {
    cortex_m::interrupt::free(|cs| {
        // not borrowed elsewhere: every borrow is inside a critical section and returns
        let Ok(mut clock) = CLOCK.borrow(cs).try_borrow_mut() else { return 0 };
        let Some(clock) = clock.as_mut() else { return 0 };
        let first = clock.tim.cnt().read().bits();
        if take_overflow(clock, cs) {
            (u64::from(clock.high) << 32) | u64::from(clock.tim.cnt().read().bits())
        } else {
            (u64::from(clock.high) << 32) | u64::from(first)
        }
    })
}

/// `true` when the counter has overflowed since the last look: the flag is cleared and counted.
fn take_overflow(clock: &mut Clock, _: &CriticalSection) -> bool {
    if clock.tim.sr().read().uif().bit_is_clear() {
        return false;
    }
    // rc_w0: UIF written 0, the other flags written 1 (the PAC's write starts them at 1), kept
    clock.tim.sr().write(|w| w.uif().clear_bit());
    clock.high = clock.high.wrapping_add(1);
    true
}

/// TIM5 update: one overflow of the microsecond counter.
#[interrupt]
fn TIM5() {
    cortex_m::interrupt::free(|cs| {
        if let Ok(mut clock) = CLOCK.borrow(cs).try_borrow_mut() {
            if let Some(clock) = clock.as_mut() {
                take_overflow(clock, cs);
            }
        }
    });
}
