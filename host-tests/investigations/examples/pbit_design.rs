//! Design of the pre-flight built-in test manoeuvre `pbit` (`Profile::PBIT`): the Cramér–Rao
//! bounds of the fault parameters for the standard manoeuvre, for a family of candidate
//! manoeuvres, and for the chosen one, with the limits each candidate keeps.
//!
//! For a candidate profile the reference model records the healthy actuator twice (noise off and
//! on, seed 1): the difference of the two conditioned traces gives the noise of a window sample,
//! `σ` (A); the noise-off recording gives the weights `w_i` of the trace and is checked against
//! the actuator's limits (peak |θ_u| below the end stop, peak |ω_u| below the no-load speed
//! `V_dc/(2·k_e·N)`, peak phase current within `I_max` + twice the hysteresis half band (the band and the current loop's lag)). The monitor
//! model then gives the sensitivities of its expected current per window sample,
//! `s_ij = ∂μ_i/∂k_j`, by central differences (`h` = 0.01, one-sided at the bounds of `[0, 1]`),
//! at the design point `k_d`. The fitness weighs sample `i` by `v_i = ρ_i·w_i` (`ρ_i` = 0.1 in
//! the fast regime of the healthy model, 1 elsewhere), so the estimator's covariance is the
//! weighted least-squares sandwich
//!
//! ```text
//! C = σ²·(SᵀVS)⁻¹ (SᵀV²S) (SᵀVS)⁻¹,   CRB_j = √C_jj
//! ```
//!
//! (for `V = I` it is the Cramér–Rao bound `σ²(SᵀS)⁻¹` of the Fisher information `SᵀS/σ²`). The
//! design criterion is the largest Err%-weighted bound among the weak modes,
//! `max(σ_k3, σ_k4, σ_k5, σ_k6, k6·σ_k7, σ_k8)` (the phase error counts in Err% times k6).
//!
//! The bounds hold for an unbiased model; the monitor model departs from the actuator where the
//! motor runs fast (steps near the no-load speed, fast ramps). The healthy bias measures that:
//! the identification (the on-board search budget of 30 iterations, no model selection, the
//! polish, fast-regime weight 0.1) of the noise-free healthy recording, whose largest spurious
//! severity `b = max(k1, …, k6, |k8 − 0.5|)` is the fault the model's mismatch alone makes up.
//! A candidate is ranked by `criterion + b`: the bound of the noise plus the bias of the model.
//! The error can depend on the fault, which `b` does not see: the best-ranked candidates are
//! decided by a small campaign (`docs/pbit.md`).
//!
//! From `host-tests/`:
//!
//! ```text
//! cargo run --release -p ema-investigations --example pbit_design            # standard, pbit, candidates
//! cargo run --release -p ema-investigations --example pbit_design -- --short # standard and pbit only
//! ```

use std::path::Path;

use ema_cli::discover::series;
use ema_cli::identify::condition_recording;
use ema_cli::identify::identify_trace;
use ema_cli::recording::Recording;
use ema_investigations::bounds;
use ema_monitor::diagnosis::IdentifyConfig;
use ema_monitor::fitness::{FAST_REGIME_SPEED_RAD_S, FAST_REGIME_WEIGHT};
use ema_monitor::profile::Segment;
use ema_monitor::{EmaParams, FaultVector, ModelEffects, Profile};
use ema_reference::{simulate, SimConfig};

/// The design point: small simultaneous faults, an eccentricity of 0.1 at phase 0.3 (its phase
/// is only visible with an eccentricity), a gain drift of 0.05.
const DESIGN_POINT: [f32; 8] = [0.05, 0.05, 0.05, 0.0, 0.0, 0.1, 0.3, 0.525];

/// Duration of every candidate: the on-board window's 2200 samples of 0.4 ms
/// (`ONBOARD_WINDOW`), within the issue's 1.0 s.
const DURATION_S: f32 = 0.88;

/// Finite-difference step on the normalized parameters.
const H: f32 = 0.01;

/// What a candidate costs and what it tells.
struct Assessment {
    duration_s: f32,
    peak_position_rad: f64,
    peak_rate_rad_s: f64,
    peak_current_a: f64,
    sigma_a: f64,
    crb: [f64; 8],
    criterion: f64,
    bias: f64,
    within_limits: bool,
}

