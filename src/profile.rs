//! The test manoeuvre: the surface position command `θ_cmd(t)` both models are driven by.
//!
//! A profile is a short list of segments, each starting at `start_s` and lasting until the next.
//! The standard profile gives every fault a visible signature: a step
//! (current saturation, overshoot: gain, friction), a fast reversal (voltage limit, backlash),
//! a slow ramp (friction level, short-circuit and eccentricity ripple) and a small 4 Hz sine
//! (repeated reversals: stick-slip, backlash).

use core::f32::consts::PI;

/// Most segments a profile can hold.
pub const MAX_SEGMENTS: usize = 16;

/// One piece of the command, active from `start_s` on.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Segment {
    /// `θ_cmd = value_rad`.
    Hold {
        /// Start time of the segment.
        start_s: f32,
        /// Held position.
        value_rad: f32,
    },
    /// `θ_cmd = start_rad + rate_rad_per_s·(t − start_s)`.
    Ramp {
        /// Start time of the segment.
        start_s: f32,
        /// Position at `start_s`.
        start_rad: f32,
        /// Slope.
        rate_rad_per_s: f32,
    },
    /// `θ_cmd = offset_rad + amplitude_rad·sin(2π·frequency_hz·(t − start_s))`.
    Sine {
        /// Start time of the segment.
        start_s: f32,
        /// Mean position.
        offset_rad: f32,
        /// Amplitude.
        amplitude_rad: f32,
        /// Frequency.
        frequency_hz: f32,
    },
}

impl Segment {
    /// Start time of the segment.
    pub const fn start_s(&self) -> f32 {
        match *self {
            Segment::Hold { start_s, .. } | Segment::Ramp { start_s, .. } | Segment::Sine { start_s, .. } => start_s,
        }
    }

    #[cfg_attr(not(target_os = "none"), inline)]
    fn value_rad(&self, t_s: f32) -> f32 {
        match *self {
            Segment::Hold { value_rad, .. } => value_rad,
            Segment::Ramp { start_s, start_rad, rate_rad_per_s } => start_rad + rate_rad_per_s * (t_s - start_s),
            Segment::Sine { start_s, offset_rad, amplitude_rad, frequency_hz } => {
                offset_rad + amplitude_rad * crate::trig::sin(2.0 * PI * frequency_hz * (t_s - start_s))
            }
        }
    }
}

/// Why a profile was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ProfileError {
    /// No segment, or more than [`MAX_SEGMENTS`].
    SegmentCount,
    /// A start time is not finite, negative, or not after the previous one; or the duration is not after the last start.
    TimeOrder,
    /// A value is not finite, or the command leaves the end stops.
    Value,
    /// A sine segment sweeps more than [`MAX_SINE_PHASE_RAD`] of phase over its length.
    SinePhase,
}

impl core::fmt::Display for ProfileError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ProfileError::SegmentCount => "a profile needs 1 to 16 segments",
            ProfileError::TimeOrder => {
                "segment start times must be finite, start at 0 and increase, and end before the duration"
            }
            ProfileError::Value => "a segment value is not finite or beyond the end stops",
            ProfileError::SinePhase => {
                "a sine segment sweeps more than 1000 rad of phase (2π × frequency × its length)"
            }
        })
    }
}

impl core::error::Error for ProfileError {}

/// Largest phase a sine segment may sweep over its length, `2π·f·(end − start)` (rad): the range
/// over which [`crate::trig::sin`] is checked against `libm` to [`crate::trig::MAX_ERROR`]. Its
/// single-precision range reduction is exact only for moderate arguments; far beyond, it loses
/// the phase and then gives a non-finite command. 1000 rad is 159 periods (4 s at 40 Hz).
pub const MAX_SINE_PHASE_RAD: f32 = 1000.0;

/// A command profile: up to [`MAX_SEGMENTS`] segments and a total duration.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Profile {
    segments: [Segment; MAX_SEGMENTS],
    len: usize,
    duration_s: f32,
}

