//! Acquisition: the three phase currents, from ADC codes to amperes, with data checks.
//!
//! The ADC is reached through **embedded-hal 0.2's `adc::OneShot`** (1.0 has no ADC trait; HALs
//! such as stm32f4xx-hal still implement the 0.2 one). [`PhaseCurrentReader`] is the one generic
//! consumer: it reads the three channels of a frame through any `OneShot<M, u16, P>` driver, retries
//! `nb::WouldBlock` a bounded number of times, converts each code with a per-phase fixed-point
//! [`Calibration`] and checks the frame. [`ReplayAdc`] is the board-agnostic driver that replays a
//! [`PackedTrace`](crate::trace::PackedTrace) (the firmware's built-in trace, and host tests).
//! A replay ends by itself; a live ADC does not, so a board wraps its reader in [`FrameLimit`],
//! which ends the acquisition on the manoeuvre's frame count, or hands it to a [`Sampler`]: a
//! timer interrupt reads one frame per control period into a bounded queue from a start trigger
//! on, thread mode consumes them, and a full queue ([`Overrun`](AcquisitionError::Overrun)) or a
//! missing trigger ([`NoTrigger`](AcquisitionError::NoTrigger)) ends the acquisition.
//!
//! ```text
//!  OneShot ADC ──codes──► range/saturation ─► stuck rule ─► sum rule ─► calibration ─► PhaseFrame
//!  (PhaseA/B/C pins)      (per code)          (per channel)  (per frame)  (Q16.16·Q0.32)   amperes
//! ```
//!
//! **Errors are values.** Each failed frame gives an [`AcquisitionError`]; the reader keeps going on
//! the next call, and the caller (the firmware) decides whether an error aborts the identification.
//! Nothing here panics or allocates. Priority within one frame: ADC failure / timeout / end of data
//! (the frame is incomplete) › [`OutOfRange`](AcquisitionError::OutOfRange) ›
//! [`Saturated`](AcquisitionError::Saturated) › [`Stuck`](AcquisitionError::Stuck) ›
//! [`InconsistentSum`](AcquisitionError::InconsistentSum).
//!
//! **Saturation.** A code of `0` or `ADC_MAX` means the sensor clipped (beyond ±20 A at the nominal
//! gain): the frame is refused, naming the phase. A code above `ADC_MAX` (a broken driver) is
//! [`OutOfRange`](AcquisitionError::OutOfRange).
//!
//! **Stuck channel rule.** A channel is flagged when *all* of these hold:
//! 1. its code has stayed identical for at least [`AcquisitionConfig::stuck_min_frames`]
//!    consecutive frames (default 200 = 20 ms at 10 kHz);
//! 2. during that run at least one *other* channel spanned (max − min) at least
//!    [`AcquisitionConfig::stuck_activity_counts`] codes (default 40 ≈ 0.39 A): the motor is being
//!    driven, so a live sensor would have moved too;
//! 3. the frozen code is more than [`AcquisitionConfig::stuck_zero_band_counts`] (default 12 ≈
//!    0.12 A) away from the channel's zero-current code (its calibration offset, rounded).
//!
//! So a motor **at rest** (every channel quiet, even bit-for-bit constant in a noiseless recording)
//! fails 2, and a phase that is **off for a whole commutation sector** at low speed, or while holding
//! at standstill, sits at zero current and fails 3. The conducting pair of the hysteresis-controlled
//! drive ripples by the hysteresis band (0.3 A ≈ 30 counts) and never freezes for 20 ms. A channel
//! frozen *at zero* is left to the sum rule: as soon as the drive energises that phase, the other
//! two stop summing to zero. The flag repeats on every frame while the run lasts.
//!
//! **Sum rule.** The star point is isolated, so `ia + ib + ic = 0`. A frame is *off* when
//! `|ia + ib + ic| >` [`AcquisitionConfig::sum_tolerance_a`] (default 0.3 A); after
//! [`AcquisitionConfig::sum_frames`] consecutive off frames (default 5) every further off frame is
//! reported as [`InconsistentSum`](AcquisitionError::InconsistentSum) until a good frame resets the
//! count. Default tolerance: sensor noise σ = 0.02 A per phase gives σ = 0.035 A on the sum (0.3 A is
//! 8.6 σ; 5 frames in a row make a false alarm negligible), quantization adds ≤ 0.015 A, and a 1 %
//! residual gain mismatch at 20 A adds 0.2 A. Frames with a saturated code are skipped by this rule
//! (neither counted nor resetting): a clipped phase breaks the sum legitimately.
//!
//! **Timeout and missing samples.** `nb::WouldBlock` is retried up to
//! [`AcquisitionConfig::max_polls`] times, then [`Timeout`](AcquisitionError::Timeout). Driver errors
//! are classified through [`AdcError::kind`]: end of data ([`ReplayAdc`] past its last frame) →
//! [`EndOfData`](AcquisitionError::EndOfData), a lost conversion (overrun) →
//! [`Missing`](AcquisitionError::Missing), anything else → [`Adc`](AcquisitionError::Adc).

