//! The command source that drives the monitor model: a [`Profile`] or a sampled command.
//!
//! The monitor model follows the surface position command `θ_cmd` the actuator flew. When the
//! manoeuvre is a stored [`Profile`] (the standard manoeuvre, or segments read from a file), the
//! model evaluates it at every step. A recording made on any other manoeuvre carries its command
//! as samples: [`SampledCommand`] holds them in a fixed-size buffer, one every `stride` control
//! periods, and the model reads them back at its control rate,
//!
//! ```text
//! θ_cmd(n) = c_i + (c_{i+1} − c_i)·j/S,    n = i·S + j,  0 ≤ j < S
//! ```
//!
//! with `n` the model step, `S` the stride and `c_i` the samples (linear interpolation; at
//! `S = 1` every step reads its own sample, unchanged). After the last sample the command holds
//! its last value. [`Command`] is either source; [`crate::fitness`] turns it into a cursor once
//! per model run, so the standard profile's path is the same code as without this module.

use core::num::NonZeroU32;

use crate::params::EmaParams;
use crate::profile::{Profile, ProfileCursor};

/// Largest stride of a [`SampledCommand`]: one sample every 64 control periods (6.4 ms at the
/// nominal 10 kHz), beyond which linear interpolation would round off the steps and reversals
/// the manoeuvre is made of.
pub const MAX_STRIDE: u32 = 64;

/// Why a sampled command was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum CommandError {
    /// No sample.
    Empty,
    /// More samples than the buffer holds.
    TooLong {
        /// The buffer's capacity, in samples.
        capacity: usize,
    },
    /// The stride is not in `1..=`[`MAX_STRIDE`].
    Stride,
    /// Sample `index` is not finite.
    NotFinite {
        /// Index of the sample.
        index: usize,
    },
    /// Sample `index` is at or beyond the end stops (`|c_i| ≥ end_stop_rad`, or the end stop is
    /// not a number).
    BeyondEndStops {
        /// Index of the sample.
        index: usize,
    },
}

impl core::fmt::Display for CommandError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            CommandError::Empty => f.write_str("the sampled command has no sample"),
            CommandError::TooLong { capacity } => {
                write!(f, "the sampled command has more samples than its buffer holds ({capacity})")
            }
            CommandError::Stride => write!(f, "the stride is not 1 to {MAX_STRIDE} control periods"),
            CommandError::NotFinite { index } => write!(f, "command sample {index} is not finite"),
            CommandError::BeyondEndStops { index } => write!(f, "command sample {index} is beyond the end stops"),
        }
    }
}

impl core::error::Error for CommandError {}

/// A command sampled every `stride` control periods, in a buffer of `N` samples:
/// `4·N + 12` bytes. The standard 0.85 s manoeuvre takes 8500 samples at the control rate
/// (stride 1: 34 000 bytes, every model step reads its own sample) or 2125 at the fitness rate
/// (stride 4: 8500 bytes, interpolated); [`ONBOARD_COMMAND_SAMPLES`] covers the on-board window
/// at the control rate. Interpolation turns a step into a ramp over one sample period, which
/// moves the current-limited transient after it (by up to 6 A in a window sample at stride 4, the
/// module's tests), so a command with steps, like the standard one, is sampled at stride 1; a larger
/// stride suits a smooth command.
///
/// Built only by the checked constructors: every sample is finite and strictly inside the end
/// stops, and the stride is in `1..=`[`MAX_STRIDE`]; there is at least one sample, except in
/// [`SampledCommand::EMPTY`] (a zero-length manoeuvre) and after a refused load.
#[derive(Clone, Debug, PartialEq)]
pub struct SampledCommand<const N: usize> {
    samples: [f32; N],
    len: usize,
    stride: NonZeroU32,
}

/// Samples of a [`SampledCommand`] for the on-board window at the control rate:
/// [`crate::conditioning::ONBOARD_WINDOW`] window samples of [`crate::conditioning::DECIMATION`]
/// control periods (8800 samples, 35 200 bytes; the standard manoeuvre uses 8500).
pub const ONBOARD_COMMAND_SAMPLES: usize = crate::conditioning::ONBOARD_WINDOW * crate::conditioning::DECIMATION;

