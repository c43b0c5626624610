//! Where the monitor model and a recording disagree at a **given** fault vector (no fit): the
//! structural residual (`I_3eq` block residual averaged over 2 ms, as `ema discover` judges it)
//! overall, by time band of the standard manoeuvre, by motor speed, and the 5 ms windows holding
//! the most of its energy.
//!
//! Produces the per-recording bands of `docs/results/mismatch-floor.md`. From `host-tests/`
//! (the recording from `ema simulate`):
//!
//! ```text
//! cargo run --release -p ema-investigations --example structural_floor -- FILE.csv [K1,...,K8] [EFFECT=S]
//! ```
//! `K` defaults to healthy; `EFFECT=S` switches one effect term of the model on.

use std::path::Path;

use ema_cli::discover::{series, Series};
use ema_cli::identify::condition_recording;
use ema_cli::recording::read_recording;
use ema_cli::simulate::{parse_effect_both_sides, parse_faults, resolve_profile};
use ema_monitor::{EmaParams, FaultVector};

fn rms<'a>(values: impl Iterator<Item = &'a f64>) -> (f64, usize) {
    let (sum, n) = values.fold((0.0, 0), |(s, n), r| (s + r * r, n + 1));
    ((sum / n.max(1) as f64).sqrt(), n)
}

fn band(s: &Series, keep: impl Fn(usize) -> bool) -> (f64, usize) {
    rms((0..s.time_s.len()).filter(|&i| keep(i)).map(|i| &s.structural_a[i]))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let file = args.first().ok_or("usage: structural_floor FILE.csv [K1,...,K8] [EFFECT=S]")?;
    let path = Path::new(file);
    let k = args.get(1).map_or(Ok(FaultVector::HEALTHY), |a| parse_faults(a))?;
    let (_, effects) = parse_effect_both_sides(args.get(2).map(String::as_str))?;
    let profile = resolve_profile("standard")?;
    let recording = read_recording(path)?;
    let trace = condition_recording(&recording, path, &EmaParams::NOMINAL, &profile)?;
    let s = series(&trace, &EmaParams::NOMINAL, &profile, &k, &effects);
    let (all, n) = band(&s, |_| true);
    println!("structural residual RMS (2 ms means): {all:.4} A over {n} blocks");
    let edges = [0.0, 0.1, 0.16, 0.2, 0.3, 0.5, 0.7, f64::INFINITY];
    for w in edges.windows(2) {
        let (r, n) = band(&s, |i| s.time_s[i] >= w[0] && s.time_s[i] < w[1]);
        println!("  t {:.2}-{:.2} s: {r:.4} A ({n} blocks)", w[0], w[1].min(s.time_s.last().copied().unwrap_or(0.0)));
    }
    let speeds = [0.0, 2.0, 20.0, 100.0, 300.0, f64::INFINITY];
    for w in speeds.windows(2) {
        let (r, n) = band(&s, |i| (w[0]..w[1]).contains(&s.speed_rad_s[i].abs()));
        println!("  |w| {}-{} rad/s: {r:.4} A ({n} blocks)", w[0], w[1]);
    }
    let total: f64 = s.structural_a.iter().map(|r| r * r).sum();
    let mut windows: Vec<(usize, f64)> = Vec::new();
    for (t, r) in s.time_s.iter().zip(&s.structural_a) {
        let w = (t / 0.005) as usize;
        match windows.last_mut() {
            Some((last, e)) if *last == w => *e += r * r,
            _ => windows.push((w, r * r)),
        }
    }
    windows.sort_by(|a, b| b.1.total_cmp(&a.1));
    println!("5 ms windows with the most energy:");
    for (w, e) in windows.iter().take(6) {
        println!("  {:.3}-{:.3} s: {:5.1} %", *w as f64 * 0.005, (*w + 1) as f64 * 0.005, 100.0 * e / total);
    }
    Ok(())
}
