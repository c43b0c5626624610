//! The fleet campaign behind `docs/results/fleet.md`: units drawn from the tolerance table, each
//! commissioned on its own healthy recordings, then flown healthy and faulty at several
//! temperatures, each flight identified as `ema identify` does (with the unit check).
//!
//! Per unit (seed `SEED + u`, drawn from `Tolerances::TYPICAL` as `ema simulate --unit` draws):
//! - three healthy commissioning flights of the standard manoeuvre at 5, 20 and 35 °C (their
//!   temperature known, as a temperature column gives it), commissioned as `ema commission` does;
//! - a fourth healthy flight at 20 °C, identified against the drawing's parameters (typical
//!   tolerances in the unit check) and against the commissioned ones (the posterior tolerances);
//! - healthy flights at −40 and +70 °C against the commissioned parameters, with the temperature
//!   known;
//! - one flight per fault mode at severity 0.3 (a short on phase A, B, C in turn; eccentricity
//!   at phase 0.3; gain 0.8), at −40, 20 or 70 °C in turn, against the commissioned parameters;
//! - the minimum detectable severities of the fourth flight, against those of the drawing's unit
//!   on its own healthy flight.
//!
//! Prints the markdown tables of the results page. From `host-tests/`:
//!
//! ```text
//! cargo run --release -p ema-investigations --example fleet -- [UNITS [SEED]]
//! ```

use std::path::Path;

use ema_cli::commission::{commission_recordings, CommissioningRecording};
use ema_cli::identify::{condition_recording_checked_for, identify_unit_recording, ModelCommand, Outcome, HOST_WINDOW};
use ema_cli::recording::Recording;
use ema_cli::unit_draw::draw_unit;
use ema_monitor::conditioning::MeasuredTrace;
use ema_monitor::health::{FaultMode, Status};
use ema_monitor::monitor::IdentifyConfig;
use ema_monitor::unit::{Tolerances, MAX_RELATIVE_SIGMA};
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};
use rayon::prelude::*;

/// Severity of the faulty flights.
const SEVERITY: f32 = 0.3;
/// Temperatures of the commissioning flights.
const COMMISSIONING_C: [f32; 3] = [5.0, 20.0, 35.0];
/// Temperatures the faulty flights take in turn.
const FAULTY_C: [f32; 3] = [-40.0, 20.0, 70.0];

/// What one unit gave.
struct UnitResult {
    seed: u64,
    commissioned: Result<(), String>,
    fourth_nominal: Status,
    fourth_commissioned: Option<Status>,
    cold: Option<Status>,
    hot: Option<Status>,
    /// Per faulty flight: mode, temperature, status, Err%.
    faulty: Vec<(FaultMode, f32, Status, f32)>,
    detectable: [Option<f32>; 5],
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let units: u64 = args.first().map(|s| s.parse()).transpose()?.unwrap_or(12);
    let seed: u64 = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(4100);
    let nominal_detectable = {
        let rec = record(&EmaParams::NOMINAL, &FaultVector::HEALTHY, 20.0, seed ^ 0xD7);
        let out = identify(&rec, &EmaParams::NOMINAL, &Tolerances::TYPICAL)?;
        out.report.uncertainty.map_or([None; 5], |u| u.detectable_below)
    };
    let results: Vec<UnitResult> =
        (0..units).into_par_iter().map(|u| run_unit(seed + u)).collect::<Result<_, String>>()?;
    print_tables(&results, &nominal_detectable);
    Ok(())
}

/// The reference model's recording of `params` (at 20 °C) with `faults` at `temperature_c`.
fn record(params: &EmaParams, faults: &FaultVector, temperature_c: f32, seed: u64) -> Recording {
    let cfg = SimConfig {
        params: params.at_temperature(temperature_c),
        faults: *faults,
        profile: Profile::STANDARD,
        noise: true,
        seed,
        ..SimConfig::default()
    };
    let result = simulate(&cfg).expect("a drawn unit simulates");
    Recording::from_reference(&result, Vec::new())
}

