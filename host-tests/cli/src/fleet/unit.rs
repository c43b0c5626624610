//! One unit of the fleet: drawn, commissioned on three healthy flights, then flown healthy and
//! faulty, each flight a reference-model recording identified as `ema identify` identifies it.

use std::path::Path;

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::IdentifyConfig;
use ema_monitor::faults::FaultMode;
use ema_monitor::health::Status;
use ema_monitor::unit::{Tolerances, MAX_RELATIVE_SIGMA};
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};

use crate::commission::{commission_recordings, CommissioningRecording};
use crate::error::CliError;
use crate::recording::Recording;
use crate::runtime::command::ModelCommand;
use crate::runtime::identification::{identify_unit_recording, Outcome};
use crate::runtime::recording::condition_recording_checked_for;
use crate::runtime::source::HOST_WINDOW;
use crate::unit_draw::draw_unit;

/// Severity of the faulty flights.
pub const SEVERITY: f32 = 0.3;
/// Temperatures of the commissioning flights (°C).
pub const COMMISSIONING_C: [f32; 3] = [5.0, 20.0, 35.0];
/// Temperature of the fourth healthy flight (°C).
pub const FOURTH_C: f32 = 20.0;
/// Temperature of the cold healthy flight (°C).
pub const COLD_C: f32 = -40.0;
/// Temperature of the hot healthy flight (°C).
pub const HOT_C: f32 = 70.0;
/// Temperatures the faulty flights take in turn (°C).
pub const FAULTY_C: [f32; 3] = [-40.0, 20.0, 70.0];

/// One faulty flight of a commissioned unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultyFlight {
    /// The fault mode present, at [`SEVERITY`].
    pub mode: FaultMode,
    /// The flight's temperature (°C).
    pub temperature_c: f32,
    /// The report's status.
    pub status: Status,
    /// The paper's Err% of the identified vector against the true one.
    pub err_percent: f32,
}

/// What one unit gave.
#[derive(Clone, Debug, PartialEq)]
pub struct UnitResult {
    /// The unit's seed (`--seed` plus its index).
    pub seed: u64,
    /// Commissioning: done, or refused with the reason `ema commission` gives.
    pub commissioned: Result<(), String>,
    /// The fourth flight against the drawing's parameters.
    pub fourth_nominal: Status,
    /// The fourth flight against the commissioned parameters (`None`: not commissioned).
    pub fourth_commissioned: Option<Status>,
    /// The healthy flight at [`COLD_C`] (`None`: not commissioned).
    pub cold: Option<Status>,
    /// The healthy flight at [`HOT_C`] (`None`: not commissioned).
    pub hot: Option<Status>,
    /// One flight per fault mode, in [`FaultMode::ALL`] order (empty: not commissioned).
    pub faulty: Vec<FaultyFlight>,
    /// Minimum detectable severity per mode of the fourth flight against the commissioned
    /// parameters.
    pub detectable: [Option<f32>; 5],
}

/// The path that names every simulated flight in messages.
fn flight_path() -> &'static Path {
    Path::new("fleet.csv")
}

/// What drives the monitor model: the standard manoeuvre.
fn standard() -> ModelCommand {
    ModelCommand::Profile { profile: Profile::STANDARD, name: "standard".to_owned() }
}

/// The seed of flight `k` of the unit `seed` (its sensor noise): `16·seed + k`, modulo 2⁶⁴.
fn flight_seed(seed: u64, k: u64) -> u64 {
    seed.wrapping_mul(16).wrapping_add(k)
}

/// The reference model's recording of `params` (at 20 °C) with `faults` at `temperature_c`, on
/// the standard manoeuvre with sensor noise seeded by `seed`.
pub fn record(params: &EmaParams, faults: &FaultVector, temperature_c: f32, seed: u64) -> Result<Recording, CliError> {
    let cfg = SimConfig {
        params: params.at_temperature(temperature_c),
        faults: *faults,
        profile: Profile::STANDARD,
        noise: true,
        seed,
        ..SimConfig::default()
    };
    let result = simulate(&cfg).map_err(|e| CliError::Simulation(e.to_string()))?;
    Ok(Recording::from_reference(&result, Vec::new()))
}

/// `rec` identified as `ema identify` identifies a recording, against `params` (at the flight's
/// temperature), the unit check within `tolerances`.
pub fn diagnose(rec: &Recording, params: &EmaParams, tolerances: &Tolerances) -> Result<Outcome, CliError> {
    identify_unit_recording(rec, flight_path(), params, &standard(), &IdentifyConfig::default(), tolerances, false)
        .map(|(outcome, _)| outcome)
}

