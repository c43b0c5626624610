//! A recording into the conditioned window the core identifies: the checks it passes before it
//! drives the monitor model (sample rate, and the command column against the profile), then its
//! acquisition through the core ([`super::source`]) into a window of [`HOST_WINDOW`] samples.
//!
//! Two acquisitions: [`condition_recording_checked`] reads every frame through the on-board frame
//! checks, as the firmware does (`ema identify`, `ema history`); [`condition_recording`] takes
//! every frame as it is (`ema discover`, `ema campaign` and the investigations, which study the
//! model on recordings whose sensor effects the checks would refuse).

use std::path::Path;

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::AcquisitionSummary;
use ema_monitor::{EmaParams, Profile};

use super::command::ModelCommand;
use super::source::{acquire_recording, FrameChecks, HOST_WINDOW};
use crate::error::{num, CliError};
use crate::recording::Recording;

/// Largest difference between the recorded command and the profile before the file is refused.
pub const COMMAND_TOLERANCE_RAD: f64 = 1e-6;

/// Refuses a recording the monitor cannot use: wrong sample rate, or a command that is not `profile`.
pub fn check_recording(r: &Recording, path: &Path, profile: &Profile, params: &EmaParams) -> Result<(), CliError> {
    check_rate(r, path, params)?;
    for k in 0..r.len() {
        let expected = f64::from(profile.command_rad(k as f32 * params.control_period_s));
        if (r.command_rad[k] - expected).abs() > COMMAND_TOLERANCE_RAD {
            return Err(CliError::input_line(
                path,
                r.line_of(k),
                Some("command_rad"),
                format!(
                    "{} but the profile commands {}; pass the profile the recording was made with (--profile)",
                    num(r.command_rad[k]),
                    num(expected)
                ),
            ));
        }
    }
    Ok(())
}

/// Refuses a recording whose sample period is not the control period of `params`.
pub fn check_rate(r: &Recording, path: &Path, params: &EmaParams) -> Result<(), CliError> {
    let period = f64::from(params.control_period_s);
    let measured = r.sample_period_s();
    if (measured - period).abs() > 1e-3 * period {
        return Err(CliError::input_line(
            path,
            0,
            Some("time_s"),
            format!("sample period {} s, the monitor needs {} s (10 kHz)", num(measured), num(period)),
        ));
    }
    Ok(())
}

/// The check a recording passes before it drives `command`: the profile's ([`check_recording`]:
/// rate and command), or for its own command the rate only.
pub fn check_for(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
    command: &ModelCommand,
) -> Result<(), CliError> {
    match command {
        ModelCommand::Profile { profile, .. } => check_recording(recording, path, profile, params),
        ModelCommand::Recorded(_) => check_rate(recording, path, params),
    }
}

/// Checks a recording made under `profile` (read from `path`, used for messages) and conditions it into the
/// conditioned window the core identifies (`I_3eq` block means and weights), every frame as it is:
/// the input of `ema discover`, `ema campaign` and the investigations, which study the model on
/// recordings whose sensor effects the frame checks would refuse (a sensor offset breaks the sum
/// rule). `ema identify` conditions through [`condition_recording_checked`].
pub fn condition_recording(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
    profile: &Profile,
) -> Result<Box<ConditionedWindow<HOST_WINDOW>>, CliError> {
    check_recording(recording, path, profile, params)?;
    Ok(acquire_recording(recording, path, FrameChecks::None)?.0)
}

/// [`condition_recording`] for the model driven by `command` (`ema discover --command`).
pub fn condition_recording_for(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
    command: &ModelCommand,
) -> Result<Box<ConditionedWindow<HOST_WINDOW>>, CliError> {
    check_for(recording, path, params, command)?;
    Ok(acquire_recording(recording, path, FrameChecks::None)?.0)
}

/// As [`condition_recording`], as on board: every frame passes the core's frame checks
/// ([`ema_monitor::acquisition::FrameCheck::amps`], nominal calibration, default settings) on its
/// way through the core's acquisition ([`ema_monitor::diagnosis::acquire`]), which holds a refused
/// frame at the last good one (zero currents before the first) and counts it in the returned
/// summary.
pub fn condition_recording_checked(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
    profile: &Profile,
) -> Result<(Box<ConditionedWindow<HOST_WINDOW>>, AcquisitionSummary), CliError> {
    check_recording(recording, path, profile, params)?;
    acquire_recording(recording, path, FrameChecks::OnBoard)
}

/// [`condition_recording_checked`] for the model driven by `command` (`ema identify --command`).
pub fn condition_recording_checked_for(
    recording: &Recording,
    path: &Path,
    params: &EmaParams,
    command: &ModelCommand,
) -> Result<(Box<ConditionedWindow<HOST_WINDOW>>, AcquisitionSummary), CliError> {
    check_for(recording, path, params, command)?;
    acquire_recording(recording, path, FrameChecks::OnBoard)
}
