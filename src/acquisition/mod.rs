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
//! `|ia + ib + ic| >` [`AcquisitionConfig::sum_tolerance_a`] `+`
//! [`AcquisitionConfig::sum_tolerance_share`]` · max |i_j|` (defaults 0.3 A and 0.02), plus, when
//! the phases are sampled at different instants ([`AcquisitionConfig::phase_skew_us`], one ADC
//! converting them in turn), the skews' spread times the fastest current slope
//! ([`AcquisitionConfig::max_current_slope_a_per_us`]; [`AcquisitionConfig::sum_tolerance_at`]); after
//! [`AcquisitionConfig::sum_frames`] consecutive off frames (default 5) every further off frame is
//! reported as [`InconsistentSum`](AcquisitionError::InconsistentSum) until a good frame resets the
//! count. Default tolerance: sensor noise σ = 0.02 A per phase gives σ = 0.035 A on the sum (0.3 A is
//! 8.6 σ; 5 frames in a row make a false alarm negligible) and quantization adds ≤ 0.015 A; the
//! sensors' gains, each within about 1 % of its declaration, differ by up to 2 %, which moves the
//! sum by that share of the conducting current. A larger mismatch, held over the manoeuvre, is the
//! gain check's to find (`self_calibration`). Frames with a saturated code are skipped by this rule
//! (neither counted nor resetting): a clipped phase breaks the sum legitimately.
//!
//! **Zero points.** A live reader configured with
//! [`AcquisitionConfig::self_calibration`] measures each phase's zero on the frames before the
//! trigger ([`PhaseCurrents::read_rest_frame`], [`PhaseCurrents::start_recording`]), so that a
//! board carries no hand-measured offset; [`SensorCheck`] says what it found
//! (`self_calibration`).
//!
//! **Timeout and missing samples.** `nb::WouldBlock` is retried up to
//! [`AcquisitionConfig::max_polls`] times, then [`Timeout`](AcquisitionError::Timeout). Driver errors
//! are classified through [`AdcError::kind`]: end of data ([`ReplayAdc`] past its last frame) →
//! [`EndOfData`](AcquisitionError::EndOfData), a lost conversion (overrun) →
//! [`Missing`](AcquisitionError::Missing), anything else → [`Adc`](AcquisitionError::Adc).

mod calibration;
mod detect;
mod frame_check;
mod limit;
mod replay;
mod sampler;
mod self_calibration;
mod summary;
mod temperature;

use core::convert::Infallible;
use core::fmt;
use core::marker::PhantomData;

use embedded_hal::adc::{Channel, OneShot};

pub use calibration::{AmpsFixed, Calibration, GainAmpsPerCount, OffsetCounts, PhaseCalibration};
pub use frame_check::FrameCheck;
pub use limit::{manoeuvre_frames, FrameLimit};
pub use replay::{replay_config, ReplayAdc, ReplayError};
pub use sampler::{Sample, Sampler, SamplerConfig, SamplerConsumer, SamplerProducer, SamplerState, SAMPLER_QUEUE};
pub use self_calibration::{
    GainCheck, RestEstimator, SelfCalibrationConfig, SensorCheck, SensorFault, ZeroSource, MAX_GAIN_MISMATCH,
    MIN_GAIN_CONDITION, REST_BLOCK_FRAMES,
};
pub use summary::{AcquisitionSummary, MAX_REFUSED_RUN, MAX_REFUSED_SHARE};
pub use temperature::{TemperatureReading, TemperatureSensor, PLAUSIBLE_MARGIN_C};

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
    /// `sum_tolerance_a` is not finite and positive, the share, a skew or the slope is negative
    /// or not finite, or `sum_frames` is 0.
    SumRule,
    /// A self-calibration limit is zero, negative or not finite.
    SelfCalibration,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ConfigError::Offset => "calibration offset must be finite and strictly inside the ADC range",
            ConfigError::Gain => "calibration gain must be finite, in (0, 1) A/count and representable",
            ConfigError::MaxPolls => "max_polls must be at least 1",
            ConfigError::StuckRule => "stuck rule needs stuck_min_frames >= 2 and stuck_activity_counts >= 1",
            ConfigError::SumRule => "sum rule needs a finite positive tolerance and sum_frames >= 1",
            ConfigError::SelfCalibration => "self-calibration limits must be positive and finite",
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
    /// Largest `|ia + ib + ic|` of a consistent frame at zero current (default 0.3 A).
    pub sum_tolerance_a: f32,
    /// Share of the frame's largest phase current added to that tolerance (default 0.02): the
    /// sensors' gain mismatch, which the gain check bounds over the manoeuvre.
    pub sum_tolerance_share: f32,
    /// When each phase is sampled after the frame's instant (µs): 0 for simultaneous sampling
    /// (the default), the conversion order's spacing for one ADC converting the phases in turn.
    pub phase_skew_us: [f32; 3],
    /// Fastest change of a phase current (A/µs) the skew can meet (default 0.0675 A/µs: the
    /// 270 V supply across the conducting pair's 2 × 2 mH). With skewed phases the sum rule's
    /// tolerance grows by `(max skew − min skew) · slope`: the phases' samples are up to that far
    /// apart along the current's ripple.
    pub max_current_slope_a_per_us: f32,
    /// Consecutive inconsistent frames before reporting (default 5).
    pub sum_frames: u32,
    /// The zero points measured on the frames before the trigger (`self_calibration`), or the
    /// declared calibration's kept (`None`, the default: a replay without rest frames).
    pub self_calibration: Option<SelfCalibrationConfig>,
}

