//! Simultaneous sampling of the three phase currents: ADC1, ADC2 and ADC3 in triple regular
//! simultaneous mode, started by TIM2's update, read by DMA2 into a static double buffer; the
//! core's frame checks on the codes ([`SimultaneousReader`]). The board's register code for the
//! three ADCs, DMA2 and TIM2's trigger output is here alone.
//!
//! **Why.** One ADC converting the phases in turn samples them microseconds apart; at 270 V across
//! the conducting pair's 2 × 2 mH the current moves 0.0675 A/µs, so a frame whose phase C comes
//! 9 µs after its phase A sums to 0.6 A instead of 0, twice the sum rule's tolerance. Three ADCs
//! started by the same trigger sample the three phases at one instant.
//!
//! **Pins** (RM0390 §13.3.3; the datasheet's pin table; UM1724's Arduino connector tables):
//!
//! | phase | pin | Arduino | converted by |
//! |---|---|---|---|
//! | A | PA0 | A0 | ADC1, channel 0 (ADC123_IN0) |
//! | B | PA1 | A1 | ADC2, channel 1 (ADC123_IN1) |
//! | C | PC0 | A5 | ADC3, channel 10 (ADC123_IN10) |
//!
//! PA4 (A2), the one-shot path's phase C, is ADC12_IN4: ADC3 cannot convert it. ADC3's inputs on
//! the LQFP64 are PA0–PA3 and PC0–PC3; PA2 and PA3 carry USART2 to the ST-LINK's virtual COM port,
//! so phase C moves to PC0, A5 on the board's default solder bridges.
//!
//! **Timing** (RM0390 §13.3.2, §13.5, §13.9.2; the datasheet's ADC characteristics). ADCCLK is
//! PCLK2/4 = 90/4 = 22.5 MHz (44.4 ns; the ADC's limit is 36 MHz), the same for the three ADCs
//! (ADC_CCR.ADCPRE is common). Each ADC converts one channel per trigger with 56-cycle sampling:
//! - TIM2's update is its TRGO (TIM2_CR2.MMS = update, RM0390 §17.4.2); ADC1's regular group
//!   starts on its rising edge (ADC1_CR2.EXTSEL = TIM2_TRGO, EXTEN = rising, RM0390 §13.6), and in
//!   triple regular simultaneous mode ADC1 passes the same trigger to ADC2 and ADC3 (RM0390
//!   §13.9.2), whose own triggers stay off (RM0390 §13.9: the slaves' triggers must be disabled);
//! - the three sampling windows open the datasheet's trigger latency t_latr, 2 ADCCLK (89 ns),
//!   after TRGO and last 56 ADCCLK: the **aperture** is 2.49 µs, the sample being the input at
//!   the window's end, 2.58 µs after TIM2's update;
//! - the three ADCs run on the same ADCCLK from the same trigger, so their windows open and close
//!   on the same clock edges: the **skew** between ADC1, ADC2 and ADC3 is 0 cycles by design.
//!   Neither RM0390 nor the datasheet gives a residual figure; bounded by one ADCCLK, 44 ns, it is
//!   3 mA at 0.0675 A/µs, 1 % of the sum rule's 0.3 A, so the reader declares no skew;
//! - the conversion ends 12 ADCCLK later (68 cycles, 3.02 µs per trigger for all three at once),
//!   the three DMA transfers follow within a fraction of a microsecond: a frame is in memory
//!   about 3.2 µs after the update, 97 µs before the next one.
//!
//! **DMA** (RM0390 §9.3, §13.9). ADC_CCR.DMA = mode 1: each simultaneous conversion gives three
//! requests, and each reads ADC_CDR's low half-word, which holds ADC1's data at the first, ADC2's
//! at the second and ADC3's at the third (RM0390 §13.9, *DMA requests in multi ADC mode*; mode 1
//! is the one for triple regular simultaneous mode, modes 2 and 3 pair the data for the dual and
//! interleaved modes). ADC_CCR.DDS = 1 keeps the requests coming after each transfer count.
//! DMA2 stream 0, channel 0 (the ADC1 request, RM0390 Table 29) moves them in direct mode,
//! half-word to half-word, peripheral address fixed, memory incremented, circular, into
//! `[A, B, C, A, B, C]`: two frames, so that the half-transfer interrupt announces a frame in the
//! first half and the transfer-complete interrupt one in the second, and the CPU reads one half
//! while the DMA fills the other. The ADCs' own ADC_CR2.DMA bits stay clear: in multi ADC mode
//! the requests are ADC_CCR's.
//!
//! **Errors.** A DMA transfer or direct-mode error (DMA_LISR TEIF0, DMEIF0, FEIF0; RM0390
//! §9.3.19) refuses the frame as [`AcquisitionError::Adc`] and restarts the stream when the error
//! disabled it. An ADC overrun (ADC_CSR OVR1/2/3; detected because ADC_CR2.EOCS = 1, RM0390
//! §13.8.2) stops the DMA requests (RM0390 §13.9); the frame is
//! [`AcquisitionError::Missing`] and the sampling restarts as RM0390 §13.8.1 says: DMA stream
//! disabled and reloaded, OVR cleared, DMA requests re-enabled, conversions resumed by the next
//! trigger; since no DMA interrupt follows an overrun, the ADC interrupt hands it to the DMA's
//! (`dma_sampling.rs`). A restart that fails (the stream does not stop) is tried again at each
//! following frame. A frame the DMA has not refreshed since the last one taken is
//! [`AcquisitionError::Missing`].
//!
//! **Temperature.** While the sampling is stopped, the reader converts the temperature input
//! (PB0, ADC12_IN8) on ADC1 alone, in independent mode and by software start (embedded-hal's
//! `OneShot`); [`TripleAdc::start`] puts the triple mode back.