const EMPTY: Segment = Segment::Hold { start_s: 0.0, value_rad: 0.0 };

impl Profile {
    /// The standard 0.85 s test manoeuvre.
    pub const STANDARD: Profile = {
        let mut segments = [EMPTY; MAX_SEGMENTS];
        segments[0] = Segment::Hold { start_s: 0.0, value_rad: 0.0 };
        segments[1] = Segment::Hold { start_s: 0.01, value_rad: 0.05 };
        segments[2] = Segment::Hold { start_s: 0.15, value_rad: -0.05 };
        segments[3] = Segment::Ramp { start_s: 0.30, start_rad: -0.05, rate_rad_per_s: 0.2 };
        segments[4] = Segment::Sine { start_s: 0.60, offset_rad: 0.01, amplitude_rad: 0.01, frequency_hz: 4.0 };
        Profile { segments, len: 5, duration_s: 0.85 }
    };

    /// The pre-flight built-in test manoeuvre `pbit` (0.88 s), designed for the weak modes
    /// (eccentricity and its phase, low short circuits, gain drift; `docs/pbit.md`,
    /// decision 0023): a step to 0.05 rad and a reversal to −0.05 rad (gain, current saturation,
    /// backlash; the standard manoeuvre's step), then four constant-rate segments of 0.17 s at
    /// ±0.3 rad/s at the surface (150 rad/s at the motor, half the fast regime's 300 rad/s, so
    /// every sample weighs fully in the fitness), each change of sign a reversal. The
    /// eccentricity's current ripple is periodic in the rotor angle: the 0.68 s at constant rate
    /// hold 16 motor turns of it, against 4.8 in the standard's ramp. Of the candidates of the
    /// design (steps of 0.02–0.1 rad, one to four constant-rate segments of 0.1–0.55 rad/s), it
    /// is chosen by its Cramér–Rao bounds on the weak modes *and* by the monitor model's bias on
    /// it: a larger step or faster ramps carry more information but run the motor where the
    /// monitor model departs from the actuator, and the identification's error follows the bias.
    pub const PBIT: Profile = {
        let mut segments = [EMPTY; MAX_SEGMENTS];
        segments[0] = Segment::Hold { start_s: 0.0, value_rad: 0.0 };
        segments[1] = Segment::Hold { start_s: 0.01, value_rad: 0.05 };
        segments[2] = Segment::Hold { start_s: 0.10, value_rad: -0.05 };
        segments[3] = Segment::Ramp { start_s: 0.20, start_rad: -0.05, rate_rad_per_s: 0.3 };
        segments[4] = Segment::Ramp { start_s: 0.37, start_rad: 0.001, rate_rad_per_s: -0.3 };
        segments[5] = Segment::Ramp { start_s: 0.54, start_rad: -0.05, rate_rad_per_s: 0.3 };
        segments[6] = Segment::Ramp { start_s: 0.71, start_rad: 0.001, rate_rad_per_s: -0.3 };
        Profile { segments, len: 7, duration_s: 0.88 }
    };

