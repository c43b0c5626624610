//! A recording as the core's phase-current source, read by the core's own acquisition.
//!
//! [`RecordingSource`] hands the recording's rows to [`diagnosis::acquire`] one frame at a time as
//! [`PhaseCurrents`] does on board, and reports [`AcquisitionError::EndOfData`] after the last
//! row. With [`FrameChecks::OnBoard`] every frame first passes the core's frame checks
//! ([`FrameCheck::amps`]: range, stuck channel and sum, nominal calibration, default settings),
//! so a refused frame is held at the last good one and counted exactly as the firmware holds and
//! counts it; a recording's rows before its manoeuvre ([`Recording::rest_currents_a`]) are its
//! rest frames, on which its sensors' zero points are measured first, as a board measures them on
//! the frames before its trigger, when there are enough of them
//! (`AcquisitionConfig::for_recorded_rest`). With [`FrameChecks::None`] every frame is taken as it
//! is. [`acquire_recording`] runs the acquisition ([`acquire_recording_by`]: the flight API's) and
//! names the row of a refused window in its error.

use std::path::Path;

use ema_monitor::acquisition::{
    AcquisitionConfig, AcquisitionError, Calibration, FrameCheck, PhaseCurrents, PhaseFrame, SensorCheck,
};
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::{self, AcquisitionSummary, MonitorError};

use crate::error::CliError;
use crate::recording::Recording;

/// Window capacity for host identifications from CSV: 3.2 s of recording at the 2.5 kHz fitness rate.
pub const HOST_WINDOW: usize = 8192;

/// Whether a recording's frames pass the core's frame checks on their way to the trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameChecks {
    /// The on-board checks ([`FrameCheck::amps`], nominal calibration, default settings): what
    /// `ema identify` and `ema history` read through.
    OnBoard,
    /// None: every frame as it is, for the studies of the model on recordings whose sensor
    /// effects the checks would refuse (a sensor offset breaks the sum rule).
    None,
}

/// The rows of a recording as the core's [`PhaseCurrents`] source, in order, then
/// [`AcquisitionError::EndOfData`].
pub struct RecordingSource<'r> {
    recording: &'r Recording,
    check: Option<FrameCheck>,
    next: usize,
    ended: bool,
}

impl<'r> RecordingSource<'r> {
    /// The source of `recording`'s rows under `checks`; the on-board checks' settings are the
    /// core's defaults, which it accepts (an error here is the core refusing its own defaults).
    pub fn new(recording: &'r Recording, checks: FrameChecks) -> Result<Self, ema_monitor::acquisition::ConfigError> {
        let check = match checks {
            FrameChecks::OnBoard => {
                let config = AcquisitionConfig::for_recorded_rest(recording.rest_currents_a.len());
                let mut check = FrameCheck::new(Calibration::NOMINAL, config)?;
                for row in &recording.rest_currents_a {
                    check.rest_amps(row.map(|i| i as f32));
                }
                check.start_recording();
                Some(check)
            }
            FrameChecks::None => None,
        };
        Ok(Self { recording, check, next: 0, ended: false })
    }

    /// Rows handed out so far (the index of the next row).
    pub fn rows_read(&self) -> usize {
        self.next
    }

    /// `true` once the source has reported [`AcquisitionError::EndOfData`].
    pub fn has_ended(&self) -> bool {
        self.ended
    }
}

impl PhaseCurrents for RecordingSource<'_> {
    fn read_frame(&mut self) -> Result<PhaseFrame, AcquisitionError> {
        let r = self.recording;
        let k = self.next;
        if k >= r.len() {
            self.ended = true;
            return Err(AcquisitionError::EndOfData);
        }
        self.next += 1;
        let currents_a = [r.ia_a[k] as f32, r.ib_a[k] as f32, r.ic_a[k] as f32];
        match &mut self.check {
            Some(check) => check.amps(currents_a),
            // no ADC stands behind a recording's currents: the codes are not read downstream
            None => Ok(PhaseFrame { ia_a: currents_a[0], ib_a: currents_a[1], ic_a: currents_a[2], codes: [0; 3] }),
        }
    }

    fn sensor_check(&self) -> SensorCheck {
        self.check.as_ref().map_or(SensorCheck::DECLARED, FrameCheck::sensor_check)
    }
}

/// Every row of `recording` (read from `path`, named in errors) through [`diagnosis::acquire`]
/// into a new conditioned window of `W` window samples, under `checks`. A frame the window refuses
/// names its file line; a window refused when it closes (too short, no excitation) names the file.
pub fn acquire_recording<const W: usize>(
    recording: &Recording,
    path: &Path,
    checks: FrameChecks,
) -> Result<(Box<ConditionedWindow<W>>, AcquisitionSummary), CliError> {
    acquire_recording_by(recording, path, checks, |source, trace| diagnosis::acquire(source, trace))
}

/// [`acquire_recording`] by `acquire`, which reads every frame of the source into the window as
/// [`diagnosis::acquire`] does (the flight API's
/// [`HealthMonitor::acquire`](ema_monitor::flight::HealthMonitor::acquire)), and gives what it
/// returns beside the window.
pub fn acquire_recording_by<const W: usize, T>(
    recording: &Recording,
    path: &Path,
    checks: FrameChecks,
    acquire: impl FnOnce(&mut RecordingSource<'_>, &mut ConditionedWindow<W>) -> Result<T, MonitorError>,
) -> Result<(Box<ConditionedWindow<W>>, T), CliError> {
    let mut source = RecordingSource::new(recording, checks).map_err(|e| CliError::input(path, e.to_string()))?;
    let mut trace = Box::new(ConditionedWindow::<W>::new());
    match acquire(&mut source, &mut trace) {
        Ok(acquired) => Ok((trace, acquired)),
        // before the end of the data the window refused the last frame read; after it, it
        // refused to close
        Err(MonitorError::Conditioning(e)) if !source.has_ended() => Err(CliError::input_line(
            path,
            recording.line_of(source.rows_read().saturating_sub(1)),
            None,
            e.to_string(),
        )),
        Err(MonitorError::Conditioning(e)) => Err(CliError::input(path, e.to_string())),
        Err(e) => Err(CliError::input(path, e.to_string())),
    }
}