use core::cell::{Cell, UnsafeCell};
use core::sync::atomic::{compiler_fence, Ordering};

use cortex_m::peripheral::NVIC;

use ema_monitor::acquisition::{AcquisitionConfig, AcquisitionError, Calibration, ConfigError};
use ema_monitor::acquisition::{FrameCheck, Phase, PhaseCurrents, PhaseFrame, SensorCheck};
use stm32f4xx_hal::adc::config::{AdcConfig, Clock, SampleTime};
use stm32f4xx_hal::adc::Adc;
use stm32f4xx_hal::gpio::{Analog, PA0, PA1, PB0, PC0};
use stm32f4xx_hal::hal_02::adc::OneShot;
use stm32f4xx_hal::nb;
use stm32f4xx_hal::pac::{self, tim2::cr2::MMS, ADC1, ADC2, ADC3, ADC_COMMON, DMA2, TIM2};
use stm32f4xx_hal::rcc::{Enable, Rcc};
use stm32f4xx_hal::timer::CounterUs;

/// The phase pins: PA0 (phase A, ADC1), PA1 (phase B, ADC2), PC0 (phase C, ADC3), all analog.
pub type PhasePins = (PA0<Analog>, PA1<Analog>, PC0<Analog>);

/// ADC1's channel: PA0, ADC123_IN0 (phase A).
const CHANNEL_A: u8 = 0;
/// ADC2's channel: PA1, ADC123_IN1 (phase B).
const CHANNEL_B: u8 = 1;
/// ADC3's channel: PC0, ADC123_IN10 (phase C).
const CHANNEL_C: u8 = 10;
/// ADC1's channel of the temperature input: PB0, ADC12_IN8.
const CHANNEL_TEMPERATURE: u8 = 8;

/// The DMA2 stream: stream 0, whose channel 0 is ADC1's request (RM0390 Table 29).
const STREAM: usize = 0;
/// Half-words of the buffer: two frames of three codes.
const BUFFER_LEN: u16 = 6;
/// Polls of DMA_S0CR.EN after clearing it: the stream stops after its current single transfer
/// (RM0390 §9.3.15), a few bus cycles; 1000 polls are tens of microseconds.
const STREAM_STOP_POLLS: u32 = 1_000;
/// Core cycles waited for the ADCs: their power-up time t_STAB after ADON (at most 3 µs, the
/// datasheet) and an ongoing conversion's end before the flags are cleared (68 ADCCLK, 3.02 µs).
/// 1 800 cycles are 10 µs at 180 MHz, and longer at any slower core clock.
const ADC_SETTLE_CYCLES: u32 = 1_800;

/// The DMA's destination: `[A, B, C, A, B, C]`, two frames of ADC1, ADC2, ADC3 codes.
struct FrameBuffer(UnsafeCell<[u16; BUFFER_LEN as usize]>);