    /// Builds a checked profile; `end_stop_rad` bounds the commanded value at every segment start and end.
    pub fn new(segments: &[Segment], duration_s: f32, end_stop_rad: f32) -> Result<Self, ProfileError> {
        if segments.is_empty() || segments.len() > MAX_SEGMENTS {
            return Err(ProfileError::SegmentCount);
        }
        if !duration_s.is_finite() || duration_s <= 0.0 || segments[0].start_s() != 0.0 {
            return Err(ProfileError::TimeOrder);
        }
        let mut out = [EMPTY; MAX_SEGMENTS];
        for (i, s) in segments.iter().enumerate() {
            let start = s.start_s();
            let end = segments.get(i + 1).map_or(duration_s, Segment::start_s);
            if !start.is_finite() || !end.is_finite() || end <= start {
                return Err(ProfileError::TimeOrder);
            }
            let fields_ok = match *s {
                Segment::Hold { value_rad, .. } => value_rad.is_finite(),
                Segment::Ramp { start_rad, rate_rad_per_s, .. } => start_rad.is_finite() && rate_rad_per_s.is_finite(),
                Segment::Sine { offset_rad, amplitude_rad, frequency_hz, .. } => {
                    offset_rad.is_finite()
                        && amplitude_rad.is_finite()
                        && frequency_hz.is_finite()
                        && frequency_hz >= 0.0
                }
            };
            let bound = match *s {
                Segment::Sine { offset_rad, amplitude_rad, .. } => libm::fabsf(offset_rad) + libm::fabsf(amplitude_rad),
                _ => libm::fmaxf(libm::fabsf(s.value_rad(start)), libm::fabsf(s.value_rad(end))),
            };
            if !fields_ok || bound.is_nan() || end_stop_rad.is_nan() || bound >= end_stop_rad {
                return Err(ProfileError::Value);
            }
            if let Segment::Sine { frequency_hz, .. } = *s {
                let phase_rad = 2.0 * PI * frequency_hz * (end - start);
                if phase_rad.is_nan() || phase_rad > MAX_SINE_PHASE_RAD {
                    return Err(ProfileError::SinePhase);
                }
            }
            out[i] = *s;
        }
        Ok(Profile { segments: out, len: segments.len(), duration_s })
    }

    /// The segments in time order.
    pub fn segments(&self) -> &[Segment] {
        // `len` ≤ MAX_SEGMENTS by construction; the `min` states it to the compiler (no panic path).
        &self.segments[..self.len.min(MAX_SEGMENTS)]
    }

    /// Total duration of the manoeuvre.
    pub fn duration_s(&self) -> f32 {
        self.duration_s
    }

    /// Commanded surface position at time `t_s` (the last segment that has started; the first before 0).
    pub fn command_rad(&self, t_s: f32) -> f32 {
        let mut active = &self.segments[0];
        for s in self.segments() {
            if s.start_s() <= t_s {
                active = s;
            } else {
                break;
            }
        }
        active.value_rad(t_s)
    }
}

/// Reads a [`Profile`] at non-decreasing times without rescanning its segments (the monitor
/// model's hot loop): same values as [`Profile::command_rad`].
#[derive(Clone, Debug)]
pub struct ProfileCursor<'a> {
    segments: &'a [Segment],
    active: usize,
}

impl<'a> ProfileCursor<'a> {
    /// A cursor at the profile's first segment.
    pub fn new(profile: &'a Profile) -> Self {
        Self { segments: profile.segments(), active: 0 }
    }

    /// Commanded surface position at `t_s`, which must not be earlier than the previous call's.
    #[cfg_attr(not(target_os = "none"), inline)]
    pub fn command_rad(&mut self, t_s: f32) -> f32 {
        while let Some(next) = self.segments.get(self.active + 1) {
            if next.start_s() > t_s {
                break;
            }
            self.active += 1;
        }
        match self.segments.get(self.active) {
            Some(s) => s.value_rad(t_s),
            None => 0.0, // a profile always has a segment (checked when it is built)
        }
    }
}