impl AcquisitionConfig {
    /// The defaults (10 kHz frames, nominal ±20 A sensors).
    pub const DEFAULT: Self = Self {
        max_polls: 1000,
        stuck_min_frames: 200,
        stuck_activity_counts: 40,
        stuck_zero_band_counts: 12,
        sum_tolerance_a: 0.3,
        sum_tolerance_share: 0.02,
        phase_skew_us: [0.0; 3],
        max_current_slope_a_per_us: 0.0675,
        sum_frames: 5,
        self_calibration: None,
    };

    /// The defaults with the zero points measured before the trigger
    /// ([`SelfCalibrationConfig::DEFAULT`]): what a live board uses.
    pub const SELF_CALIBRATED: Self = Self { self_calibration: Some(SelfCalibrationConfig::DEFAULT), ..Self::DEFAULT };

    /// Checks the settings (see [`ConfigError`]).
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.max_polls == 0 {
            return Err(ConfigError::MaxPolls);
        }
        if self.stuck_min_frames < 2 || self.stuck_activity_counts == 0 {
            return Err(ConfigError::StuckRule);
        }
        let share_ok = self.sum_tolerance_share.is_finite() && self.sum_tolerance_share >= 0.0;
        let skew_ok = self.phase_skew_us.iter().all(|s| s.is_finite() && *s >= 0.0)
            && self.max_current_slope_a_per_us.is_finite()
            && self.max_current_slope_a_per_us >= 0.0;
        if !self.sum_tolerance_a.is_finite()
            || self.sum_tolerance_a <= 0.0
            || !share_ok
            || !skew_ok
            || self.sum_frames == 0
        {
            return Err(ConfigError::SumRule);
        }
        if self.self_calibration.is_some_and(|c| !c.is_valid()) {
            return Err(ConfigError::SelfCalibration);
        }
        Ok(())
    }
}

impl AcquisitionConfig {
    /// The settings a recording with `rest_frames` frames before its manoeuvre is read with: the
    /// defaults, with the sensors' zero points measured on those frames when there are at least
    /// [`SelfCalibrationConfig::min_rest_frames`], the declared ones kept otherwise. A live board
    /// always measures them, and a trigger too soon after arming is a sensor fault there; a
    /// recording made without the pre-trigger in mind is not.
    pub const fn for_recorded_rest(rest_frames: usize) -> Self {
        // `as`: a usize beyond u32 is far more than enough rest frames either way
        if rest_frames >= SelfCalibrationConfig::DEFAULT.min_rest_frames as usize {
            Self::SELF_CALIBRATED
        } else {
            Self::DEFAULT
        }
    }

    /// These settings for phases sampled `phase_skew_us` after the frame's instant.
    pub const fn with_phase_skew_us(self, phase_skew_us: [f32; 3]) -> Self {
        Self { phase_skew_us, ..self }
    }

    /// The sum rule's tolerance for a frame whose largest phase current is `peak_a` (module doc).
    pub fn sum_tolerance_at(&self, peak_a: f32) -> f32 {
        let [a, b, c] = self.phase_skew_us;
        let spread_us = a.max(b).max(c) - a.min(b).min(c);
        self.sum_tolerance_a + self.sum_tolerance_share * peak_a + spread_us * self.max_current_slope_a_per_us
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
///
/// A live source is also read before the trigger, with the actuator at rest
/// ([`PhaseCurrents::read_rest_frame`]), and told when the manoeuvre starts
/// ([`PhaseCurrents::start_recording`]), so that it can measure its sensors' zero points
/// ([`self_calibration`](SelfCalibrationConfig)); [`PhaseCurrents::sensor_check`] says what it found.
pub trait PhaseCurrents {
    /// The next frame, or why there is none (the source stays usable after an error).
    fn read_frame(&mut self) -> Result<PhaseFrame, AcquisitionError>;

    /// One frame before the trigger (the actuator at rest). By default, read and dropped.
    fn read_rest_frame(&mut self) -> Result<(), AcquisitionError> {
        self.read_frame().map(|_| ())
    }

    /// The trigger came: the frames from here on are the manoeuvre's. By default, nothing.
    fn start_recording(&mut self) {}

    /// A new acquisition is armed on the same source (a board's next flight): the rest frames
    /// start afresh. By default, nothing.
    fn rearm(&mut self) {}

    /// What the sensors' self-calibration found; by default the declared calibration.
    fn sensor_check(&self) -> SensorCheck {
        SensorCheck::DECLARED
    }
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
        let codes = self.convert()?;
        self.check.codes(codes)
    }

    /// Converts the three channels of one frame before the trigger, for the zero points.
    pub fn read_rest_frame(&mut self) -> Result<(), AcquisitionError> {
        let codes = self.convert()?;
        self.check.rest(codes);
        Ok(())
    }

    /// The three conversions of one frame.
    fn convert(&mut self) -> Result<[u16; 3], AcquisitionError> {
        let polls = self.check.config().max_polls;
        let a = poll(&mut self.adc, &mut self.pins.0, Phase::A, polls)?;
        let b = poll(&mut self.adc, &mut self.pins.1, Phase::B, polls)?;
        let c = poll(&mut self.adc, &mut self.pins.2, Phase::C, polls)?;
        self.frames = self.frames.saturating_add(1);
        Ok([a, b, c])
    }
}

impl<A, PA, PB, PC, M> PhaseCurrentReader<A, PA, PB, PC, M> {
    /// Complete frames converted so far (including those refused by a check).
    pub const fn frames_read(&self) -> u32 {
        self.frames
    }

    /// The calibration in use.
    pub const fn calibration(&self) -> &Calibration {
        self.check.calibration()
    }

    /// The check settings in use.
    pub const fn config(&self) -> &AcquisitionConfig {
        self.check.config()
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

    fn read_rest_frame(&mut self) -> Result<(), AcquisitionError> {
        PhaseCurrentReader::read_rest_frame(self)
    }

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
