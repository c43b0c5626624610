//! Where one fault vector fits a recording better than another, 40 ms window by window: the
//! on-board fitness `E` (fast regime weighted as on board) split over the evidence windows
//! ([`ema_monitor::fitness::EquivalentCurrentFit::window_errors`]), and each window's gain `E_A − E_B`.
//! It is what the firmware's window check ([`ema_monitor::diagnosis::helps_without_its_best_window`])
//! weighs: a group whose gain comes from one window alone is dropped.
//!
//! Produces the window gains of `docs/decisions/0002-window-check.md` (a hidden cogging read as
//! an eccentricity: the recording of `ema simulate --seed 8 --effect cogging=1`). From
//! `host-tests/`:
//!
//! ```text
//! cargo run --release -p ema-investigations --example window_gains -- FILE.csv K_A K_B
//! ```
//! (`K` as `k1,…,k8`; typically `K_A` without a fault group and `K_B` with it.)

use std::path::Path;

use ema_cli::identify::condition_recording;
use ema_cli::recording::read_recording;
use ema_cli::simulate::parse_faults;
use ema_monitor::diagnosis::tuning::WINDOW_GAIN_SHARE;
use ema_monitor::fitness::{EquivalentCurrentFit, FAST_REGIME_WEIGHT};
use ema_monitor::{EmaParams, Profile};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: window_gains FILE.csv K_A K_B";
    let (Some(file), Some(a), Some(b)) = (args.first(), args.get(1), args.get(2)) else {
        return Err(usage.into());
    };
    let recording = read_recording(file)?;
    let trace = condition_recording(&recording, Path::new(file), &EmaParams::NOMINAL, &Profile::STANDARD)?;
    let fit = EquivalentCurrentFit::new(&trace, EmaParams::NOMINAL, &Profile::STANDARD)?
        .with_fast_regime_weight(FAST_REGIME_WEIGHT)
        .ok_or("fast-regime weight")?;
    let (k_a, k_b) = (parse_faults(a)?, parse_faults(b)?);
    let (w_a, w_b) = (fit.window_errors(&k_a), fit.window_errors(&k_b));
    println!("E(K_A) {:.6e} A², E(K_B) {:.6e} A²", fit.error(&k_a), fit.error(&k_b));
    let window_s = w_a.window_samples as f64 * 4e-4;
    let windows = w_a.samples.div_ceil(w_a.window_samples.max(1));
    let gains: Vec<f64> = (0..windows).map(|j| f64::from(w_a.errors[j]) - f64::from(w_b.errors[j])).collect();
    println!("window (s)       gain E_A − E_B (A²)");
    for (j, g) in gains.iter().enumerate() {
        println!("{:.2}-{:.2}   {g:+.3e}", j as f64 * window_s, (j + 1) as f64 * window_s);
    }
    let (best, best_gain) =
        gains.iter().copied().enumerate().fold((0, f64::NEG_INFINITY), |m, (j, g)| if g > m.1 { (j, g) } else { m });
    let rest: f64 = gains.iter().enumerate().filter(|&(j, _)| j != best).map(|(_, g)| g).sum();
    println!(
        "best window {:.2}-{:.2} s gains {best_gain:+.3e}; the rest {rest:+.3e} ({:.1} % of it; the check asks {:.0} % when K_A holds no group K_B lacks, else > 0)",
        best as f64 * window_s,
        (best + 1) as f64 * window_s,
        100.0 * rest / best_gain,
        100.0 * WINDOW_GAIN_SHARE
    );
    Ok(())
}