mod calibration;
mod detect;
mod limit;
mod replay;
mod sampler;
mod summary;
mod temperature;

use core::convert::Infallible;
use core::fmt;
use core::marker::PhantomData;

use embedded_hal::adc::{Channel, OneShot};

pub use calibration::{AmpsFixed, Calibration, GainAmpsPerCount, OffsetCounts, PhaseCalibration};
pub use limit::{manoeuvre_frames, FrameLimit};
pub use replay::{ReplayAdc, ReplayError};
pub use sampler::{Sample, Sampler, SamplerConfig, SamplerConsumer, SamplerProducer, SamplerState, SAMPLER_QUEUE};
pub use summary::{AcquisitionSummary, MAX_REFUSED_RUN, MAX_REFUSED_SHARE};
pub use temperature::{TemperatureReading, TemperatureSensor, PLAUSIBLE_MARGIN_C};

use crate::trace::ADC_MAX;
use detect::{StuckDetector, SumDetector};

/// One of the three motor phases.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// Phase A.
    A,
    /// Phase B.
    B,
    /// Phase C.
    C,
}

impl Phase {
    /// The three phases in frame order.
    pub const ALL: [Phase; 3] = [Phase::A, Phase::B, Phase::C];

    /// Position of the phase in a frame (A = 0, B = 1, C = 2).
    pub const fn index(self) -> usize {
        match self {
            Phase::A => 0,
            Phase::B => 1,
            Phase::C => 2,
        }
    }
}

impl fmt::Display for Phase {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Phase::A => "A",
            Phase::B => "B",
            Phase::C => "C",
        })
    }
}

/// ADC pin of phase A (a zero-sized channel marker; channel number 0).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PhaseA;
/// ADC pin of phase B (a zero-sized channel marker; channel number 1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PhaseB;
/// ADC pin of phase C (a zero-sized channel marker; channel number 2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PhaseC;

/// A pin type that carries one phase current (implemented by [`PhaseA`], [`PhaseB`], [`PhaseC`]).
pub trait PhasePin {
    /// The phase this pin measures.
    const PHASE: Phase;
}

macro_rules! phase_pin {
    ($pin:ident, $phase:ident) => {
        impl PhasePin for $pin {
            const PHASE: Phase = Phase::$phase;
        }
        /// Channel number = [`Phase::index`], for any ADC.
        impl<ADC> Channel<ADC> for $pin {
            type ID = u8;
            fn channel() -> u8 {
                Phase::$phase.index() as u8
            }
        }
    };
}
phase_pin!(PhaseA, A);
phase_pin!(PhaseB, B);
phase_pin!(PhaseC, C);

/// What kind of failure an ADC driver reported (embedded-hal `Error::kind()` style).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum AdcErrorKind {
    /// No more data will come (a replay reached its end).
    EndOfData,
    /// The conversion of this sample was lost (overrun, DMA late): the sample is missing.
    Overrun,
    /// Any other driver failure.
    Other,
}

/// The error type of a `OneShot` driver, classified for [`PhaseCurrentReader`].
///
/// Implemented for `()` (many 0.2 HALs), [`Infallible`] and [`ReplayError`]; a HAL with its own
/// error type needs one small impl here (or a wrapper driver).
pub trait AdcError: fmt::Debug {
    /// Classifies the error.
    fn kind(&self) -> AdcErrorKind;
}

