//! An effect's signature in the measured current, the actuator's against the model term's: the
//! reference model records the standard manoeuvre with the effect and without it (same faults,
//! same noise seeds `1..=N`, or noise off with `N = 0`), and the **actuator's signature** is the
//! seeds' mean `I_3eq` with the effect minus without; the monitor model, at the true vector, runs
//! with its term at the same severity and with it off, and the **model's signature** is the
//! difference of those. By band of time and of speed: both signatures' RMS, their correlation and
//! the gain `g = ⟨ref, model⟩/⟨model, model⟩` a least-squares fit would give the term (1 when the
//! term is right, below 1 when it is too strong or out of phase), on the 0.4 ms blocks the fitness
//! compares and on the 2 ms means the structural residual uses. Then the RMS of the measured
//! seeds' mean minus the model with its term at `s` = 0, 0.1·S, …, 1.2·S by band: where in the
//! recording a fit of the term would settle, and whether it moves smoothly with `s` (a jump is a
//! discrete event of the model, such as a lost step at a reversal); then the lag (in blocks) at
//! which the two signatures agree best, and with `T0 T1` the blocks between them.
//!
//! Produces the effect-term signatures of `docs/model.md` (e.g. the cogging term with friction).
//! From `host-tests/`:
//!
//! ```text
//! cargo run --release -p ema-investigations --example effect_signature -- N EFFECT=S [K1,...,K8 [T0 T1]]
//! cargo run --release -p ema-investigations --example effect_signature -- 16 cogging=1 0.3,0,0,0,0,0,0.5,0.5
//! ```

use std::path::Path;

use ema_cli::discover::{moving_mean, series, SMOOTH_BLOCKS};
use ema_cli::identify::condition_recording;
use ema_cli::recording::Recording;
use ema_cli::simulate::{parse_effect_both_sides, parse_faults};
use ema_monitor::{EmaParams, FaultVector, ModelEffects, Profile};
use ema_reference::effects::Effects;
use ema_reference::{simulate, SimConfig};

/// Seeds' mean of the measured `I_3eq` blocks with `effects` (noise off when `seeds` is 0), and the
/// model's series at `k` with `model_effects` along the first recording.
fn measured_mean(
    seeds: u64,
    k: &FaultVector,
    effects: Effects,
    model_effects: &[ModelEffects],
) -> Result<(Vec<f64>, Vec<ema_cli::discover::Series>), Box<dyn std::error::Error>> {
    let mut mean: Vec<f64> = Vec::new();
    let mut models = Vec::new();
    let runs: Vec<(u64, bool)> = if seeds == 0 { vec![(1, false)] } else { (1..=seeds).map(|s| (s, true)).collect() };
    for &(seed, noise) in &runs {
        let cfg = SimConfig { seed, noise, effects, faults: *k, ..SimConfig::default() };
        let recording = Recording::from_reference(&simulate(&cfg)?, vec![]);
        let trace =
            condition_recording(&recording, Path::new("in-memory.csv"), &EmaParams::NOMINAL, &Profile::STANDARD)?;
        if models.is_empty() {
            for fx in model_effects {
                models.push(series(&trace, &EmaParams::NOMINAL, &Profile::STANDARD, k, fx));
            }
        }
        if mean.is_empty() {
            mean = vec![0.0; trace.len()];
        }
        for (m, y) in mean.iter_mut().zip(trace.current_a()) {
            *m += f64::from(y) / runs.len() as f64;
        }
    }
    Ok((mean, models))
}

