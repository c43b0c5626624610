//! The core's flight API ([`HealthMonitor`]) on the host: a recording acquired through the
//! on-board frame checks ([`super::source::RecordingSource`] as the flight's phase-current
//! source), and the identification stepped by [`HostHooks`], which evaluates each sweep of the
//! global search in parallel ([`ParallelSweeps`]: bit for bit the firmware's one-evaluation
//! steps) and times it. The flight policy itself (plan from the health record, identify, report with its
//! uncertainty, record with the evidence pooled over flights) is the core's, as on board.

use std::path::Path;
use std::time::Instant;

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::{Identification, Start, StepDriver};
use ema_monitor::flight::{Acquired, FlightHooks, HealthMonitor};

use super::command::ModelCommand;
use super::identification::ParallelSweeps;
use super::recording::check_for;
use super::source::{acquire_recording_by, FrameChecks};
use super::temperature::ModelParams;
use crate::error::CliError;
use crate::recording::Recording;

/// The host's hooks around a flight's identification: the global search's sweeps evaluated in
/// parallel on the current rayon pool ([`ParallelSweeps`]), and the identification's wall time.
#[derive(Debug, Default)]
pub struct HostHooks {
    sweeps: ParallelSweeps,
    started: Option<Instant>,
    seconds: f64,
}

impl HostHooks {
    /// Wall time of the last identification (s): from its first step to its report, without its
    /// uncertainty and the record.
    pub fn seconds(&self) -> f64 {
        self.seconds
    }
}

impl FlightHooks for HostHooks {
    fn identification_start(&mut self, _flight: u32, _start: Start) {
        self.started = Some(Instant::now());
    }

    fn global_cost<const W: usize, const P: usize>(&mut self, id: &Identification<'_, W, P>) -> Option<f32> {
        self.sweeps.global_cost(id)
    }

    fn identification_end(&mut self) {
        self.seconds = self.started.take().map_or(0.0, |t| t.elapsed().as_secs_f64());
    }
}

/// A flight's recording (read from `path`, named in errors) acquired by `monitor` as on board:
/// checked against `command` first (rate, and the profile's command), then every row through the
/// on-board frame checks into a new window ([`HealthMonitor::acquire`]), the flight at the
/// recording's temperature when `model` has one. The rate is the control rate: the check has
/// refused a recording sampled at another.
pub fn acquire_flight<const W: usize, const P: usize>(
    monitor: &HealthMonitor<'_, W, P>,
    recording: &Recording,
    path: &Path,
    model: &ModelParams,
    command: &ModelCommand,
) -> Result<(Box<ConditionedWindow<W>>, Acquired), CliError> {
    check_for(recording, path, &model.params, command)?;
    let rate_hz = 1.0 / monitor.params().control_period_s;
    let (trace, acquired) = acquire_recording_by(recording, path, FrameChecks::OnBoard, |source, trace| {
        monitor.acquire(source, trace, rate_hz)
    })?;
    let temperature_c = model.temperature_c.map_or(f32::NAN, |t| t as f32);
    Ok((trace, Acquired { temperature_c, ..acquired }))
}