impl AdcError for () {
    fn kind(&self) -> AdcErrorKind {
        AdcErrorKind::Other
    }
}

impl AdcError for Infallible {
    fn kind(&self) -> AdcErrorKind {
        match *self {}
    }
}

/// Why a frame of phase currents is not available or not trustworthy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum AcquisitionError {
    /// The code is 0 or `ADC_MAX`: the current sensor of `phase` clipped.
    Saturated {
        /// Phase that clipped.
        phase: Phase,
        /// The clipped code (0 or `ADC_MAX`).
        code: u16,
    },
    /// The driver returned a code above `ADC_MAX` (not a 12-bit sample).
    OutOfRange {
        /// Phase of the bad code.
        phase: Phase,
        /// The code.
        code: u16,
    },
    /// The channel of `phase` has returned `code` for too long while the others moved (module doc).
    Stuck {
        /// Phase whose channel is frozen.
        phase: Phase,
        /// The frozen code.
        code: u16,
    },
    /// `ia + ib + ic` has been beyond the tolerance for `sum_frames` consecutive frames or more
    /// (isolated star: the sum must be ≈ 0).
    InconsistentSum {
        /// The sum of this frame, in milliamperes.
        sum_ma: i32,
    },
    /// The driver kept answering `WouldBlock` for `max_polls` polls.
    Timeout {
        /// Phase being converted.
        phase: Phase,
    },
    /// The driver lost this sample (overrun).
    Missing {
        /// Phase whose sample is missing.
        phase: Phase,
    },
    /// The driver reported a failure.
    Adc {
        /// Phase being converted.
        phase: Phase,
    },
    /// No more data (replay finished, or a live acquisition ended: [`SamplerConsumer::outcome`]).
    EndOfData,
    /// The timer-paced sampler found its queue full: thread mode fell a whole queue behind and
    /// frame `frame` (counted from the trigger) is lost. The acquisition ends ([`Sampler`]).
    Overrun {
        /// Index of the lost frame from the trigger (= frames queued before it).
        frame: u32,
    },
    /// The start trigger did not come within the sampler's timeout.
    NoTrigger {
        /// Ticks waited.
        waited_frames: u32,
    },
}

impl AcquisitionError {
    /// The phase the error names, if any.
    pub const fn phase(&self) -> Option<Phase> {
        match *self {
            AcquisitionError::Saturated { phase, .. }
            | AcquisitionError::OutOfRange { phase, .. }
            | AcquisitionError::Stuck { phase, .. }
            | AcquisitionError::Timeout { phase }
            | AcquisitionError::Missing { phase }
            | AcquisitionError::Adc { phase } => Some(phase),
            AcquisitionError::InconsistentSum { .. }
            | AcquisitionError::EndOfData
            | AcquisitionError::Overrun { .. }
            | AcquisitionError::NoTrigger { .. } => None,
        }
    }
}

impl fmt::Display for AcquisitionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            AcquisitionError::Saturated { phase, code } => {
                write!(f, "phase {phase} current sensor saturated (code {code})")
            }
            AcquisitionError::OutOfRange { phase, code } => write!(f, "phase {phase} code {code} above the ADC range"),
            AcquisitionError::Stuck { phase, code } => {
                write!(f, "phase {phase} channel stuck at code {code} while the other phases move")
            }
            AcquisitionError::InconsistentSum { sum_ma } => {
                write!(f, "phase currents do not sum to zero ({sum_ma} mA, isolated star)")
            }
            AcquisitionError::Timeout { phase } => write!(f, "phase {phase} conversion timed out"),
            AcquisitionError::Missing { phase } => write!(f, "phase {phase} sample missing (ADC overrun)"),
            AcquisitionError::Adc { phase } => write!(f, "phase {phase} ADC error"),
            AcquisitionError::EndOfData => f.write_str("end of phase-current data"),
            AcquisitionError::Overrun { frame } => {
                write!(f, "sampler overrun: frame queue full at frame {frame} (thread mode too slow)")
            }
            AcquisitionError::NoTrigger { waited_frames } => {
                write!(f, "no start trigger within {waited_frames} frames")
            }
        }
    }
}

impl core::error::Error for AcquisitionError {}