// SAFETY: the CPU reads the buffer only through the one `TripleAdc` (it owns ADC1–3 and DMA2,
// singletons, so at most one exists), with volatile reads of the half the DMA has completed;
// the CPU never writes it. The DMA is the only writer.
unsafe impl Sync for FrameBuffer {}

/// The two frames the DMA writes (12 bytes of `.bss`).
static FRAMES: FrameBuffer = FrameBuffer(UnsafeCell::new([0; BUFFER_LEN as usize]));

/// Why the simultaneous sampling did not start.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum SamplingError {
    /// DMA2 stream 0 stayed enabled after [`STREAM_STOP_POLLS`] polls: it cannot be reloaded.
    StreamBusy,
}

/// What DMA2 stream 0 and the ADCs signalled since the last frame was taken.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Events(u8);

impl Events {
    /// A frame is complete in the buffer's first half (DMA_LISR.HTIF0).
    const HALF: u8 = 1 << 0;
    /// A frame is complete in the buffer's second half (DMA_LISR.TCIF0).
    const FULL: u8 = 1 << 1;
    /// A DMA transfer error (TEIF0), direct-mode error (DMEIF0) or FIFO error (FEIF0).
    const DMA_ERROR: u8 = 1 << 2;
    /// ADC1's overrun (ADC_CSR.OVR1): phase A's sample lost.
    const OVERRUN_A: u8 = 1 << 3;
    /// ADC2's overrun (OVR2).
    const OVERRUN_B: u8 = 1 << 4;
    /// ADC3's overrun (OVR3).
    const OVERRUN_C: u8 = 1 << 5;
    /// Any overrun.
    const OVERRUN: u8 = Self::OVERRUN_A | Self::OVERRUN_B | Self::OVERRUN_C;

    const fn has(self, bits: u8) -> bool {
        self.0 & bits != 0
    }

    /// Frames lost between two interrupts: 1 when both halves completed (the DMA filled the
    /// buffer's other half before this one was taken) or an overrun stopped the transfers (a
    /// trigger passed without one), else 0. The sampler's ticks then no longer count the frames
    /// one for one.
    pub const fn lost_frames(self) -> u32 {
        let both = self.0 & (Self::HALF | Self::FULL) == Self::HALF | Self::FULL;
        if both || self.has(Self::OVERRUN) {
            1
        } else {
            0
        }
    }
}

/// What a `TripleAdc` is made of: the HAL's ADC1 (handed over after the temperature reading),
/// ADC2, ADC3, their common registers and DMA2.
pub struct Parts {
    /// ADC1, as the HAL's one-shot driver left it ([`hal_adc1`]).
    pub adc1: Adc<ADC1>,
    /// ADC2.
    pub adc2: ADC2,
    /// ADC3.
    pub adc3: ADC3,
    /// ADC_CSR, ADC_CCR, ADC_CDR.
    pub common: ADC_COMMON,
    /// DMA2 (stream 0 is used).
    pub dma2: DMA2,
}

/// ADC1–3 in triple regular simultaneous mode and DMA2 stream 0 (module doc).
pub struct TripleAdc {
    adc1: ADC1,
    adc2: ADC2,
    adc3: ADC3,
    common: ADC_COMMON,
    dma: DMA2,
    _pins: PhasePins,
    /// Events the interrupt acknowledged since the last frame was taken ([`TripleAdc::acknowledge`]).
    pending: Cell<Events>,
    /// A one-shot conversion of the temperature input is under way.
    one_shot: Cell<bool>,
    /// The last restart failed ([`TripleAdc::stalled`]).
    stalled: Cell<bool>,
}

impl TripleAdc {
    /// Takes the ADCs and DMA2 over, their clocks on, the three ADCs configured and powered but
    /// not triggered; TIM2's update becomes its TRGO (TIM2_CR2.MMS = update, RM0390 §17.4.2).
    /// [`TripleAdc::start`] starts the sampling.
    pub fn new(parts: Parts, pins: PhasePins, timer: &mut CounterUs<TIM2>, rcc: &mut Rcc) -> Self {
        let Parts { adc1, adc2, adc3, common, dma2 } = parts;
        let adc1 = adc1_from_hal(adc1);
        ADC1::enable(rcc);
        ADC2::enable(rcc);
        ADC3::enable(rcc);
        DMA2::enable(rcc);
        timer.set_master_mode(MMS::Update);
        let adc = Self {
            adc1,
            adc2,
            adc3,
            common,
            dma: dma2,
            _pins: pins,
            pending: Cell::new(Events::default()),
            one_shot: Cell::new(false),
            stalled: Cell::new(false),
        };
        adc.configure();
        cortex_m::asm::delay(ADC_SETTLE_CYCLES); // t_STAB after ADON
        adc
    }

