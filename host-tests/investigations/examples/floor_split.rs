//! What the structural residual at the true fault vector is made of: the sensor noise, which no
//! model can remove, and the monitor model's mismatch with the actuator. The reference model
//! records the standard manoeuvre with noise seeds `1..=N` (everything else equal); the monitor
//! model, deterministic, runs once at the true vector. Over the seeds, the mean of the measured
//! `I_3eq` block means is the actuator's noise-free expectation, so
//!
//! - **noise** = RMS over seeds and blocks of each seed's 2 ms means minus the seeds' mean,
//!   `·√(N/(N−1))` (unbiased);
//! - **mismatch** = RMS of the seeds' mean minus the model, with the noise left in a mean of `N`
//!   taken out: `√(max(0, RMS² − noise²/N))`;
//! - **floor** (what `ema discover` sees on one recording) = RMS over seeds of the structural
//!   residual, ≈ `√(noise² + mismatch²)`.
//!
//! Then by band of time and of speed, the 5 ms windows with the most mismatch, and the mean
//! mismatch by half of the commutation sector (where a term's error is tied to the rotor angle).
//!
//! Produces the noise / mismatch split of `docs/results/mismatch-floor.md` (and
//! `ema_cli::discover::NOISE_FLOOR_A`). From `host-tests/`:
//!
//! ```text
//! cargo run --release -p ema-investigations --example floor_split -- N [K1,...,K8] [EFFECT=S]
//! cargo run --release -p ema-investigations --example floor_split -- 16 0,0,0,0,0,0,0.5,0.5
//! ```
//! `EFFECT=S` puts the effect in the actuator **and** switches the model's term on at the same
//! severity: how well the term matches the effect, with the noise taken out.

use std::f64::consts::{FRAC_PI_3, FRAC_PI_6, TAU};
use std::path::Path;

use ema_cli::discover::{moving_mean, series, SMOOTH_BLOCKS};
use ema_cli::identify::condition_recording;
use ema_cli::recording::Recording;
use ema_cli::simulate::{parse_effect_both_sides, parse_faults};
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};

/// Speeds (rad/s) at which the sector table counts blocks: above, a 0.4 ms block spans more than
/// about a sector; below, the angle barely moves and one position dominates.
const SECTOR_SPEEDS_RAD_S: (f64, f64) = (20.0, 300.0);

/// Per-block sums over the seeds, split into bands.
struct Split {
    /// `Σ_seeds (m_s − mean)²` per block.
    noise_sq: Vec<f64>,
    /// Seeds' mean minus the model, per block.
    mean_residual: Vec<f64>,
    /// `Σ_seeds r_s²` per block.
    floor_sq: Vec<f64>,
    seeds: usize,
}