/// Why a calibration or an [`AcquisitionConfig`] was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConfigError {
    /// The offset is not finite or not strictly inside `(0, ADC_MAX)` counts.
    Offset,
    /// The gain is not finite, not in `(0, 1)` A/count, or below the Q0.32 resolution.
    Gain,
    /// `max_polls` is 0.
    MaxPolls,
    /// `stuck_min_frames` is below 2 or `stuck_activity_counts` is 0.
    StuckRule,
    /// `sum_tolerance_a` is not finite and positive, or `sum_frames` is 0.
    SumRule,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ConfigError::Offset => "calibration offset must be finite and strictly inside the ADC range",
            ConfigError::Gain => "calibration gain must be finite, in (0, 1) A/count and representable",
            ConfigError::MaxPolls => "max_polls must be at least 1",
            ConfigError::StuckRule => "stuck rule needs stuck_min_frames >= 2 and stuck_activity_counts >= 1",
            ConfigError::SumRule => "sum rule needs a finite positive tolerance and sum_frames >= 1",
        })
    }
}

impl core::error::Error for ConfigError {}

/// Settings of the reader's checks (defaults and their reasons in the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub struct AcquisitionConfig {
    /// Polls of one conversion before [`AcquisitionError::Timeout`] (default 1000).
    pub max_polls: u32,
    /// Frames a code must stay identical before the channel can be stuck (default 200).
    pub stuck_min_frames: u32,
    /// Span another channel must cover during that run (default 40 counts ≈ 0.39 A).
    pub stuck_activity_counts: u16,
    /// Codes this close to the zero-current code are never stuck (default 12 counts ≈ 0.12 A).
    pub stuck_zero_band_counts: u16,
    /// Largest `|ia + ib + ic|` of a consistent frame (default 0.3 A).
    pub sum_tolerance_a: f32,
    /// Consecutive inconsistent frames before reporting (default 5).
    pub sum_frames: u32,
}

impl AcquisitionConfig {
    /// The defaults (10 kHz frames, nominal ±20 A sensors).
    pub const DEFAULT: Self = Self {
        max_polls: 1000,
        stuck_min_frames: 200,
        stuck_activity_counts: 40,
        stuck_zero_band_counts: 12,
        sum_tolerance_a: 0.3,
        sum_frames: 5,
    };

    /// Checks the settings (see [`ConfigError`]).
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.max_polls == 0 {
            return Err(ConfigError::MaxPolls);
        }
        if self.stuck_min_frames < 2 || self.stuck_activity_counts == 0 {
            return Err(ConfigError::StuckRule);
        }
        if !self.sum_tolerance_a.is_finite() || self.sum_tolerance_a <= 0.0 || self.sum_frames == 0 {
            return Err(ConfigError::SumRule);
        }
        Ok(())
    }
}

impl Default for AcquisitionConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One frame of phase currents.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PhaseFrame {
    /// Phase A current.
    pub ia_a: f32,
    /// Phase B current.
    pub ib_a: f32,
    /// Phase C current.
    pub ic_a: f32,
    /// The raw ADC codes `[a, b, c]`.
    pub codes: [u16; 3],
}

impl PhaseFrame {
    /// The currents `[ia, ib, ic]`.
    pub const fn currents_a(&self) -> [f32; 3] {
        [self.ia_a, self.ib_a, self.ic_a]
    }
}

/// A source of checked phase-current frames: what the conditioning stage consumes.
pub trait PhaseCurrents {
    /// The next frame, or why there is none (the source stays usable after an error).
    fn read_frame(&mut self) -> Result<PhaseFrame, AcquisitionError>;
}

/// Reads the three phase currents through any embedded-hal 0.2 `OneShot` driver `A`.
///
/// `PA`, `PB`, `PC` are the pins (channels) of phases A, B, C; `M` is the ADC marker type of the
/// `OneShot<M, u16, P>` impls (HALs use the peripheral, e.g. `OneShot<ADC1, u16, PA0> for
/// Adc<ADC1>`; [`ReplayAdc`] uses itself, the default).
pub struct PhaseCurrentReader<A, PA, PB, PC, M = A> {
    adc: A,
    pins: (PA, PB, PC),
    check: FrameCheck,
    frames: u32,
    _marker: PhantomData<fn() -> M>,
}