    /// DMA2 stream 0, the one this module uses.
    fn stream(&self) -> &pac::dma2::ST {
        self.dma.st(STREAM)
    }

    /// `true` while ADC1 answers TIM2's trigger (between [`TripleAdc::start`] and
    /// [`TripleAdc::stop`]).
    fn is_running(&self) -> bool {
        !self.adc1.cr2().read().exten().is_disabled()
    }

    /// Starts the sampling: the stream reloaded, the triple mode and its DMA requests on, ADC1
    /// answering TIM2's TRGO from its next update. No event from before counts; the reader's
    /// rest frames start afresh with the sampler's re-arm (`PhaseCurrents::rearm`).
    pub fn start(&self) -> Result<(), SamplingError> {
        self.one_shot.set(false);
        self.stalled.set(false);
        self.restart()
    }

    /// Stops the sampling: ADC1's trigger off, the DMA requests off (ADC_CCR.DMA = 0), the
    /// stream disabled, the overrun interrupts masked, the ADCs back to independent mode (for a
    /// one-shot conversion). A stream that does not stop within the bounded wait is left to the
    /// next [`TripleAdc::start`], which refuses it.
    pub fn stop(&self) {
        let _stopped = self.halt(); // a stream still enabled is refused by the next start
        self.clear_flags();
        self.pending.set(Events::default());
    }

    /// The interrupt's acknowledgement: reads DMA_LISR's stream 0 flags and ADC_CSR's overrun
    /// flags, clears exactly the DMA flags seen (DMA_LIFCR; a flag set after the read stays
    /// for the next interrupt) and keeps the events for the next frame taken. Returns them.
    pub fn acknowledge(&self) -> Events {
        let lisr = self.dma.lisr().read();
        let (ht, tc) = (lisr.htif0().bit_is_set(), lisr.tcif0().bit_is_set());
        let (te, dme, fe) = (lisr.teif0().bit_is_set(), lisr.dmeif0().bit_is_set(), lisr.feif0().bit_is_set());
        self.dma
            .lifcr()
            .write(|w| w.chtif0().bit(ht).ctcif0().bit(tc).cteif0().bit(te).cdmeif0().bit(dme).cfeif0().bit(fe));
        let csr = self.common.csr().read();
        let mut bits = 0;
        for (set, bit) in [
            (ht, Events::HALF),
            (tc, Events::FULL),
            (te || dme || fe, Events::DMA_ERROR),
            (csr.ovr1().bit_is_set(), Events::OVERRUN_A),
            (csr.ovr2().bit_is_set(), Events::OVERRUN_B),
            (csr.ovr3().bit_is_set(), Events::OVERRUN_C),
        ] {
            if set {
                bits |= bit;
            }
        }
        let events = Events(bits);
        self.pending.set(Events(self.pending.get().0 | events.0));
        events
    }

    /// Masks the three ADCs' overrun interrupt (ADC_CR1.OVRIE): the ADC interrupt's handler
    /// calls it, then hands the overrun to DMA2 stream 0's handler; the restart unmasks it.
    pub fn mask_overrun(&self) {
        self.set_overrun_interrupt(false);
    }

    /// The codes `[A, B, C]` of the last frame the DMA completed, or why there is none (module
    /// doc). Restarts the sampling after an overrun (RM0390 §13.8.1: stream reloaded, OVR
    /// cleared, requests on, the next trigger converts) or a DMA error that disabled the stream
    /// (RM0390 §9.3.19); a restart that fails is retried at the next frame taken
    /// ([`TripleAdc::stalled`]). A DMA error names phase A: it concerns the whole frame.
    fn take_codes(&self) -> Result<[u16; 3], AcquisitionError> {
        let events = self.pending.replace(Events::default());
        let stream_off = events.has(Events::DMA_ERROR) && self.stream().cr().read().en().is_disabled();
        if events.has(Events::OVERRUN) || stream_off || self.stalled.get() {
            self.stalled.set(self.restart().is_err());
        }
        if events.has(Events::OVERRUN) {
            let phase = if events.has(Events::OVERRUN_A) {
                Phase::A
            } else if events.has(Events::OVERRUN_B) {
                Phase::B
            } else {
                Phase::C
            };
            return Err(AcquisitionError::Missing { phase });
        }
        if events.has(Events::DMA_ERROR) {
            return Err(AcquisitionError::Adc { phase: Phase::A });
        }
        if !events.has(Events::HALF | Events::FULL) {
            return Err(AcquisitionError::Missing { phase: Phase::A });
        }
        Ok(self.last_frame())
    }