/// `rec` identified as `ema identify` does, against `params` (at the flight's temperature).
fn identify(rec: &Recording, params: &EmaParams, tolerances: &Tolerances) -> Result<Outcome, String> {
    let command = ModelCommand::Profile { profile: Profile::STANDARD, name: "standard".to_owned() };
    identify_unit_recording(
        rec,
        Path::new("fleet.csv"),
        params,
        &command,
        &IdentifyConfig::default(),
        tolerances,
        false,
    )
    .map(|(outcome, _)| outcome)
    .map_err(|e| e.to_string())
}

fn run_unit(seed: u64) -> Result<UnitResult, String> {
    let unit = draw_unit(&EmaParams::NOMINAL, &Tolerances::TYPICAL, seed).map_err(|e| e.to_string())?;
    let command = ModelCommand::Profile { profile: Profile::STANDARD, name: "standard".to_owned() };
    let path = Path::new("fleet.csv");
    let mut traces: Vec<Box<MeasuredTrace<HOST_WINDOW>>> = Vec::new();
    for (r, &t) in COMMISSIONING_C.iter().enumerate() {
        let rec = record(&unit.params, &FaultVector::HEALTHY, t, seed * 16 + r as u64);
        let (trace, _) =
            condition_recording_checked_for(&rec, path, &EmaParams::NOMINAL, &command).map_err(|e| e.to_string())?;
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
    let fourth = record(&unit.params, &FaultVector::HEALTHY, 20.0, seed * 16 + 3);
    let fourth_nominal = identify(&fourth, &EmaParams::NOMINAL, &Tolerances::TYPICAL)?.report.status;
    let Ok(baseline) = baseline else {
        return Ok(UnitResult {
            seed,
            commissioned: Err(baseline.err().map(|e| e.to_string()).unwrap_or_default()),
            fourth_nominal,
            fourth_commissioned: None,
            cold: None,
            hot: None,
            faulty: Vec::new(),
            detectable: [None; 5],
        });
    };
    let posterior = Tolerances {
        relative_sigma: core::array::from_fn(|i| {
            (Tolerances::TYPICAL.relative_sigma[i] * baseline.sigma_z[i]).min(MAX_RELATIVE_SIGMA)
        }),
    };
    let own = baseline.params;
    let fourth_out = identify(&fourth, &own, &posterior)?;
    let at = |t: f32, s: u64| -> Result<Status, String> {
        let rec = record(&unit.params, &FaultVector::HEALTHY, t, s);
        Ok(identify(&rec, &own.at_temperature(t), &posterior)?.report.status)
    };
    let cold = at(-40.0, seed * 16 + 4)?;
    let hot = at(70.0, seed * 16 + 5)?;
    let mut faulty = Vec::new();
    for (m, mode) in FaultMode::ALL.iter().enumerate() {
        let mut k = FaultVector::HEALTHY;
        match mode {
            FaultMode::Friction => k.0[0] = SEVERITY,
            FaultMode::Backlash => k.0[1] = SEVERITY,
            FaultMode::ShortCircuit => k.0[2 + (seed % 3) as usize] = SEVERITY,
            FaultMode::Eccentricity => (k.0[5], k.0[6]) = (SEVERITY, 0.3),
            FaultMode::GainDrift => k.0[7] = 0.5 + SEVERITY,
        }
        let t = FAULTY_C[(m + seed as usize) % FAULTY_C.len()];
        let rec = record(&unit.params, &k, t, seed * 16 + 6 + m as u64);
        let report = identify(&rec, &own.at_temperature(t), &posterior)?.report;
        faulty.push((*mode, t, report.status, report.faults.paper_error_percent(&k)));
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

fn label(s: Option<Status>) -> String {
    s.map_or("–".to_owned(), |s| match s.reason() {
        Some(r) => format!("INCONCLUSIVE ({})", r.label()),
        None => s.label().to_owned(),
    })
}

fn print_tables(results: &[UnitResult], nominal_detectable: &[Option<f32>; 5]) {
    let n = results.len();
    let count = |f: &dyn Fn(&UnitResult) -> bool| results.iter().filter(|r| f(r)).count();
    let alarm = |s: Option<Status>| matches!(s, Some(Status::Degraded | Status::Failing));
    let abstain = |s: Option<Status>| matches!(s, Some(Status::Inconclusive(_)));
    let commissioned = count(&|r| r.commissioned.is_ok());
    println!("## Healthy units, a fourth flight\n");
    println!("| against | units | false DEGRADED or FAILING | INCONCLUSIVE | HEALTHY |");
    println!("|---|---|---|---|---|");
    println!(
        "| the drawing's parameters | {n} | {} | {} | {} |",
        count(&|r| alarm(Some(r.fourth_nominal))),
        count(&|r| abstain(Some(r.fourth_nominal))),
        count(&|r| r.fourth_nominal == Status::Healthy)
    );
    println!(
        "| its commissioned parameters | {commissioned} of {n} commissioned | {} | {} | {} |",
        count(&|r| alarm(r.fourth_commissioned)),
        count(&|r| abstain(r.fourth_commissioned)),
        count(&|r| r.fourth_commissioned == Some(Status::Healthy))
    );
    println!(
        "\nCommissioned units flown healthy at −40 °C: {} of {commissioned} HEALTHY; at +70 °C: {} of {commissioned} HEALTHY (temperature known).\n",
        count(&|r| r.cold == Some(Status::Healthy)),
        count(&|r| r.hot == Some(Status::Healthy))
    );
    println!("## One fault mode at {SEVERITY} on a commissioned unit\n");
    println!("| mode | flights | diagnosed (DEGRADED or FAILING) | mean Err% | largest Err% |");
    println!("|---|---|---|---|---|");
    let mut all = Vec::new();
    for mode in FaultMode::ALL {
        let rows: Vec<&(FaultMode, f32, Status, f32)> =
            results.iter().flat_map(|r| r.faulty.iter()).filter(|f| f.0 == mode).collect();
        let errs: Vec<f32> = rows.iter().map(|f| f.3).collect();
        all.extend(errs.iter().copied());
        let mean = errs.iter().sum::<f32>() / errs.len().max(1) as f32;
        let max = errs.iter().copied().fold(0.0f32, f32::max);
        println!(
            "| {} | {} | {} | {mean:.2} | {max:.2} |",
            mode.name(),
            rows.len(),
            rows.iter().filter(|f| matches!(f.2, Status::Degraded | Status::Failing)).count()
        );
    }
    let mean = all.iter().sum::<f32>() / all.len().max(1) as f32;
    println!("| all | {} | | {mean:.2} | |", all.len());
    println!("\n## Minimum detectable severity of a healthy flight (median over the commissioned units)\n");
    println!("| mode | the drawing's unit | commissioned units |");
    println!("|---|---|---|");
    for (m, mode) in FaultMode::ALL.iter().enumerate() {
        let mut v: Vec<f32> = results.iter().filter_map(|r| r.detectable[m]).collect();
        v.sort_by(f32::total_cmp);
        let median = v.get(v.len() / 2).map_or("–".to_owned(), |x| format!("{x:.3}"));
        let nominal = nominal_detectable[m].map_or("–".to_owned(), |x| format!("{x:.3}"));
        println!("| {} | {nominal} | {median} |", mode.name());
    }
    println!("\n## Per unit\n");
    println!("| unit seed | commissioning | 4th flight, drawing | 4th flight, commissioned | −40 °C | +70 °C | faulty flights (mode °C: status Err%) |");
    println!("|---|---|---|---|---|---|---|");
    for r in results {
        let faulty: Vec<String> =
            r.faulty.iter().map(|f| format!("{} {:.0}: {} {:.2}", f.0.name(), f.1, label(Some(f.2)), f.3)).collect();
        println!(
            "| {} | {} | {} | {} | {} | {} | {} |",
            r.seed,
            r.commissioned.as_ref().map_or_else(|e| format!("refused: {e}"), |_| "ok".to_owned()),
            label(Some(r.fourth_nominal)),
            label(r.fourth_commissioned),
            label(r.cold),
            label(r.hot),
            faulty.join("; ")
        );
    }
}
