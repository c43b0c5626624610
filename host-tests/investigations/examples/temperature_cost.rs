//! What an unknown temperature costs in detectability: the Cramér–Rao bound of each fault
//! parameter when the flight's temperature is known (a temperature column, the board's sensor)
//! and when it is one more parameter of the flight (`ema identify --estimate-temperature`,
//! `src/operating_temperature.rs`).
//!
//! For each manoeuvre (standard, pbit) and temperature `T₀`, the reference model records the
//! healthy nominal actuator at `T₀` twice (noise off and on, seed 1): the difference gives the
//! noise of a window sample `σ`, the noise-off recording the trace's weights `w_i`. The monitor
//! model, with its parameters at `T₀`, gives the sensitivities of its expected current per window
//! sample to the eight fault parameters at the design point of `pbit_design` (small faults, an
//! eccentricity of 0.1 so that its phase is visible; central differences of 0.01) and to the
//! temperature (central differences of 2 K: `T₀` stays on one side of 20 °C, where the cold
//! friction law bends). The fitness weighs sample `i` by `v_i = ρ_i·w_i`, so the covariance is
//! the weighted least-squares sandwich `σ²·(SᵀVS)⁻¹(SᵀV²S)(SᵀVS)⁻¹` over the eight parameters
//! (temperature known) or the nine (temperature unknown). A mode's smallest detectable severity
//! scales with its bound, so the ratio of the two bounds is what the unknown temperature costs.
//!
//! The bounds are local (a linear model around the design point) and hold for an unbiased model.
//! From `host-tests/`:
//!
//! ```text
//! cargo run --release -p ema-investigations --example temperature_cost
//! ```

use std::path::Path;

use ema_cli::discover::series;
use ema_cli::identify::condition_recording;
use ema_cli::recording::Recording;
use ema_investigations::bounds;
use ema_monitor::fitness::{FAST_REGIME_SPEED_RAD_S, FAST_REGIME_WEIGHT};
use ema_monitor::{EmaParams, FaultVector, ModelEffects, Profile};
use ema_reference::{simulate, SimConfig};

/// The design point (as `pbit_design`'s): small simultaneous faults, an eccentricity of 0.1 at
/// phase 0.3, a gain drift of 0.05.
const DESIGN_POINT: [f32; 8] = [0.05, 0.05, 0.05, 0.0, 0.0, 0.1, 0.3, 0.525];

/// Finite-difference step on the normalized parameters.
const H: f32 = 0.01;

/// Finite-difference half step on the temperature (K).
const H_T: f32 = 2.0;

/// Temperatures of the flights (°C): a cold and a hot day, each on one side of 20 °C.
const TEMPERATURES_C: [f32; 2] = [-30.0, 45.0];

/// The parameters' names, in the fault vector's order.
const NAMES: [&str; 8] = [
    "k1 friction",
    "k2 backlash",
    "k3 short A",
    "k4 short B",
    "k5 short C",
    "k6 eccentricity",
    "k7 ecc. phase",
    "k8 gain",
];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let base = EmaParams::NOMINAL;
    println!("| manoeuvre | T₀ | parameter | bound, T known | bound, T unknown | ratio |");
    println!("|---|---|---|---|---|---|");
    for (name, profile) in [("standard", Profile::STANDARD), ("pbit", Profile::PBIT)] {
        for t0 in TEMPERATURES_C {
            let params = base.at_temperature(t0);
            let record = |noise: bool| -> Result<_, Box<dyn std::error::Error>> {
                let cfg = SimConfig { params, profile, noise, seed: 1, ..SimConfig::default() };
                let rec = simulate(&cfg)?;
                let recording = Recording::from_reference(&rec, vec![]);
                Ok(condition_recording(&recording, Path::new("in-memory.csv"), &base, &profile)?)
            };
            let (clean, noisy) = (record(false)?, record(true)?);
            let n = clean.len();
            let sigma_a =
                (clean.current_a().zip(noisy.current_a()).map(|(a, b)| f64::from(a - b).powi(2)).sum::<f64>()
                    / n as f64)
                    .sqrt();
            let at = |p: &EmaParams, k: [f32; 8]| series(&clean, p, &profile, &FaultVector(k), &ModelEffects::NONE);
            let healthy = at(&params, FaultVector::HEALTHY.0);
            let v: Vec<f64> = clean
                .weights()
                .zip(&healthy.speed_rad_s)
                .map(|(w, s)| {
                    let rho =
                        if s.abs() > f64::from(FAST_REGIME_SPEED_RAD_S) { f64::from(FAST_REGIME_WEIGHT) } else { 1.0 };
                    rho * f64::from(w)
                })
                .collect();
            let mut sens = bounds::fault_sensitivities(DESIGN_POINT, H, |k| at(&params, k).model_a);
            let (hot, cold) = (base.at_temperature(t0 + H_T), base.at_temperature(t0 - H_T));
            let (a, b) = (at(&hot, DESIGN_POINT).model_a, at(&cold, DESIGN_POINT).model_a);
            sens.push(a.iter().zip(&b).map(|(x, y)| (x - y) / f64::from(2.0 * H_T)).collect());
            let known: [f64; 8] =
                bounds::sandwich_bounds(&sens, &v, sigma_a).ok_or("singular information, temperature known")?;
            let unknown: [f64; 9] =
                bounds::sandwich_bounds(&sens, &v, sigma_a).ok_or("singular information, temperature unknown")?;
            for j in 0..8 {
                println!(
                    "| {name} | {t0:+.0} °C | {} | {:.4} | {:.4} | {:.2} |",
                    NAMES[j],
                    known[j],
                    unknown[j],
                    unknown[j] / known[j]
                );
            }
        }
    }
    Ok(())
}
