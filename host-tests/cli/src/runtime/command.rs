//! What drives the monitor model: a command profile, or the recording's own command column
//! sampled at the control rate into the core's [`SampledCommand`] (`--command` and `--profile`
//! of `ema identify`, `ema discover` and `ema history`).

use std::path::Path;

use clap::ValueEnum;
use ema_monitor::command::CommandError;
use ema_monitor::conditioning::DECIMATION;
use ema_monitor::{Command, EmaParams, Profile, SampledCommand};
use serde::Serialize;

use super::source::HOST_WINDOW;
use crate::error::{num, CliError};
use crate::recording::Recording;
use crate::simulate::resolve_profile;

/// Most rows `--command recorded` takes: the command buffer holds the host window's length at the
/// control rate, [`HOST_WINDOW`] × [`DECIMATION`] = 32 768 samples (3.2768 s at 10 kHz, 128 KiB).
pub const HOST_COMMAND_SAMPLES: usize = HOST_WINDOW * DECIMATION;

/// What drives the monitor model (`--command` of `ema identify` and `ema discover`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum CommandArg {
    /// The command profile given by `--profile`; the recording's command column must match it.
    Profile,
    /// The recording's own command column, whatever the manoeuvre (no profile needed).
    Recorded,
}

/// The command that drives the monitor model, as `--command` and `--profile` chose it.
#[derive(Clone, Debug, PartialEq)]
#[allow(clippy::large_enum_variant, reason = "one per command run; the sampled command is boxed already")]
pub enum ModelCommand {
    /// A command profile, with the name it was given by (`standard` or a file).
    Profile {
        /// The profile.
        profile: Profile,
        /// `standard` or the profile file's path.
        name: String,
    },
    /// The recording's command column, sampled at the control rate (stride 1).
    Recorded(Box<SampledCommand<HOST_COMMAND_SAMPLES>>),
}

impl ModelCommand {
    /// The core's command source.
    pub fn command(&self) -> Command<'_> {
        match self {
            ModelCommand::Profile { profile, .. } => Command::Profile(profile),
            ModelCommand::Recorded(samples) => samples.as_command(),
        }
    }

    /// `profile standard`, `profile FILE` or `recorded (8500 samples at 10000 Hz, 0.85 s)`.
    pub fn label(&self) -> String {
        self.to_json().label()
    }

    /// The profile, when a profile drives the model.
    pub fn profile(&self) -> Option<&Profile> {
        match self {
            ModelCommand::Profile { profile, .. } => Some(profile),
            ModelCommand::Recorded(_) => None,
        }
    }

    /// The JSON report's `command`: `{"source": "profile", "profile": NAME}` or
    /// `{"source": "recorded", "samples": N, "duration_s": T}`.
    pub fn to_json(&self) -> CommandJson {
        match self {
            ModelCommand::Profile { name, .. } => {
                CommandJson { source: "profile", profile: Some(name.clone()), samples: None, duration_s: None }
            }
            ModelCommand::Recorded(s) => CommandJson {
                source: "recorded",
                profile: None,
                samples: Some(s.samples().len()),
                duration_s: Some(s.samples().len() as f64 / control_rate_hz()),
            },
        }
    }
}

/// What drove the monitor model, in the JSON reports of `ema identify` and `ema discover`.
#[derive(Clone, Debug, Serialize)]
pub struct CommandJson {
    /// `profile` or `recorded`.
    pub source: &'static str,
    /// The profile's name (`standard` or its file), under `profile`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub profile: Option<String>,
    /// Samples of the recorded command, under `recorded`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// Length of the recorded command (s), under `recorded`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub duration_s: Option<f64>,
}

impl CommandJson {
    /// `profile NAME`, or `recorded (N samples at R Hz, T s)`.
    pub fn label(&self) -> String {
        match (&self.profile, self.samples, self.duration_s) {
            (Some(name), _, _) => format!("profile {name}"),
            (None, Some(n), Some(t)) => format!("recorded ({n} samples at {} Hz, {t} s)", control_rate_hz()),
            _ => self.source.to_owned(),
        }
    }
}

/// The nominal control rate in Hz, rounded to an integer (10 000).
fn control_rate_hz() -> f64 {
    (1.0 / f64::from(EmaParams::NOMINAL.control_period_s)).round()
}

/// The command `--command` names for `recording` (read from `path`, named in errors): the profile
/// `profile` (`standard` or a file), or the recording's command column ([`resolve_command`], then
/// [`command_for`]).
pub fn model_command(
    arg: CommandArg,
    profile: &str,
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
) -> Result<ModelCommand, CliError> {
    command_for(resolve_command(arg, profile)?, recording, path, params)
}

/// The flags' part of [`model_command`], checked before the recording is read: the profile
/// `profile` resolved (`Some`) under `--command profile`, `None` under `--command recorded`, which
/// refuses a `--profile` other than `standard` (the recorded command replaces the profile).
pub fn resolve_command(arg: CommandArg, profile: &str) -> Result<Option<ModelCommand>, CliError> {
    match arg {
        CommandArg::Profile => {
            Ok(Some(ModelCommand::Profile { profile: resolve_profile(profile)?, name: profile.to_owned() }))
        }
        CommandArg::Recorded if profile != "standard" => Err(CliError::flag(
            "--profile",
            "--command recorded drives the model by the recording's command column; drop --profile",
        )),
        CommandArg::Recorded => Ok(None),
    }
}

/// The resolved command ([`resolve_command`]), or for `None` the recording's command column
/// ([`recorded_command`]).
pub fn command_for(
    resolved: Option<ModelCommand>,
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
) -> Result<ModelCommand, CliError> {
    match resolved {
        Some(command) => Ok(command),
        None => recorded_command(recording, path, params).map(ModelCommand::Recorded),
    }
}

/// The recording's command column as the core's sampled command at the control rate: at most
/// [`HOST_COMMAND_SAMPLES`] rows, every value inside the end stops of `params`; errors name the
/// file, the line and the limit.
pub fn recorded_command(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
) -> Result<Box<SampledCommand<HOST_COMMAND_SAMPLES>>, CliError> {
    if recording.len() > HOST_COMMAND_SAMPLES {
        let rate_hz = (1.0 / f64::from(params.control_period_s)).round();
        return Err(CliError::input(
            path,
            format!(
                "{} rows ({} s); --command recorded holds at most {HOST_COMMAND_SAMPLES} rows ({} s at {rate_hz} Hz): \
                 trim the recording",
                recording.len(),
                recording.len() as f64 / rate_hz,
                HOST_COMMAND_SAMPLES as f64 / rate_hz,
            ),
        ));
    }
    let samples = recording.command_rad.iter().map(|&c| c as f32);
    SampledCommand::new(samples, 1, params.end_stop_rad).map(Box::new).map_err(|e| match e {
        CommandError::NotFinite { index } | CommandError::BeyondEndStops { index } => CliError::input_line(
            path,
            recording.line_of(index),
            Some("command_rad"),
            format!(
                "{} rad; the command must be finite and inside the end stops (±{} rad)",
                num(recording.command_rad.get(index).copied().unwrap_or(f64::NAN)),
                num(params.end_stop_rad)
            ),
        ),
        e => CliError::input(path, e.to_string()),
    })
}