/// The fault vector of `mode` at [`SEVERITY`] on the unit `seed`: a short on phase A, B or C by
/// the seed, an eccentricity at phase 0.3, the gain at `0.5 + SEVERITY`.
fn fault(mode: FaultMode, seed: u64) -> FaultVector {
    let mut k = FaultVector::HEALTHY;
    match mode {
        FaultMode::Friction => k.0[0] = SEVERITY,
        FaultMode::Backlash => k.0[1] = SEVERITY,
        FaultMode::ShortCircuit => k.0[2 + (seed % 3) as usize] = SEVERITY,
        FaultMode::Eccentricity => (k.0[5], k.0[6]) = (SEVERITY, 0.3),
        FaultMode::GainDrift => k.0[7] = 0.5 + SEVERITY,
    }
    k
}

/// Flies the unit `seed` (module doc of [`crate::fleet`]). A refused commissioning is a result,
/// not an error; a flight that cannot be simulated or identified is an error.
pub fn fly_unit(seed: u64) -> Result<UnitResult, CliError> {
    let unit = draw_unit(&EmaParams::NOMINAL, &Tolerances::TYPICAL, seed)
        .map_err(|e| CliError::flag("--seed", format!("unit {seed}: {e}")))?;
    let command = standard();
    let path = flight_path();
    let mut traces: Vec<Box<ConditionedWindow<HOST_WINDOW>>> = Vec::new();
    for (r, &t) in COMMISSIONING_C.iter().enumerate() {
        let rec = record(&unit.params, &FaultVector::HEALTHY, t, flight_seed(seed, r as u64))?;
        let (trace, _) = condition_recording_checked_for(&rec, path, &EmaParams::NOMINAL, &command)?;
        traces.push(trace);
    }
    let recordings: Vec<CommissioningRecording<'_>> = traces
        .iter()
        .zip(COMMISSIONING_C)
        .map(|(trace, t)| CommissioningRecording {
            trace: trace.as_ref(),
            command: command.command(),
            temperature_c: t,
            path,
        })
        .collect();
    let config = IdentifyConfig::default();
    let baseline = commission_recordings(&recordings, &EmaParams::NOMINAL, &Tolerances::TYPICAL, &config);
    let fourth = record(&unit.params, &FaultVector::HEALTHY, FOURTH_C, flight_seed(seed, 3))?;
    let fourth_nominal = diagnose(&fourth, &EmaParams::NOMINAL, &Tolerances::TYPICAL)?.report.status;
    let baseline = match baseline {
        Ok(baseline) => baseline,
        Err(e) => {
            return Ok(UnitResult {
                seed,
                commissioned: Err(e.to_string()),
                fourth_nominal,
                fourth_commissioned: None,
                cold: None,
                hot: None,
                faulty: Vec::new(),
                detectable: [None; 5],
            })
        }
    };
    let posterior = Tolerances {
        relative_sigma: core::array::from_fn(|i| {
            (Tolerances::TYPICAL.relative_sigma[i] * baseline.sigma_z[i]).min(MAX_RELATIVE_SIGMA)
        }),
    };
    let own = baseline.params;
    let fourth_out = diagnose(&fourth, &own, &posterior)?;
    let healthy_at = |t: f32, k: u64| -> Result<Status, CliError> {
        let rec = record(&unit.params, &FaultVector::HEALTHY, t, flight_seed(seed, k))?;
        Ok(diagnose(&rec, &own.at_temperature(t), &posterior)?.report.status)
    };
    let cold = healthy_at(COLD_C, 4)?;
    let hot = healthy_at(HOT_C, 5)?;
    let mut faulty = Vec::new();
    for (m, &mode) in FaultMode::ALL.iter().enumerate() {
        let k = fault(mode, seed);
        let t = FAULTY_C[(m + (seed % FAULTY_C.len() as u64) as usize) % FAULTY_C.len()];
        let rec = record(&unit.params, &k, t, flight_seed(seed, 6 + m as u64))?;
        let report = diagnose(&rec, &own.at_temperature(t), &posterior)?.report;
        faulty.push(FaultyFlight {
            mode,
            temperature_c: t,
            status: report.status,
            err_percent: report.faults.paper_error_percent(&k),
        });
    }
    Ok(UnitResult {
        seed,
        commissioned: Ok(()),
        fourth_nominal,
        fourth_commissioned: Some(fourth_out.report.status),
        cold: Some(cold),
        hot: Some(hot),
        faulty,
        detectable: fourth_out.report.uncertainty.map_or([None; 5], |u| u.detectable_below),
    })
}