/// `(rms_ref, rms_model, correlation, gain)` over the blocks `keep` selects.
fn compare(r: &[f64], m: &[f64], keep: impl Fn(usize) -> bool) -> (f64, f64, f64, f64, usize) {
    let (mut rr, mut mm, mut rm, mut n) = (0.0, 0.0, 0.0, 0usize);
    for i in (0..r.len().min(m.len())).filter(|&i| keep(i)) {
        rr += r[i] * r[i];
        mm += m[i] * m[i];
        rm += r[i] * m[i];
        n += 1;
    }
    let c = n.max(1) as f64;
    ((rr / c).sqrt(), (mm / c).sqrt(), rm / (rr * mm).sqrt().max(1e-30), rm / mm.max(1e-30), n)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: effect_signature N EFFECT=S [K1,...,K8]";
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seeds: u64 = args.first().ok_or(usage)?.parse()?;
    let (effects, model_effects) = parse_effect_both_sides(Some(args.get(1).ok_or(usage)?.as_str()))?;
    let k = args.get(2).map_or(Ok(FaultVector::HEALTHY), |a| parse_faults(a))?;
    let (effect, severity) = model_effects.active().next().ok_or("EFFECT: the library has no term for it")?;
    let scan: Vec<f32> = (0..=12).map(|i| 0.1 * i as f32 * severity).collect();
    let mut runs = vec![model_effects, ModelEffects::NONE];
    for &s in &scan {
        let mut fx = ModelEffects::NONE;
        fx.set(effect, s)?;
        runs.push(fx);
    }
    let (with, models) = measured_mean(seeds, &k, effects, &runs)?;
    let (without, _) = measured_mean(seeds, &k, Effects::NONE, &[])?;
    let (on, off) = (&models[0], &models[1]);
    let sig_ref: Vec<f64> = with.iter().zip(&without).map(|(a, b)| a - b).collect();
    let sig_model: Vec<f64> = on.model_a.iter().zip(&off.model_a).map(|(a, b)| a - b).collect();
    let smooth_ref = moving_mean(&sig_ref, SMOOTH_BLOCKS);
    let smooth_model = moving_mean(&sig_model, SMOOTH_BLOCKS);
    let row = |label: String, keep: &dyn Fn(usize) -> bool| {
        let (a, b, c, g, n) = compare(&sig_ref, &sig_model, keep);
        let (sa, sb, sc, sg, _) = compare(&smooth_ref, &smooth_model, keep);
        println!("{label:<20} {a:8.4} {b:8.4} {c:6.2} {g:6.2} | {sa:8.4} {sb:8.4} {sc:6.2} {sg:6.2} {n:6}");
    };
    println!(
        "signature (with minus without, A): actuator ({}) vs model term, true vector",
        if seeds == 0 { "noise off".to_string() } else { format!("mean of {seeds} noise seeds") }
    );
    println!(
        "{:<20} {:>8} {:>8} {:>6} {:>6} | {:>8} {:>8} {:>6} {:>6} {:>6}",
        "band", "rms ref", "rms mod", "corr", "gain", "2ms ref", "2ms mod", "corr", "gain", "blocks"
    );
    row("all".into(), &|_| true);
    let t = &off.time_s;
    let edges = [0.0, 0.1, 0.16, 0.2, 0.3, 0.5, 0.7, f64::INFINITY];
    for w in edges.windows(2) {
        row(format!("t {:.2}-{:.2} s", w[0], w[1].min(0.85)), &|i| t[i] >= w[0] && t[i] < w[1]);
    }
    let speeds = [0.0, 2.0, 20.0, 100.0, 300.0, f64::INFINITY];
    for w in speeds.windows(2) {
        let speed = &off.speed_rad_s;
        row(format!("|w| {}-{} rad/s", w[0], w[1]), &|i| (w[0]..w[1]).contains(&speed[i].abs()));
    }
    println!("RMS of the seeds' mean with the effect minus the model with its term at s (0.4 ms blocks, A):");
    print!("{:<20}", "band \\ s");
    for s in &scan {
        print!(" {s:6.2}");
    }
    println!();
    let scan_row = |label: String, keep: &dyn Fn(usize) -> bool| {
        print!("{label:<20}");
        for m in &models[2..] {
            let (e, n) = (0..with.len())
                .filter(|&i| keep(i))
                .fold((0.0, 0usize), |(e, n), i| (e + (with[i] - m.model_a[i]).powi(2), n + 1));
            print!(" {:6.3}", (e / n.max(1) as f64).sqrt());
        }
        println!();
    };
    scan_row("all".into(), &|_| true);
    for w in edges.windows(2) {
        scan_row(format!("t {:.2}-{:.2} s", w[0], w[1].min(0.85)), &|i| t[i] >= w[0] && t[i] < w[1]);
    }
    for w in speeds.windows(2) {
        let speed = &off.speed_rad_s;
        scan_row(format!("|w| {}-{} rad/s", w[0], w[1]), &|i| (w[0]..w[1]).contains(&speed[i].abs()));
    }
    println!("correlation of the 0.4 ms signatures at a lag (model shifted by L blocks):");
    for lag in -4i64..=4 {
        let n = sig_ref.len() as i64;
        let (mut rr, mut mm, mut rm) = (0.0, 0.0, 0.0);
        for i in 0..n {
            let j = i - lag;
            if (0..n).contains(&j) {
                let (r, m) = (sig_ref[i as usize], sig_model[j as usize]);
                rr += r * r;
                mm += m * m;
                rm += r * m;
            }
        }
        println!("  L {lag:+}: corr {:6.3}, gain {:6.3}", rm / (rr * mm).sqrt().max(1e-30), rm / mm.max(1e-30));
    }
    if let (Some(t0), Some(t1)) = (args.get(3), args.get(4)) {
        let (t0, t1): (f64, f64) = (t0.parse()?, t1.parse()?);
        println!(
            "blocks from {t0} to {t1} s: time, model speed, actuator and model signatures, measured with the effect, \
             model at each s (A)"
        );
        for i in (0..t.len()).filter(|&i| t[i] >= t0 && t[i] < t1) {
            print!("  {:.4} {:8.1} {:+.4} {:+.4} {:8.4}", t[i], off.speed_rad_s[i], sig_ref[i], sig_model[i], with[i]);
            for m in &models[2..] {
                print!(" {:8.4}", m.model_a[i]);
            }
            println!();
        }
    }
    Ok(())
}