    /// `true` when the last restart failed (DMA2 stream 0 did not stop): no conversion and no
    /// interrupt come until one succeeds, so the interrupt pends itself to try again at the next
    /// frame taken, each try a refused frame, until the sampler ends.
    pub fn stalled(&self) -> bool {
        self.stalled.get()
    }

    /// The codes `[A, B, C]` of the last frame the DMA completed, as the interrupt would take
    /// them, without the events and checks of a frame taken: for the on-target tests, which look
    /// at the raw codes while the sampler runs.
    pub fn last_codes(&self) -> [u16; 3] {
        self.last_frame()
    }

    /// The frame in the half the DMA is not writing: DMA_S0NDTR counts the half-words left
    /// before the wrap, so 1–3 means the DMA is in (or about to start) the second half and the
    /// first holds the last frame; 4–6 (and 0, the reload) the other way round.
    fn last_frame(&self) -> [u16; 3] {
        let left = self.stream().ndtr().read().ndt().bits();
        compiler_fence(Ordering::Acquire);
        // SAFETY: `FRAMES` is a valid, aligned `[u16; 6]` for the program's life; the DMA writes
        // it concurrently, which a volatile read of the whole array tolerates (no reference to
        // it is formed); the half returned is the one the DMA is not writing.
        let [a0, b0, c0, a1, b1, c1] = unsafe { core::ptr::read_volatile(FRAMES.0.get()) };
        if (1..=3).contains(&left) {
            [a0, b0, c0]
        } else {
            [a1, b1, c1]
        }
    }

    /// Stops the trigger, the requests and the stream, with the stream's and the ADCs'
    /// interrupts masked first (disabling a stream sets its TCIF, RM0390 §9.3.15, which must not
    /// interrupt); the ADCs back to independent mode. `false` when the stream did not stop
    /// within [`STREAM_STOP_POLLS`] polls.
    fn halt(&self) -> bool {
        self.adc1.cr2().modify(|_, w| w.exten().disabled());
        self.common.ccr().modify(|_, w| w.dma().disabled().multi().independent());
        self.set_overrun_interrupt(false);
        let cr = self.stream().cr();
        cr.modify(|_, w| w.tcie().disabled().htie().disabled().teie().disabled().dmeie().disabled());
        cr.modify(|_, w| w.en().disabled());
        (0..STREAM_STOP_POLLS).any(|_| cr.read().en().is_disabled())
    }

    /// The start sequence (RM0390 §9.3.18 for the stream, §13.9 for the multi mode: configured in
    /// independent mode, then switched), also the overrun's recovery. The flags are cleared and
    /// the interrupts' pending states dropped before the stream's interrupts are enabled again,
    /// so that nothing from before the restart interrupts (a tick that stands for no frame).
    fn restart(&self) -> Result<(), SamplingError> {
        if !self.halt() {
            return Err(SamplingError::StreamBusy);
        }
        cortex_m::asm::delay(ADC_SETTLE_CYCLES); // a conversion under way ends
        self.clear_flags();
        NVIC::unpend(pac::Interrupt::DMA2_STREAM0);
        NVIC::unpend(pac::Interrupt::ADC);
        self.pending.set(Events::default());
        self.configure();
        self.stream().cr().modify(|_, w| w.en().enabled());
        self.common.ccr().modify(|_, w| w.multi().triple_r().dma().mode1().dds().continuous());
        self.set_overrun_interrupt(true);
        self.adc1.cr2().modify(|_, w| w.extsel().tim2trgo().exten().rising_edge());
        Ok(())
    }

