//! Timer-paced acquisition of the built-in trace on QEMU `mps2-an386`: TIMER0 interrupts once per
//! control period and its handler ticks a [`Sampler`]'s producer, which reads one frame from the
//! replay ADC; thread mode consumes the frames. Shared by the firmware (`src/main.rs`) and the
//! on-target self-test (`tests/selftest.rs`), the one place with MMIO and the interrupt handler;
//! the core stays free of `unsafe`. Each binary defines `exit(ok: bool) -> !` at its root.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::interrupt::Mutex;
use cortex_m_rt::exception;
use ema_monitor::acquisition::{
    replay_config, Calibration, ConfigError, PhaseA, PhaseB, PhaseC, PhaseCurrentReader, ReplayAdc, ReplayReader,
    Sampler, SamplerConfig, SamplerConsumer, SamplerProducer,
};
use ema_monitor::trace::PackedTrace;

/// TIMER0 of the CMSDK APB subsystem on `mps2-an386` (QEMU `hw/arm/mps2.c`): registers at
/// 0x4000_0000, interrupt line 8, counting down at the 25 MHz system clock; it interrupts and
/// reloads when it reaches zero.
mod timer0 {
    use cortex_m::interrupt::InterruptNumber;
    use cortex_m::peripheral::NVIC;

    const CTRL: *mut u32 = 0x4000_0000 as *mut u32;
    const VALUE: *mut u32 = 0x4000_0004 as *mut u32;
    const RELOAD: *mut u32 = 0x4000_0008 as *mut u32;
    const INTCLEAR: *mut u32 = 0x4000_000C as *mut u32;
    /// CTRL: enable (bit 0) and interrupt enable (bit 3).
    const ENABLE_IRQ: u32 = 0b1001;
    /// Timer input clock (the board's SYSCLK).
    pub const CLOCK_HZ: u32 = 25_000_000;
    /// Its interrupt line (`DefaultHandler`'s `irqn`).
    pub const IRQ: u16 = 8;

    #[derive(Clone, Copy)]
    struct Line;
    // SAFETY: 8 is a valid external interrupt number of the AN386 (and below the NVIC's 240).
    unsafe impl InterruptNumber for Line {
        fn number(self) -> u16 {
            IRQ
        }
    }

    /// Interrupts every `period_us` µs.
    pub fn start(period_us: u32) {
        let reload = period_us * (CLOCK_HZ / 1_000_000) - 1;
        // SAFETY: the timer's own registers (MMIO, word-aligned); nothing else uses TIMER0.
        unsafe {
            CTRL.write_volatile(0);
            RELOAD.write_volatile(reload);
            VALUE.write_volatile(reload);
            INTCLEAR.write_volatile(1);
            CTRL.write_volatile(ENABLE_IRQ);
            NVIC::unmask(Line);
        }
    }

    /// Stops the timer and its interrupt.
    pub fn stop() {
        NVIC::mask(Line);
        // SAFETY: as in `start`.
        unsafe {
            CTRL.write_volatile(0);
            INTCLEAR.write_volatile(1);
        }
        NVIC::unpend(Line);
    }

    /// Acknowledges the interrupt (from its handler).
    pub fn clear() {
        // SAFETY: as in `start`.
        unsafe { INTCLEAR.write_volatile(1) };
    }
}

/// Control period of `EmaParams::NOMINAL`: one frame every 100 µs (10 kHz).
pub const FRAME_PERIOD_US: u32 = 100;

/// The producer the timer's interrupt ticks, when an acquisition is armed.
static PRODUCER: Mutex<RefCell<Option<SamplerProducer<'static, ReplayReader<'static>>>>> =
    Mutex::new(RefCell::new(None));

/// The simulated flight computer raises the trigger at this tick (`u32::MAX`: never).
static TRIGGER_AT: AtomicU32 = AtomicU32::new(0);

/// Interrupts: TIMER0 ticks the armed producer with the trigger's level; any other one ends
/// the run with failure.
#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    if irqn != timer0::IRQ as i16 {
        crate::exit(false)
    }
    timer0::clear();
    cortex_m::interrupt::free(|cs| {
        if let Some(p) = PRODUCER.borrow(cs).borrow_mut().as_mut() {
            let tick = p.ticks();
            p.tick(tick >= TRIGGER_AT.load(Ordering::Relaxed));
        }
    });
}

/// Arms an acquisition of `trace` into `sampler` with the trigger at tick `trigger_at` and starts
/// the timer; the consumer waits with `wfi`. Tick `n` (from 0) reads frame `n` of the replay, so
/// the trace's trigger frame as `trigger_at` starts the recording at the manoeuvre's first frame.
pub fn arm<const N: usize>(
    sampler: &'static mut Sampler<N>,
    trace: PackedTrace<'static>,
    config: SamplerConfig,
    trigger_at: u32,
) -> Result<SamplerConsumer<'static, fn()>, ConfigError> {
    let reader = PhaseCurrentReader::new(
        ReplayAdc::new(trace),
        (PhaseA, PhaseB, PhaseC),
        Calibration::NOMINAL,
        replay_config(&trace),
    )?;
    let (producer, consumer) = sampler.split(reader, config, cortex_m::asm::wfi as fn());
    TRIGGER_AT.store(trigger_at, Ordering::Relaxed);
    cortex_m::interrupt::free(|cs| *PRODUCER.borrow(cs).borrow_mut() = Some(producer));
    timer0::start(FRAME_PERIOD_US);
    Ok(consumer)
}

/// Stops the timer and takes the producer back from the interrupt.
pub fn disarm() {
    timer0::stop();
    cortex_m::interrupt::free(|cs| PRODUCER.borrow(cs).borrow_mut().take());
}