/// The reader over the built-in trace replay.
pub type ReplayReader<'a> = PhaseCurrentReader<ReplayAdc<'a>, PhaseA, PhaseB, PhaseC>;

impl<A, PA, PB, PC, M> PhaseCurrentReader<A, PA, PB, PC, M>
where
    A: OneShot<M, u16, PA> + OneShot<M, u16, PB> + OneShot<M, u16, PC>,
    PA: Channel<M>,
    PB: Channel<M>,
    PC: Channel<M>,
    <A as OneShot<M, u16, PA>>::Error: AdcError,
    <A as OneShot<M, u16, PB>>::Error: AdcError,
    <A as OneShot<M, u16, PC>>::Error: AdcError,
{
    /// A reader of `adc` on `pins` (A, B, C), with a validated calibration and checked `config`.
    pub fn new(
        adc: A,
        pins: (PA, PB, PC),
        calibration: Calibration,
        config: AcquisitionConfig,
    ) -> Result<Self, ConfigError> {
        Ok(Self { adc, pins, check: FrameCheck::new(calibration, config)?, frames: 0, _marker: PhantomData })
    }

    /// Converts the three channels of the next frame and checks it (see the module doc).
    pub fn read_frame(&mut self) -> Result<PhaseFrame, AcquisitionError> {
        let polls = self.check.config.max_polls;
        let a = poll(&mut self.adc, &mut self.pins.0, Phase::A, polls)?;
        let b = poll(&mut self.adc, &mut self.pins.1, Phase::B, polls)?;
        let c = poll(&mut self.adc, &mut self.pins.2, Phase::C, polls)?;
        self.frames = self.frames.saturating_add(1);
        self.check.codes([a, b, c])
    }
}

impl<A, PA, PB, PC, M> PhaseCurrentReader<A, PA, PB, PC, M> {
    /// Complete frames converted so far (including those refused by a check).
    pub const fn frames_read(&self) -> u32 {
        self.frames
    }

    /// The calibration in use.
    pub const fn calibration(&self) -> &Calibration {
        &self.check.calibration
    }

    /// The check settings in use.
    pub const fn config(&self) -> &AcquisitionConfig {
        &self.check.config
    }

    /// The driver.
    pub const fn adc(&self) -> &A {
        &self.adc
    }

    /// The driver, for another channel between acquisitions (e.g. a temperature input on the
    /// same ADC while no frame is read).
    pub fn adc_mut(&mut self) -> &mut A {
        &mut self.adc
    }

    /// Forgets the stuck and sum history (e.g. after a gap in the data).
    pub fn reset_checks(&mut self) {
        self.check.reset();
    }

    /// Gives the driver and the pins back.
    pub fn release(self) -> (A, (PA, PB, PC)) {
        (self.adc, self.pins)
    }
}

impl<A, PA, PB, PC, M> PhaseCurrents for PhaseCurrentReader<A, PA, PB, PC, M>
where
    A: OneShot<M, u16, PA> + OneShot<M, u16, PB> + OneShot<M, u16, PC>,
    PA: Channel<M>,
    PB: Channel<M>,
    PC: Channel<M>,
    <A as OneShot<M, u16, PA>>::Error: AdcError,
    <A as OneShot<M, u16, PB>>::Error: AdcError,
    <A as OneShot<M, u16, PC>>::Error: AdcError,
{
    fn read_frame(&mut self) -> Result<PhaseFrame, AcquisitionError> {
        PhaseCurrentReader::read_frame(self)
    }
}

/// The checks of one frame (range and saturation, stuck channel, sum; module doc), with their
/// history: the one implementation behind the ADC reader ([`FrameCheck::codes`]) and recordings
/// given in amperes ([`FrameCheck::amps`], `ema identify`'s CSV path).
#[derive(Clone, Copy, Debug)]
pub struct FrameCheck {
    calibration: Calibration,
    config: AcquisitionConfig,
    zero_codes: [u16; 3],
    stuck: StuckDetector,
    sum: SumDetector,
}

