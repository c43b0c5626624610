//! The goodness-of-fit test's power: recordings inside the fault library (campaign draws, noise
//! on and off) and outside it (`compliance`, `bus_sag`), each identified as `ema identify` does,
//! with the final residual of the reported vector written out for the statistics of
//! `docs/decisions/0017-windowed-fit-test.md`.
//!
//! One line per case on stdout: the status, the whole-recording score `z`, the largest window
//! score and its limit (`health::FitCheck`), the whole-recording score with the noise variance
//! estimated from the recording (half the mean square of successive residual differences) in
//! place of the analytic one, that estimate over the analytic variance, and the Err%. The
//! residual series goes to `DIR/<label>.csv` (`y,model,w,rho`: measured block mean, the monitor
//! model's, the weight `w_i`, the fast-regime weight `ρ_i`). `RUNS` campaign draws per mode and
//! level (default 2), `PREFIX` keeps the cases whose label starts with it. From `host-tests/`:
//!
//! ```text
//! cargo run --release -p ema-investigations --example fit_power -- DIR [RUNS [PREFIX]]
//! ```

use std::fmt::Write as _;
use std::path::Path;

use ema_cli::campaign::{plan, CampaignArgs};
use ema_cli::identify::{condition_recording, identify_trace, AlgorithmArg};
use ema_cli::recording::Recording;
use ema_cli::simulate::parse_effects;
use ema_monitor::diagnosis::tuning::MODEL_MISMATCH_A;
use ema_monitor::diagnosis::{window_noise_variance_a2, Algorithm, IdentifyConfig};
use ema_monitor::fitness::{simulate_window, EquivalentCurrentFit};
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = args.first().ok_or("usage: fit_power DIR [RUNS [PREFIX]]")?;
    let runs: u32 = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(2);
    std::fs::create_dir_all(dir)?;
    let campaign = CampaignArgs {
        runs,
        algorithms: vec![AlgorithmArg::Pso],
        multi: 0,
        multi_low: 0,
        flights: 1,
        noise: ema_cli::simulate::Noise::On,
        max_iterations: 200,
        paper_only: false,
        fast_regime_weight: None,
        profile: "standard".into(),
        seed: 2018,
        audit: false,
        threads: Some(1),
        modes: Vec::new(),
        json: false,
        output: Default::default(),
        progress: Default::default(),
        params: Default::default(),
    };
    // (label, faults, effects, noise, seed)
    let mut cases: Vec<(String, FaultVector, String, bool, u64)> = Vec::new();
    let faulty = FaultVector([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let gain = FaultVector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.8]);
    for effect in ["compliance", "bus_sag"] {
        for s in ["0.3", "0.6", "1"] {
            for (name, k) in [("healthy", FaultVector::HEALTHY), ("friction", faulty), ("gain", gain)] {
                for seed in [8u64, 9] {
                    let label = format!("out-{effect}={s}-{name}-{seed}-on");
                    cases.push((label, k, format!("{effect}={s}"), true, seed));
                }
            }
        }
    }
    for p in plan(&campaign)? {
        cases.push((format!("lib-{}-{}-{}-on", p.mode, p.level, p.run), p.truth, String::new(), true, p.seed));
        if p.run == 0 {
            cases.push((format!("lib-{}-{}-{}-off", p.mode, p.level, p.run), p.truth, String::new(), false, p.seed));
        }
    }
    for seed in 1..=4u64 {
        cases.push((format!("healthy-{seed}-on"), FaultVector::HEALTHY, String::new(), true, seed));
    }
    cases.push(("healthy-1-off".into(), FaultVector::HEALTHY, String::new(), false, 1));
    let only: Option<&String> = args.get(2);
    for (label, truth, effect, noise, seed) in cases {
        if let Some(prefix) = only {
            if !label.starts_with(prefix.as_str()) {
                continue;
            }
        }
        let effects = if effect.is_empty() {
            ema_reference::Effects::NONE
        } else {
            parse_effects(std::slice::from_ref(&effect))?
        };
        let config = SimConfig { faults: truth, effects, noise, seed, ..SimConfig::default() };
        let rec = simulate(&config)?;
        let recording = Recording::from_reference(&rec, Vec::new());
        let profile = Profile::STANDARD;
        let trace = condition_recording(&recording, Path::new(&label), &EmaParams::NOMINAL, &profile)?;
        let id = IdentifyConfig { algorithm: Algorithm::Pso, seed: 1, ..IdentifyConfig::default() };
        let outcome = identify_trace(&trace, &EmaParams::NOMINAL, &profile, &id, Path::new(&label))?;
        let fit = EquivalentCurrentFit::new(&trace, EmaParams::NOMINAL, &profile)?
            .with_fast_regime_weight(id.fast_regime_weight)
            .ok_or("weight")?;
        let (intervals, weight) = fit.fast_regime();
        let (y, w): (Vec<f32>, Vec<f32>) = (trace.current_a().collect(), trace.weights().collect());
        let (mut csv, mut r, mut v) = (String::from("y,model,w,rho\n"), Vec::new(), Vec::new());
        simulate_window(&EmaParams::NOMINAL, &profile, &outcome.report.faults, y.len(), |i, m, _| {
            let rho = if intervals.iter().any(|&(a, b)| (a..b).contains(&(i as u32))) { weight } else { 1.0 };
            let _ = writeln!(csv, "{},{},{},{}", y[i], m, w[i], rho);
            r.push(f64::from(y[i] - m));
            v.push(f64::from(rho * w[i]));
            true
        });
        std::fs::write(Path::new(dir).join(format!("{label}.csv")), csv)?;
        let rep = outcome.report;
        let check = rep.fit_check.ok_or("no fit check")?;
        // The alternative: the noise variance from the recording itself, half the weighted mean
        // square of successive residual differences, in place of the analytic one.
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for i in 1..r.len() {
            let vi = v[i].min(v[i - 1]);
            num += vi * (r[i] - r[i - 1]).powi(2);
            den += vi;
        }
        let noise_model =
            f64::from(window_noise_variance_a2(&EmaParams::NOMINAL, ema_monitor::conditioning::DECIMATION as f32));
        let mismatch = f64::from(MODEL_MISMATCH_A).powi(2);
        let from_recording = num / den / 2.0;
        let n_eff = f64::from(check.effective_samples);
        let w_bar = f64::from(check.expected_a2) / (noise_model + mismatch);
        let t = n_eff * f64::from(rep.fitness) / (w_bar * (from_recording + mismatch));
        let z_recording = (t - n_eff) / (2.0 * n_eff).sqrt();
        println!(
            "{label} {} z {:.2} window_z {:.2} window {} limit {:.2} z_noise_from_recording {:.2} noise_ratio {:.3} err {:.2} k {:?}",
            rep.status.label(),
            check.z,
            check.window_z,
            check.window,
            check.window_limit,
            z_recording,
            from_recording / noise_model,
            rep.faults.paper_error_percent(&truth),
            rep.faults.0
        );
    }
    Ok(())
}
