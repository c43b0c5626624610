//! How far the reference model's recordings move with its integration step: the standard
//! manoeuvre, noise and quantization off, at each step `STEP_S` against the finest `FINE_S`; the
//! RMS difference of the sampled `½Σ|i_j|` in 2 ms means (what the monitor reads, ripple and all)
//! over the whole recording and after the fast reversal (t ≥ 0.32 s), where the loop is not
//! chaotic. The reference crate's `tests/convergence.rs` holds the chosen step to it.
//!
//! Produces the step table of `docs/decisions/0004-reference-step.md`. From `host-tests/`:
//!
//! ```text
//! cargo run --release -p ema-investigations --example reference_step -- FINE_S STEP_S [STEP_S ...]
//! cargo run --release -p ema-investigations --example reference_step -- 5e-8 2e-6 1e-6 5e-7 2.5e-7 2e-7 1e-7
//! ```

use ema_reference::analysis::{equivalent_current_magnitude, moving_average, rms_difference};
use ema_reference::{simulate, SimConfig};

/// Samples in 2 ms at the 10 kHz ACE rate.
const MEAN_SAMPLES: usize = 20;
/// Start of the slow part of the standard profile, after the fast reversal.
const SLOW_FROM_S: f64 = 0.32;

/// The sampled `½Σ|i_j|` in 2 ms means and the sample times at step `dt`.
fn sampled_means(dt: f64) -> Result<(Vec<f64>, Vec<f64>), Box<dyn std::error::Error>> {
    let r = simulate(&SimConfig { noise: false, quantization: false, step_s: dt, ..SimConfig::default() })?;
    let sampled: Vec<f64> = r.samples.iter().map(|s| equivalent_current_magnitude(s.phase_current_a, 1.0)).collect();
    Ok((moving_average(&sampled, MEAN_SAMPLES), r.samples.iter().map(|s| s.time_s).collect()))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: reference_step FINE_S STEP_S [STEP_S ...]";
    let steps: Vec<f64> = std::env::args().skip(1).map(|a| a.parse()).collect::<Result<_, _>>()?;
    let (&fine_s, coarse) = steps.split_first().ok_or(usage)?;
    if coarse.is_empty() {
        return Err(usage.into());
    }
    let (fine, time_s) = sampled_means(fine_s)?;
    let slow = time_s.iter().position(|&t| t >= SLOW_FROM_S).unwrap_or(time_s.len());
    println!("sampled ½Σ|i_j|, 2 ms means, noise off: RMS difference from the {:.3} µs run (A)", fine_s * 1e6);
    println!("{:>10} {:>10} {:>14}", "step (µs)", "whole", "t ≥ 0.32 s");
    for &dt in coarse {
        let (x, _) = sampled_means(dt)?;
        println!(
            "{:>10.3} {:>10.4} {:>14.4}",
            dt * 1e6,
            rms_difference(&x, &fine),
            rms_difference(&x[slow..], &fine[slow..])
        );
    }
    Ok(())
}