impl<const N: usize> SampledCommand<N> {
    /// No sample: a zero-length manoeuvre, which every trace is longer than (an identification
    /// under it is refused). It is the buffer a firmware keeps in a static and fills in place
    /// with [`SampledCommand::load`], so that the `4·N` bytes never pass through the stack.
    pub const EMPTY: Self = Self { samples: [0.0; N], len: 0, stride: NonZeroU32::MIN };

    /// The command `samples`, one every `stride` control periods, checked against the end stops
    /// `end_stop_rad` (the actuator's [`EmaParams::end_stop_rad`]).
    pub fn new(samples: impl IntoIterator<Item = f32>, stride: u32, end_stop_rad: f32) -> Result<Self, CommandError> {
        let mut out = Self::EMPTY;
        out.load(samples, stride, end_stop_rad)?;
        Ok(out)
    }

    /// [`SampledCommand::new`] in place: on an error the command is left [`SampledCommand::EMPTY`].
    pub fn load(
        &mut self,
        samples: impl IntoIterator<Item = f32>,
        stride: u32,
        end_stop_rad: f32,
    ) -> Result<(), CommandError> {
        self.len = 0;
        self.stride = NonZeroU32::new(stride).filter(|s| s.get() <= MAX_STRIDE).ok_or(CommandError::Stride)?;
        for (index, value) in samples.into_iter().enumerate() {
            let Some(slot) = self.samples.get_mut(index) else {
                self.len = 0;
                return Err(CommandError::TooLong { capacity: N });
            };
            // `inside` is false for a NaN end stop too
            let inside = libm::fabsf(value) < end_stop_rad;
            if !value.is_finite() || !inside {
                self.len = 0;
                return Err(if value.is_finite() {
                    CommandError::BeyondEndStops { index }
                } else {
                    CommandError::NotFinite { index }
                });
            }
            *slot = value;
            self.len = index + 1;
        }
        if self.len == 0 {
            return Err(CommandError::Empty);
        }
        Ok(())
    }

    /// `profile` sampled every `stride` control periods of `params` over its frames
    /// ([`Command::frames`]): sample `i` is `profile.command_rad(t)` at `t = (i·S)·T_c`, computed
    /// as the model computes its step time, so at stride 1 the model runs exactly as under the
    /// profile itself.
    pub fn sampled(profile: &Profile, stride: u32, params: &EmaParams) -> Result<Self, CommandError> {
        let mut out = Self::EMPTY;
        out.load_profile(profile, stride, params)?;
        Ok(out)
    }

    /// [`SampledCommand::sampled`] in place: on an error the command is left
    /// [`SampledCommand::EMPTY`].
    pub fn load_profile(&mut self, profile: &Profile, stride: u32, params: &EmaParams) -> Result<(), CommandError> {
        let Some(step) = NonZeroU32::new(stride).filter(|s| s.get() <= MAX_STRIDE) else {
            self.len = 0;
            return Err(CommandError::Stride);
        };
        let frames = Command::Profile(profile).frames(params);
        let count = frames.saturating_add(step.get() - 1) / step; // ⌈frames / S⌉, S ≠ 0
        let dt = params.control_period_s;
        let samples = (0..count).map(|i| profile.command_rad(i.wrapping_mul(step.get()) as f32 * dt));
        self.load(samples, stride, params.end_stop_rad)
    }

    /// The samples.
    pub fn samples(&self) -> &[f32] {
        // `len` ≤ N by construction; the `min` states it to the compiler (no panic path).
        &self.samples[..self.len.min(N)]
    }

    /// Control periods per sample.
    pub fn stride(&self) -> u32 {
        self.stride.get()
    }

    /// The command as the monitor model's source.
    pub fn as_command(&self) -> Command<'_> {
        Command::Sampled(CommandSamples { samples: self.samples(), stride: self.stride })
    }
}

/// A borrowed, checked view of a [`SampledCommand`]'s samples (any capacity).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CommandSamples<'a> {
    samples: &'a [f32],
    stride: NonZeroU32,
}