impl Split {
    /// `(floor, noise, mismatch)` RMS over the blocks `keep` selects (A).
    fn band(&self, keep: impl Fn(usize) -> bool) -> (f64, f64, f64, usize) {
        let n = self.seeds as f64;
        let (mut f, mut e, mut m, mut count) = (0.0, 0.0, 0.0, 0usize);
        for i in (0..self.noise_sq.len()).filter(|&i| keep(i)) {
            f += self.floor_sq[i] / n;
            e += self.noise_sq[i] / (n - 1.0);
            m += self.mean_residual[i] * self.mean_residual[i];
            count += 1;
        }
        let c = count.max(1) as f64;
        let noise = (e / c).sqrt();
        ((f / c).sqrt(), noise, (m / c - noise * noise / n).max(0.0).sqrt(), count)
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: floor_split N [K1,...,K8] [EFFECT=S]";
    let seeds: u64 = args.first().ok_or(usage)?.parse()?;
    if seeds < 2 {
        return Err("N: at least 2 seeds".into());
    }
    let k = args.get(1).map_or(Ok(FaultVector::HEALTHY), |a| parse_faults(a))?;
    let (effects, model_effects) = parse_effect_both_sides(args.get(2).map(String::as_str))?;
    let mut measured: Vec<Vec<f64>> = Vec::new();
    let mut model = None;
    for seed in 1..=seeds {
        let cfg = SimConfig { seed, effects, faults: k, ..SimConfig::default() };
        let recording = Recording::from_reference(&simulate(&cfg)?, vec![]);
        let trace =
            condition_recording(&recording, Path::new("in-memory.csv"), &EmaParams::NOMINAL, &Profile::STANDARD)?;
        let current: Vec<f64> = trace.current_a().map(f64::from).collect();
        measured.push(moving_mean(&current, SMOOTH_BLOCKS));
        // the model is deterministic: one run, along the first recording
        if model.is_none() {
            model = Some(series(&trace, &EmaParams::NOMINAL, &Profile::STANDARD, &k, &model_effects));
        }
    }
    let model = model.ok_or(usage)?;
    let model_mean = moving_mean(&model.model_a, SMOOTH_BLOCKS);
    let blocks = model_mean.len();
    let n = seeds as f64;
    let mut split = Split {
        noise_sq: vec![0.0; blocks],
        mean_residual: vec![0.0; blocks],
        floor_sq: vec![0.0; blocks],
        seeds: seeds as usize,
    };
    for i in 0..blocks {
        let mean = measured.iter().map(|m| m[i]).sum::<f64>() / n;
        split.mean_residual[i] = mean - model_mean[i];
        split.noise_sq[i] = measured.iter().map(|m| (m[i] - mean).powi(2)).sum();
        split.floor_sq[i] = measured.iter().map(|m| (m[i] - model_mean[i]).powi(2)).sum();
    }
    let row = |label: String, (f, e, m, c): (f64, f64, f64, usize)| {
        println!("{label:<22} {f:8.4} {e:8.4} {m:9.4} {:8.1} % {c:6}", 100.0 * m * m / (f * f).max(1e-30));
    };
    println!("structural residual at the true vector (2 ms means, A), {seeds} noise seeds");
    println!("{:<22} {:>8} {:>8} {:>9} {:>10} {:>6}", "band", "floor", "noise", "mismatch", "mismatch²", "blocks");
    row("all".into(), split.band(|_| true));
    let t = &model.time_s;
    let edges = [0.0, 0.1, 0.16, 0.2, 0.3, 0.5, 0.7, f64::INFINITY];
    for w in edges.windows(2) {
        row(format!("t {:.2}-{:.2} s", w[0], w[1].min(0.85)), split.band(|i| t[i] >= w[0] && t[i] < w[1]));
    }
    let speeds = [0.0, 2.0, 20.0, 100.0, 300.0, f64::INFINITY];
    for w in speeds.windows(2) {
        let w_m = &model.speed_rad_s;
        row(format!("|w| {}-{} rad/s", w[0], w[1]), split.band(|i| (w[0]..w[1]).contains(&w_m[i].abs())));
    }
    // Where in the commutation sector: the seeds' mean minus the model by sector half (θ_e of the
    // model at the block's end), at speeds where a 0.4 ms block stays within about one sector.
    let mut halves = [[0.0f64; 2]; 12];
    for i in 0..blocks {
        let w = model.speed_rad_s[i].abs();
        if !(SECTOR_SPEEDS_RAD_S.0..SECTOR_SPEEDS_RAD_S.1).contains(&w) {
            continue;
        }
        let x = (model.electrical_angle_rad[i] - FRAC_PI_6).rem_euclid(TAU) / FRAC_PI_3;
        let sector = (x as usize).min(5);
        let half = usize::from(x - (sector as f64) >= 0.5);
        halves[2 * sector + half][0] += 1.0;
        halves[2 * sector + half][1] += split.mean_residual[i];
    }
    println!(
        "mean mismatch (seeds' mean minus model, A) by commutation sector half, {}-{} rad/s:",
        SECTOR_SPEEDS_RAD_S.0, SECTOR_SPEEDS_RAD_S.1
    );
    for (sector, pair) in halves.chunks(2).enumerate() {
        let mean = |h: &[f64; 2]| h[1] / h[0].max(1.0);
        println!(
            "  sector {sector}: first half {:+.4} ({:4} blocks), second half {:+.4} ({:4} blocks)",
            mean(&pair[0]),
            pair[0][0],
            mean(&pair[1]),
            pair[1][0]
        );
    }
    let total: f64 = split.mean_residual.iter().map(|r| r * r).sum();
    let mut windows: Vec<(usize, f64, f64, usize)> = Vec::new();
    for (time, r) in t.iter().zip(&split.mean_residual) {
        let w = (time / 0.005) as usize;
        match windows.last_mut() {
            Some((last, e, sum, count)) if *last == w => {
                *e += r * r;
                *sum += r;
                *count += 1;
            }
            _ => windows.push((w, r * r, *r, 1)),
        }
    }
    windows.sort_by(|a, b| b.1.total_cmp(&a.1));
    println!("5 ms windows with the most mismatch energy (seeds' mean minus model, and its mean):");
    for (w, e, sum, count) in windows.iter().take(8) {
        println!(
            "  {:.3}-{:.3} s: {:5.1} %  mean {:+.3} A",
            *w as f64 * 0.005,
            (*w + 1) as f64 * 0.005,
            100.0 * e / total,
            sum / *count as f64
        );
    }
    Ok(())
}