fn assess(profile: &Profile) -> Result<Assessment, Box<dyn std::error::Error>> {
    let params = EmaParams::NOMINAL;
    let record = |noise: bool| -> Result<_, Box<dyn std::error::Error>> {
        let cfg = SimConfig { profile: *profile, noise, seed: 1, ..SimConfig::default() };
        let rec = simulate(&cfg)?;
        let recording = Recording::from_reference(&rec, vec![]);
        let trace = condition_recording(&recording, Path::new("in-memory.csv"), &params, profile)?;
        Ok((rec, trace))
    };
    let (clean, clean_trace) = record(false)?;
    let (_, noisy_trace) = record(true)?;
    let n = clean_trace.len();
    let sigma_a =
        (clean_trace.current_a().zip(noisy_trace.current_a()).map(|(a, b)| f64::from(a - b).powi(2)).sum::<f64>()
            / n as f64)
            .sqrt();
    let peak_position_rad = clean.truth.iter().map(|t| t.surface_angle_rad.abs()).fold(0.0, f64::max);
    let peak_rate_rad_s = clean.truth.iter().map(|t| t.surface_speed_rad_per_s.abs()).fold(0.0, f64::max);
    let peak_current_a = clean.truth.iter().flat_map(|t| t.phase_current_a.iter().map(|i| i.abs())).fold(0.0, f64::max);
    let no_load_rate = f64::from(params.supply_voltage_v)
        / (2.0 * f64::from(params.phase_emf_constant_v_s_per_rad) * f64::from(params.gear_ratio));
    let within_limits = peak_position_rad < f64::from(params.end_stop_rad)
        && peak_rate_rad_s < no_load_rate
        && peak_current_a <= f64::from(params.current_limit_a + 2.0 * params.hysteresis_half_band_a);

    let healthy = series(&clean_trace, &params, profile, &FaultVector::HEALTHY, &ModelEffects::NONE);
    let weight: Vec<f64> = clean_trace
        .weights()
        .zip(&healthy.speed_rad_s)
        .map(|(w, v)| {
            let rho = if v.abs() > f64::from(FAST_REGIME_SPEED_RAD_S) { f64::from(FAST_REGIME_WEIGHT) } else { 1.0 };
            rho * f64::from(w)
        })
        .collect();
    let model = |k: [f32; 8]| series(&clean_trace, &params, profile, &FaultVector(k), &ModelEffects::NONE).model_a;
    let sens = bounds::fault_sensitivities(DESIGN_POINT, H, model);
    let crb: [f64; 8] = bounds::sandwich_bounds(&sens, &weight, sigma_a).ok_or("singular information matrix")?;
    let criterion =
        [crb[2], crb[3], crb[4], crb[5], f64::from(DESIGN_POINT[5]) * crb[6], crb[7]].into_iter().fold(0.0, f64::max);
    let config = IdentifyConfig { max_iterations: 30, model_selection: false, ..IdentifyConfig::default() };
    let healthy_fit = identify_trace(&clean_trace, &params, profile, &config, Path::new("in-memory.csv"))?;
    let k = healthy_fit.report.faults.0;
    let bias = k[..6].iter().map(|&x| f64::from(x)).fold(f64::from((k[7] - 0.5).abs()), f64::max);
    Ok(Assessment {
        duration_s: profile.duration_s(),
        peak_position_rad,
        peak_rate_rad_s,
        peak_current_a,
        sigma_a,
        crb,
        criterion,
        bias,
        within_limits,
    })
}

/// A candidate of the family: a step to `step` (gain, current saturation), a reversal to
/// `-step`, then constant-rate segments at each rate of `rates` (one sign each, so every change
/// of sign is a reversal), each `segment_s` long, up to `duration_s`.
fn candidate(step: f32, rates: &[f32], segment_s: f32, duration_s: f32) -> Option<Profile> {
    let mut segs = vec![
        Segment::Hold { start_s: 0.0, value_rad: 0.0 },
        Segment::Hold { start_s: 0.01, value_rad: step },
        Segment::Hold { start_s: 0.10, value_rad: -step },
    ];
    let mut t = 0.2f32;
    let mut at = -step;
    for &r in rates {
        segs.push(Segment::Ramp { start_s: t, start_rad: at, rate_rad_per_s: r });
        at += r * segment_s;
        t += segment_s;
    }
    if t > duration_s + 1e-6 {
        return None;
    }
    Profile::new(&segs, duration_s, EmaParams::NOMINAL.end_stop_rad).ok()
}

fn row(name: &str, a: &Assessment) {
    let crb: Vec<String> = a.crb.iter().map(|c| format!("{c:.4}")).collect();
    println!(
        "| {name} | {:.2} | {:.3} | {:.3} | {:.1} | {:.4} | {} | {:.4} | {:.4} | {:.4} | {} |",
        a.duration_s,
        a.peak_position_rad,
        a.peak_rate_rad_s,
        a.peak_current_a,
        a.sigma_a,
        crb.join(" | "),
        a.criterion,
        a.bias,
        a.criterion + a.bias,
        if a.within_limits { "yes" } else { "NO" }
    );
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let short = std::env::args().any(|a| a == "--short");
    println!("design point k_d = {DESIGN_POINT:?}; h = {H}\n");
    println!("| manoeuvre | T (s) | max θ_u (rad) | max ω_u (rad/s) | max i (A) | σ (A) | CRB k1 | k2 | k3 | k4 | k5 | k6 | k7 | k8 | criterion | bias b | criterion + b | limits |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    row("standard", &assess(&Profile::STANDARD)?);
    row("pbit", &assess(&Profile::PBIT)?);
    if short {
        return Ok(());
    }
    let mut best: Option<(f64, String)> = None;
    for step in [0.02f32, 0.05, 0.1] {
        for rates in [
            vec![0.2, -0.2, 0.2, -0.2],
            vec![0.3, -0.3, 0.3, -0.3],
            vec![0.4, -0.4, 0.4, -0.4],
            vec![0.5, -0.5, 0.5, -0.5],
            vec![0.55, -0.55, 0.55, -0.55],
            vec![0.3, -0.5, 0.5, -0.3],
            vec![0.5, -0.3, 0.3, -0.5],
            vec![0.1, -0.3, 0.5, -0.5],
            vec![0.5, -0.5],
            vec![0.4, -0.4],
            vec![0.2, 0.4, -0.4, -0.2],
            vec![0.5, 0.25, -0.25, -0.5],
        ] {
            let segment_s = (DURATION_S - 0.2) / rates.len() as f32;
            let Some(p) = candidate(step, &rates, segment_s, DURATION_S) else { continue };
            let a = assess(&p)?;
            let name = format!("step {step}, rates {rates:?}");
            row(&name, &a);
            if a.within_limits && best.as_ref().is_none_or(|b| a.criterion + a.bias < b.0) {
                best = Some((a.criterion + a.bias, name));
            }
        }
    }
    if let Some((c, name)) = best {
        println!("\nbest candidate within the limits: {name} (criterion + b {c:.4})");
    }
    Ok(())
}