impl CommandSamples<'_> {
    /// The samples.
    pub fn samples(&self) -> &[f32] {
        self.samples
    }

    /// Control periods per sample.
    pub fn stride(&self) -> u32 {
        self.stride.get()
    }
}

/// What drives the monitor model: a profile, evaluated at every step, or a sampled command.
/// Both are borrowed: a command is held by every fitness and monitor (copies of a profile's
/// segments would cost each of them 320 bytes; nine at once on board).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command<'a> {
    /// A command profile (the standard manoeuvre or a profile file).
    Profile(&'a Profile),
    /// A sampled command, e.g. a recording's command column.
    Sampled(CommandSamples<'a>),
}

impl Command<'_> {
    /// Control periods the manoeuvre lasts: `round(T / T_c)` for a profile of duration `T`,
    /// samples × stride for a sampled command (the standard manoeuvre: 0.85 s / 100 µs = 8500).
    /// A non-finite or negative ratio gives 0 (the `as` cast saturates; nothing panics).
    pub fn frames(&self, params: &EmaParams) -> u32 {
        match self {
            Command::Profile(p) => libm::roundf(p.duration_s() / params.control_period_s) as u32,
            Command::Sampled(s) => (s.samples.len() as u32).saturating_mul(s.stride.get()),
        }
    }

    /// Duration of the manoeuvre: the profile's, or [`Command::frames`] control periods.
    pub fn duration_s(&self, params: &EmaParams) -> f32 {
        match self {
            Command::Profile(p) => p.duration_s(),
            Command::Sampled(_) => self.frames(params) as f32 * params.control_period_s,
        }
    }

    /// `profile` or `sampled`, for reports.
    pub fn label(&self) -> &'static str {
        match self {
            Command::Profile(_) => "profile",
            Command::Sampled(_) => "sampled",
        }
    }
}

impl<'a> From<&'a Profile> for Command<'a> {
    fn from(p: &'a Profile) -> Self {
        Command::Profile(p)
    }
}

impl<'a> From<CommandSamples<'a>> for Command<'a> {
    fn from(s: CommandSamples<'a>) -> Self {
        Command::Sampled(s)
    }
}

impl<'a, const N: usize> From<&'a SampledCommand<N>> for Command<'a> {
    fn from(s: &'a SampledCommand<N>) -> Self {
        s.as_command()
    }
}

impl<'a> From<&Command<'a>> for Command<'a> {
    fn from(c: &Command<'a>) -> Self {
        *c
    }
}

/// A command source the functions that run the model take: `&Profile` (so that a call with a
/// borrowed profile reads as without sampled commands), a [`Command`] or `&Command`, a
/// `&SampledCommand<N>` or [`CommandSamples`].
pub trait CommandSource<'a> {
    /// The command.
    fn into_command(self) -> Command<'a>;
}

impl<'a> CommandSource<'a> for &'a Profile {
    fn into_command(self) -> Command<'a> {
        Command::Profile(self)
    }
}

impl<'a> CommandSource<'a> for Command<'a> {
    fn into_command(self) -> Command<'a> {
        self
    }
}

impl<'a> CommandSource<'a> for &Command<'a> {
    fn into_command(self) -> Command<'a> {
        *self
    }
}

impl<'a, const N: usize> CommandSource<'a> for &'a SampledCommand<N> {
    fn into_command(self) -> Command<'a> {
        self.as_command()
    }
}

impl<'a> CommandSource<'a> for CommandSamples<'a> {
    fn into_command(self) -> Command<'a> {
        Command::Sampled(self)
    }
}

/// The command at model step `n` (time `t_s = n·T_c`), read at non-decreasing steps.
pub(crate) trait CommandCursor {
    /// `θ_cmd` at step `step`, time `t_s`.
    fn command_rad(&mut self, step: u32, t_s: f32) -> f32;
}

impl CommandCursor for ProfileCursor<'_> {
    #[cfg_attr(not(target_os = "none"), inline)]
    fn command_rad(&mut self, _step: u32, t_s: f32) -> f32 {
        ProfileCursor::command_rad(self, t_s)
    }
}