    /// Writes every register of the three ADCs and of the stream, trigger and requests off
    /// (ADC_CR1/CR2/SMPRx/SQRx, RM0390 §13.13; DMA_S0CR/NDTR/PAR/M0AR/FCR, RM0390 §9.5). The
    /// stream must be disabled (its registers are read-only while enabled).
    fn configure(&self) {
        self.common.ccr().modify(|_, w| w.adcpre().div4().multi().independent().dma().disabled());
        // 12-bit, one channel, no scan, interrupts off (ADC_CR1)
        for cr1 in [self.adc1.cr1(), self.adc2.cr1(), self.adc3.cr1()] {
            cr1.write(|w| w.res().twelve_bit());
        }
        // on, single conversion per trigger, EOC per conversion (overrun detection, RM0390
        // §13.8.2), right-aligned, the ADC's own DMA bits clear, trigger off; ADC2 and ADC3
        // never get one (ADC1 passes its own on in multi mode)
        for cr2 in [self.adc1.cr2(), self.adc2.cr2(), self.adc3.cr2()] {
            cr2.write(|w| {
                w.adon().enabled().cont().single().dma().disabled().dds().single();
                w.eocs().each_conversion().align().right().exten().disabled().extsel().tim2trgo()
            });
        }
        // one conversion in each regular sequence (SQR1.L = 0), 56-cycle sampling
        for sqr1 in [self.adc1.sqr1(), self.adc2.sqr1(), self.adc3.sqr1()] {
            sqr1.write(|w| w.l().set(0));
        }
        // SAFETY: the channel numbers are valid SQ1 values (0, 1, 10 < 19, RM0390 §13.13.11).
        unsafe {
            self.adc1.sqr3().write(|w| w.sq1().bits(CHANNEL_A));
            self.adc2.sqr3().write(|w| w.sq1().bits(CHANNEL_B));
            self.adc3.sqr3().write(|w| w.sq1().bits(CHANNEL_C));
        }
        self.adc1.smpr2().write(|w| w.smp0().cycles56());
        self.adc2.smpr2().write(|w| w.smp1().cycles56());
        self.adc3.smpr1().write(|w| w.smp10().cycles56());

        let stream = self.stream();
        // SAFETY: ADC_CDR and `FRAMES` are valid for the stream's half-word reads and writes
        // for the program's life; NDTR (6) keeps the writes inside the 6-half-word buffer.
        unsafe {
            stream.par().write(|w| w.pa().bits(self.common.cdr().as_ptr() as u32));
            stream.m0ar().write(|w| w.m0a().bits(FRAMES.0.get() as u32));
        }
        stream.ndtr().write(|w| w.ndt().set(BUFFER_LEN));
        // direct mode (DMDIS "enabled" is direct mode on), no FIFO error interrupt
        stream.fcr().write(|w| w.dmdis().enabled().feie().disabled());
        stream.cr().write(|w| {
            w.chsel().set(0).mburst().single().pburst().single().dbm().disabled().pl().high();
            w.msize().bits16().psize().bits16().minc().incremented().pinc().fixed().circ().enabled();
            w.dir().peripheral_to_memory().pfctrl().dma().en().disabled();
            w.tcie().enabled().htie().enabled().teie().enabled().dmeie().enabled()
        });
    }

    /// Clears the three ADCs' status flags (EOC, STRT, OVR: reading each data register, then
    /// ADC_SR written 0) and stream 0's DMA flags (required before EN is set, RM0390 §9.5.5).
    fn clear_flags(&self) {
        let _ = (self.adc1.dr().read(), self.adc2.dr().read(), self.adc3.dr().read());
        self.adc1.sr().reset();
        self.adc2.sr().reset();
        self.adc3.sr().reset();
        self.dma
            .lifcr()
            .write(|w| w.chtif0().clear().ctcif0().clear().cteif0().clear().cdmeif0().clear().cfeif0().clear());
    }

    /// The three ADCs' overrun interrupt (ADC_CR1.OVRIE) on or off.
    fn set_overrun_interrupt(&self, on: bool) {
        for cr1 in [self.adc1.cr1(), self.adc2.cr1(), self.adc3.cr1()] {
            cr1.modify(|_, w| w.ovrie().bit(on));
        }
    }