impl FrameCheck {
    /// Checks of frames read through `calibration`, with the checked `config`.
    pub fn new(calibration: Calibration, config: AcquisitionConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let zero_codes = Phase::ALL.map(|p| calibration.phase(p).zero_code());
        Ok(Self { calibration, config, zero_codes, stuck: StuckDetector::new(), sum: SumDetector::new() })
    }

    /// Forgets the stuck and sum history.
    pub fn reset(&mut self) {
        self.stuck = StuckDetector::new();
        self.sum = SumDetector::new();
    }

    /// Checks the ADC codes `[a, b, c]` of the next frame and converts them to amperes.
    pub fn codes(&mut self, codes: [u16; 3]) -> Result<PhaseFrame, AcquisitionError> {
        for phase in Phase::ALL {
            let code = codes[phase.index()];
            if code > ADC_MAX {
                return Err(AcquisitionError::OutOfRange { phase, code });
            }
        }
        let stuck = self.stuck.update(codes, self.zero_codes, &self.config);
        for phase in Phase::ALL {
            let code = codes[phase.index()];
            if code == 0 || code == ADC_MAX {
                return Err(AcquisitionError::Saturated { phase, code });
            }
        }
        let [a, b, c] = codes;
        let frame = PhaseFrame {
            ia_a: self.calibration.phase(Phase::A).to_amps(a),
            ib_a: self.calibration.phase(Phase::B).to_amps(b),
            ic_a: self.calibration.phase(Phase::C).to_amps(c),
            codes,
        };
        let sum_a = frame.ia_a + frame.ib_a + frame.ic_a;
        let inconsistent = self.sum.update(sum_a, &self.config);
        if let Some((phase, code)) = stuck {
            return Err(AcquisitionError::Stuck { phase, code });
        }
        if inconsistent {
            // |sum| ≤ 3·4095 A·gain < 12 300 A: the cast cannot saturate in practice (and `as` saturates)
            return Err(AcquisitionError::InconsistentSum { sum_ma: libm::roundf(sum_a * 1000.0) as i32 });
        }
        Ok(frame)
    }

    /// Checks a frame given in amperes `[ia, ib, ic]`: each current is mapped to the code the
    /// calibrated sensor would give (`code = round(i/gain + offset)`, clipped to `[0, ADC_MAX]`, so
    /// a current beyond the sensor's range reads as saturated, a NaN as out of range), then
    /// checked as [`FrameCheck::codes`] does. The returned frame keeps the given currents.
    pub fn amps(&mut self, currents_a: [f32; 3]) -> Result<PhaseFrame, AcquisitionError> {
        let mut codes = [0u16; 3];
        for phase in Phase::ALL {
            let cal = self.calibration.phase(phase);
            let gain = cal.gain_a_per_count().to_num::<f32>();
            let offset = cal.offset_counts().to_num::<f32>();
            let i = currents_a[phase.index()];
            if !i.is_finite() {
                return Err(AcquisitionError::OutOfRange { phase, code: u16::MAX });
            }
            let code = libm::roundf(i / gain + offset);
            codes[phase.index()] = code.clamp(0.0, f32::from(ADC_MAX)) as u16;
        }
        let frame = self.codes(codes)?;
        Ok(PhaseFrame { ia_a: currents_a[0], ib_a: currents_a[1], ic_a: currents_a[2], codes: frame.codes })
    }
}

/// One conversion: at most `max_polls` polls, driver errors classified.
fn poll<A, P, M>(adc: &mut A, pin: &mut P, phase: Phase, max_polls: u32) -> Result<u16, AcquisitionError>
where
    A: OneShot<M, u16, P>,
    P: Channel<M>,
    A::Error: AdcError,
{
    for _ in 0..max_polls {
        match adc.read(pin) {
            Ok(code) => return Ok(code),
            Err(nb::Error::WouldBlock) => {}
            Err(nb::Error::Other(e)) => {
                return Err(match e.kind() {
                    AdcErrorKind::EndOfData => AcquisitionError::EndOfData,
                    AdcErrorKind::Overrun => AcquisitionError::Missing { phase },
                    AdcErrorKind::Other => AcquisitionError::Adc { phase },
                });
            }
        }
    }
    Err(AcquisitionError::Timeout { phase })
}

#[cfg(test)]
mod tests;