/// Reads [`CommandSamples`] at the control rate (module doc: linear interpolation between
/// samples, the last one held).
#[derive(Clone, Debug)]
pub(crate) struct SampledCursor<'a> {
    samples: &'a [f32],
    stride: NonZeroU32,
    inv_stride: f32,
    last: f32,
}

impl<'a> SampledCursor<'a> {
    /// A cursor over `s`.
    pub(crate) fn new(s: &CommandSamples<'a>) -> Self {
        let last = s.samples.last().copied().unwrap_or(0.0);
        Self { samples: s.samples, stride: s.stride, inv_stride: 1.0 / s.stride.get() as f32, last }
    }
}

impl CommandCursor for SampledCursor<'_> {
    #[cfg_attr(not(target_os = "none"), inline)]
    fn command_rad(&mut self, step: u32, _t_s: f32) -> f32 {
        // a non-zero divisor: no division-by-zero path
        let (i, j) = (step / self.stride, step % self.stride);
        match self.samples.get(i as usize..) {
            Some([a, b, ..]) if j != 0 => a + (b - a) * (j as f32 * self.inv_stride),
            Some([a, ..]) => *a,
            _ => self.last,
        }
    }
}

/// The cursor of either command source, chosen at run time: the loops that are not the
/// objective's (the shared window loop, the lockstep runs) are compiled once for both sources,
/// at the price of one predictable branch a step.
#[derive(Clone, Debug)]
pub(crate) enum AnyCommandCursor<'a> {
    /// A profile's.
    Profile(ProfileCursor<'a>),
    /// A sampled command's.
    Sampled(SampledCursor<'a>),
}

impl<'a> AnyCommandCursor<'a> {
    /// The cursor of `command`.
    pub(crate) fn new(command: &'a Command<'a>) -> Self {
        match command {
            Command::Profile(p) => Self::Profile(ProfileCursor::new(p)),
            Command::Sampled(s) => Self::Sampled(SampledCursor::new(s)),
        }
    }
}

impl CommandCursor for AnyCommandCursor<'_> {
    fn command_rad(&mut self, step: u32, t_s: f32) -> f32 {
        match self {
            Self::Profile(p) => CommandCursor::command_rad(p, step, t_s),
            Self::Sampled(s) => s.command_rad(step, t_s),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conditioning::DECIMATION;
    use crate::faults::FaultVector;
    use crate::fitness::simulate_window;

    #[test]
    fn bad_samples_are_refused() {
        let e = 0.6;
        assert_eq!(SampledCommand::<4>::new([], 1, e), Err(CommandError::Empty));
        assert_eq!(SampledCommand::<4>::new([0.0; 5], 1, e), Err(CommandError::TooLong { capacity: 4 }));
        assert_eq!(SampledCommand::<4>::new([0.0], 0, e), Err(CommandError::Stride));
        assert_eq!(SampledCommand::<4>::new([0.0], MAX_STRIDE + 1, e), Err(CommandError::Stride));
        assert_eq!(SampledCommand::<4>::new([0.0, f32::NAN], 1, e), Err(CommandError::NotFinite { index: 1 }));
        assert_eq!(SampledCommand::<4>::new([0.0, 0.1, -0.6], 1, e), Err(CommandError::BeyondEndStops { index: 2 }));
        assert_eq!(SampledCommand::<4>::new([0.0], 1, f32::NAN), Err(CommandError::BeyondEndStops { index: 0 }));
        let mut ok = SampledCommand::<4>::new([0.0, 0.1, -0.5, 0.2], MAX_STRIDE, e).unwrap();
        assert_eq!((ok.samples(), ok.stride()), (&[0.0, 0.1, -0.5, 0.2][..], MAX_STRIDE));
        // a refused load in place leaves no sample: a zero-length manoeuvre
        assert_eq!(ok.load([0.1, 0.7], 1, e), Err(CommandError::BeyondEndStops { index: 1 }));
        assert_eq!((ok.samples(), ok.as_command().frames(&EmaParams::NOMINAL)), (&[][..], 0));
    }

    #[test]
    fn a_cursor_interpolates_and_holds_the_last_sample() {
        let c = SampledCommand::<3>::new([0.0, 0.4, -0.2], 4, 0.6).unwrap();
        let Command::Sampled(s) = c.as_command() else { unreachable!() };
        let mut cursor = SampledCursor::new(&s);
        let read: [f32; 14] = core::array::from_fn(|n| cursor.command_rad(n as u32, 0.0));
        let expected = [0.0, 0.1, 0.2, 0.3, 0.4, 0.25, 0.1, -0.05, -0.2, -0.2, -0.2, -0.2, -0.2, -0.2];
        for (n, (r, e)) in read.iter().zip(expected).enumerate() {
            assert!((r - e).abs() < 1e-7, "step {n}: {r} vs {e}");
        }
        assert_eq!(c.as_command().frames(&EmaParams::NOMINAL), 12);
    }

    #[test]
    fn the_standard_profile_has_the_same_frames_sampled() {
        let p = EmaParams::NOMINAL;
        let at_control_rate = SampledCommand::<8500>::sampled(&Profile::STANDARD, 1, &p).unwrap();
        assert_eq!(at_control_rate.samples().len(), 8500);
        assert_eq!(Command::from(&Profile::STANDARD).frames(&p), 8500);
        assert_eq!(at_control_rate.as_command().frames(&p), 8500);
        assert!((at_control_rate.as_command().duration_s(&p) - 0.85).abs() < 1e-6);
        let at_fitness_rate = SampledCommand::<2125>::sampled(&Profile::STANDARD, 4, &p).unwrap();
        assert_eq!(at_fitness_rate.as_command().frames(&p), 8500);
        assert_eq!(
            SampledCommand::<8499>::sampled(&Profile::STANDARD, 1, &p),
            Err(CommandError::TooLong { capacity: 8499 })
        );
    }

    /// The model's window (block means of the expected measured envelope) under `command`.
    fn window(command: Command<'_>, k: &FaultVector) -> [f32; 2125] {
        let mut out = [0.0; 2125];
        simulate_window(&EmaParams::NOMINAL, command, k, out.len(), |i, v, _| {
            out[i] = v;
            true
        });
        out
    }

    /// The standard profile sampled at the control rate drives the model bit for bit as the
    /// profile does. At the fitness rate (stride 4, interpolated) each of its two steps becomes a
    /// 0.4 ms ramp, which shifts the current-limited transient that follows: up to 6.2 A in a
    /// block mean there and 0.18 A RMS over the window (bounds 7 A and 0.2 A), so a command with
    /// steps is sampled at stride 1.
    #[test]
    fn the_standard_profile_sampled_drives_the_model_as_the_profile() {
        let p = EmaParams::NOMINAL;
        let exact = SampledCommand::<8500>::sampled(&Profile::STANDARD, 1, &p).unwrap();
        let decimated = SampledCommand::<2125>::sampled(&Profile::STANDARD, DECIMATION as u32, &p).unwrap();
        for k in [
            FaultVector::HEALTHY,
            FaultVector([0.3, 0.2, 0.0, 0.2, 0.0, 0.0, 0.5, 0.35]),
            FaultVector([0.0, 0.0, 0.4, 0.0, 0.3, 0.2, 0.1, 0.6]),
        ] {
            let by_profile = window(Command::from(&Profile::STANDARD), &k);
            let by_samples = window(exact.as_command(), &k);
            assert!(by_profile.iter().zip(&by_samples).all(|(a, b)| a.to_bits() == b.to_bits()), "{k:?}");
            let by_decimated = window(decimated.as_command(), &k);
            let (mut worst, mut sq) = (0.0f32, 0.0f32);
            for (a, b) in by_profile.iter().zip(&by_decimated) {
                worst = worst.max((a - b).abs());
                sq += (a - b) * (a - b);
            }
            let rms = libm::sqrtf(sq / by_profile.len() as f32);
            assert!(worst < 7.0 && rms < 0.2, "{k:?}: worst {worst} A, RMS {rms} A");
        }
    }
}
