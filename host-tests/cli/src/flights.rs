//! Series of flights of one actuator, for the evidence pooled over flights: each flight is a
//! reference-model recording of the standard manoeuvre with sensor noise (its own noise seed),
//! identified on board's way ([`IdentifyConfig::onboard`]), then added to the sequential test of
//! [`ema_monitor::diagnosis::evidence`]; the same recordings feed the pooled fit
//! ([`crate::runtime::identification::identify_pooled`]). The measurement of flights-to-detection
//! (`examples/flights-to-detection.rs`) and its tests run on these.

use std::path::PathBuf;

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::evidence::{mode_present, Decision, Evidence, FlightEvidence};
use ema_monitor::diagnosis::{Identification, IdentifyConfig, ONBOARD_POPULATION};
use ema_monitor::faults::{FaultMode, MODE_COUNT};
use ema_monitor::health::HealthReport;
use ema_monitor::optimizer::rng::{splitmix64_mix, SPLITMIX_GAMMA};
use ema_monitor::{Command, EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};

use crate::error::CliError;
use crate::recording::Recording;
use crate::runtime::recording::condition_recording;
use crate::runtime::source::HOST_WINDOW;

/// The noise seed of flight `flight` of series `series` (SplitMix64's finaliser of both,
/// [`splitmix64_mix`]).
pub fn flight_seed(series: u64, flight: usize) -> u64 {
    splitmix64_mix(series.wrapping_mul(SPLITMIX_GAMMA) ^ (flight as u64).wrapping_add(0xD1B5_4A32_D192_ED03))
}

/// One flight's recording of the actuator with faults `truth` (standard manoeuvre, sensor noise
/// from `seed`), conditioned.
pub fn flight_trace(truth: &FaultVector, seed: u64) -> Result<Box<ConditionedWindow<HOST_WINDOW>>, CliError> {
    let config = SimConfig { faults: *truth, seed, ..SimConfig::default() };
    let rec = simulate(&config).map_err(|e| CliError::Simulation(e.to_string()))?;
    let recording = Recording::from_reference(&rec, Vec::new());
    let label = PathBuf::from(format!("flight (seed {seed})"));
    condition_recording(&recording, &label, &EmaParams::NOMINAL, &Profile::STANDARD)
}

/// One flight of a series: its diagnosis and the sequential test after it.
#[derive(Clone, Debug)]
pub struct FlightRecord {
    /// The flight's own health report.
    pub report: HealthReport,
    /// The flight's evidence (`None`: no diagnosis, nothing added).
    pub evidence: Option<FlightEvidence>,
    /// The accumulators after the flight.
    pub accumulated: Evidence,
    /// The sequential test's decision per mode after the flight.
    pub decisions: [Decision; MODE_COUNT],
    /// Which modes the flight's own diagnosis holds.
    pub single: [bool; MODE_COUNT],
}

/// Identifies `trace` with the on-board settings (optimizer seed `seed`) and adds it to `evidence`.
pub fn fly(
    trace: &ConditionedWindow<HOST_WINDOW>,
    seed: u64,
    evidence: &mut Evidence,
) -> Result<FlightRecord, CliError> {
    let config = IdentifyConfig { seed, ..IdentifyConfig::onboard() };
    let mut id: Box<Identification<'_, HOST_WINDOW, ONBOARD_POPULATION>> = Box::new(
        Identification::new(trace, EmaParams::NOMINAL, &Profile::STANDARD, &config)
            .map_err(|e| CliError::Simulation(e.to_string()))?,
    );
    id.run(u32::MAX);
    let report = id.report();
    let flight = evidence.observe(&id);
    let n = flight.map_or(f32::NAN, |f| f.effective_samples);
    let decisions = if n.is_finite() { evidence.decisions(n) } else { [Decision::Undecided; MODE_COUNT] };
    let single = FaultMode::ALL.map(|m| report.status.is_diagnosis() && mode_present(&report.faults, m));
    Ok(FlightRecord { report, evidence: flight, accumulated: *evidence, decisions, single })
}

/// The pooled diagnosis of `traces` (the on-board settings, optimizer seed `seed`).
pub fn pooled(traces: &[&ConditionedWindow<HOST_WINDOW>], seed: u64) -> Result<HealthReport, CliError> {
    let config = IdentifyConfig { seed, ..IdentifyConfig::onboard() };
    let commands = vec![Command::Profile(&Profile::STANDARD); traces.len()];
    crate::runtime::identification::identify_pooled(traces, &commands, &EmaParams::NOMINAL, &config)
        .map(|o| o.report)
        .map_err(|e| CliError::Simulation(e.to_string()))
}