impl Default for Profile {
    fn default() -> Self {
        Self::STANDARD
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cursor_reads_what_the_profile_says() {
        let p = Profile::STANDARD;
        let mut cursor = ProfileCursor::new(&p);
        for step in 0..9000 {
            let t = step as f32 * 1e-4;
            assert_eq!(cursor.command_rad(t).to_bits(), p.command_rad(t).to_bits(), "t = {t}");
        }
    }

    #[test]
    fn standard_profile_values() {
        let p = Profile::STANDARD;
        assert_eq!(p.command_rad(0.005), 0.0);
        assert_eq!(p.command_rad(0.1), 0.05);
        assert_eq!(p.command_rad(0.2), -0.05);
        assert!((p.command_rad(0.45) - (-0.05 + 0.2 * 0.15)).abs() < 1e-6);
        assert!((p.command_rad(0.6625) - 0.02).abs() < 1e-5); // quarter period of 4 Hz
        assert!(Profile::new(p.segments(), p.duration_s(), 0.6).is_ok());
    }

    /// `pbit` passes the checks of a profile file, lasts at most 1.0 s and fits the on-board
    /// window, and its command is continuous from the reversal on (each ramp starts where the
    /// previous one ends); its ramps stay at half the fast regime's motor speed.
    #[test]
    fn pbit_is_a_valid_manoeuvre_that_fits_on_board() {
        let p = Profile::PBIT;
        assert!(Profile::new(p.segments(), p.duration_s(), 0.6).is_ok());
        assert!(p.duration_s() <= 1.0);
        let samples = libm::roundf(p.duration_s() / 1e-4) as usize / crate::conditioning::DECIMATION;
        assert!(samples <= crate::conditioning::ONBOARD_WINDOW, "{samples} window samples");
        for pair in p.segments()[3..].windows(2) {
            let t = pair[1].start_s();
            assert!((pair[0].value_rad(t) - pair[1].value_rad(t)).abs() < 1e-6, "jump at {t} s");
        }
        assert!(p.segments().iter().all(|s| match *s {
            Segment::Ramp { rate_rad_per_s, .. } => rate_rad_per_s.abs() <= 0.3,
            _ => true,
        }));
    }

    #[test]
    fn bad_profiles_are_refused() {
        let hold = |start_s, value_rad| Segment::Hold { start_s, value_rad };
        assert_eq!(Profile::new(&[], 1.0, 0.6), Err(ProfileError::SegmentCount));
        assert_eq!(Profile::new(&[hold(0.1, 0.0)], 1.0, 0.6), Err(ProfileError::TimeOrder));
        assert_eq!(Profile::new(&[hold(0.0, 0.0), hold(0.0, 0.1)], 1.0, 0.6), Err(ProfileError::TimeOrder));
        assert_eq!(Profile::new(&[hold(0.0, 0.0)], f32::NAN, 0.6), Err(ProfileError::TimeOrder));
        assert_eq!(Profile::new(&[hold(0.0, 0.7)], 1.0, 0.6), Err(ProfileError::Value));
        assert_eq!(Profile::new(&[hold(0.0, f32::INFINITY)], 1.0, 0.6), Err(ProfileError::Value));
        let ramp = Segment::Ramp { start_s: 0.0, start_rad: 0.0, rate_rad_per_s: 1.0 };
        assert_eq!(Profile::new(&[ramp], 1.0, 0.6), Err(ProfileError::Value));
    }

    /// A sine of 1e13 Hz (found by the `profile` fuzz target) once passed the checks and
    /// commanded −∞ rad: its phase was far beyond the range of the f32 sine.
    #[test]
    fn a_sine_beyond_the_phase_range_is_refused() {
        let hold = Segment::Hold { start_s: 0.0, value_rad: 0.01 };
        let sine =
            |frequency_hz| Segment::Sine { start_s: 0.868_888_9, offset_rad: 0.01, amplitude_rad: 0.04, frequency_hz };
        assert_eq!(Profile::new(&[hold, sine(1e13)], 1.8, 0.6), Err(ProfileError::SinePhase));
        assert_eq!(Profile::new(&[hold, sine(f32::MAX)], 1.8, 0.6), Err(ProfileError::SinePhase));
        // 150 Hz over 0.93 s is 877 rad: accepted, and the command stays inside the end stops
        let p = Profile::new(&[hold, sine(150.0)], 1.8, 0.6).unwrap();
        for step in 0..18_000 {
            let c = p.command_rad(step as f32 * 1e-4);
            assert!(c.is_finite() && libm::fabsf(c) <= 0.05 + 1e-6, "step {step}: {c}");
        }
        assert_eq!(Profile::new(&[hold, sine(175.0)], 1.8, 0.6), Err(ProfileError::SinePhase));
    }
}