    /// Starts one conversion of the temperature input on ADC1 alone (independent mode, software
    /// start, 56-cycle sampling). Only while stopped.
    fn start_temperature(&self) {
        self.common.ccr().modify(|_, w| w.multi().independent().dma().disabled());
        self.adc1.cr1().write(|w| w.res().twelve_bit());
        self.adc1.cr2().write(|w| w.adon().enabled().eocs().each_conversion().exten().disabled());
        self.adc1.sqr1().write(|w| w.l().set(0));
        // SAFETY: 8 is a valid SQ1 value (RM0390 §13.13.11).
        self.adc1.sqr3().write(|w| unsafe { w.sq1().bits(CHANNEL_TEMPERATURE) });
        self.adc1.smpr2().write(|w| w.smp8().cycles56());
        let _ = self.adc1.dr().read();
        self.adc1.sr().reset();
        self.adc1.cr2().modify(|_, w| w.swstart().start());
    }

    /// The temperature conversion's code once ADC1's EOC is set.
    fn temperature_code(&self) -> Option<u16> {
        self.adc1.sr().read().eoc().is_complete().then(|| self.adc1.dr().read().data().bits())
    }
}

/// ADC1 back from the HAL's one-shot driver, which has no `release`: the driver ends here.
fn adc1_from_hal(hal: Adc<ADC1>) -> ADC1 {
    {
        let _ended = hal;
    }
    // SAFETY: the HAL's `Adc<ADC1>` owned the one ADC1 instance and has gone out of scope just
    // above, so the stolen handle is again the only one.
    unsafe { ADC1::steal() }
}

/// The phase currents of the simultaneous frames, through the core's frame checks, with the
/// zero points measured before the trigger (`AcquisitionConfig::SELF_CALIBRATED` over
/// `Calibration::NOMINAL`: no hand-edited calibration on the board) and no sampling skew.
pub struct SimultaneousReader {
    adc: TripleAdc,
    check: FrameCheck,
}

impl SimultaneousReader {
    /// The reader of `adc`'s frames.
    pub fn new(adc: TripleAdc) -> Result<Self, ConfigError> {
        let check = FrameCheck::new(Calibration::NOMINAL, AcquisitionConfig::SELF_CALIBRATED)?;
        Ok(Self { adc, check })
    }

    /// The sampling hardware (started and stopped by `dma_sampling`'s `arm` and `disarm`).
    pub const fn adc(&self) -> &TripleAdc {
        &self.adc
    }
}

impl PhaseCurrents for SimultaneousReader {
    fn read_frame(&mut self) -> Result<PhaseFrame, AcquisitionError> {
        let codes = self.adc.take_codes()?;
        self.check.codes(codes)
    }

    fn read_rest_frame(&mut self) -> Result<(), AcquisitionError> {
        let codes = self.adc.take_codes()?;
        self.check.rest(codes);
        Ok(())
    }

    /// The zero points from the rest frames, the stuck and sum history afresh: each acquisition
    /// starts its checks anew here.
    fn start_recording(&mut self) {
        self.check.start_recording();
    }

    fn rearm(&mut self) {
        self.check.rearm();
    }

    fn sensor_check(&self) -> SensorCheck {
        self.check.sensor_check()
    }
}

/// The temperature input (PB0, ADC12_IN8) through ADC1 while the sampling is stopped: the first
/// call starts the conversion and answers `WouldBlock`, a later one returns the code once it is
/// there (the core's `TemperatureSensor::read` polls a bounded number of times). While the
/// sampling runs, the conversion is refused (`Err(Other(()))`).
impl OneShot<ADC1, u16, PB0<Analog>> for SimultaneousReader {
    type Error = ();

    fn read(&mut self, _pin: &mut PB0<Analog>) -> nb::Result<u16, ()> {
        let adc = &self.adc;
        if adc.is_running() {
            adc.one_shot.set(false);
            return Err(nb::Error::Other(()));
        }
        if !adc.one_shot.replace(true) {
            adc.start_temperature();
            return Err(nb::Error::WouldBlock);
        }
        match adc.temperature_code() {
            Some(code) => {
                adc.one_shot.set(false);
                Ok(code)
            }
            None => Err(nb::Error::WouldBlock),
        }
    }
}

/// ADC1 through the HAL, clocked at 90/4 = 22.5 MHz (≤ 36 MHz) with 56-cycle samples: what
/// [`TripleAdc::new`] takes over, the same clock and sampling time it keeps.
pub fn hal_adc1(adc1: ADC1, rcc: &mut Rcc) -> Adc<ADC1> {
    let config = AdcConfig::default().clock(Clock::Pclk2_div_4).default_sample_time(SampleTime::Cycles_56);
    Adc::new(adc1, true, config, rcc)
}
