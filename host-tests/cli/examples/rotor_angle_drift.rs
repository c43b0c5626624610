//! How far the monitor model's rotor angle drifts from the actuator's along the standard
//! manoeuvre: the reference model records it (noise on), the monitor model runs at the true fault
//! vector, and both electrical angles `θ_e` are compared every 50 ms, with the cogging phase
//! difference `6·Δθ_e` (24 cycles per mechanical turn, 4 pole pairs). The model runs without the
//! effect's term, or with it at severity `MODEL_S`: whether the term moves the model's rotor the
//! way the effect moves the actuator's. `SEED` 0 records without sensor noise.
//!
//! ```text
//! cargo run --release -p ema-cli --example rotor_angle_drift -- SEED [EFFECT=S] [K1,...,K8] [MODEL_S]
//! ```

use std::f64::consts::{PI, TAU};
use std::path::Path;

use ema_cli::discover::series;
use ema_cli::identify::condition_recording;
use ema_cli::recording_io::Recording;
use ema_cli::simulate::{parse_effect_both_sides, parse_faults};
use ema_monitor::conditioning::DECIMATION;
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::sim::Simulator;
use ema_reference::{simulate, SimConfig};

/// `x` wrapped into `(−π, π]`.
fn wrapped(x: f64) -> f64 {
    let r = x.rem_euclid(TAU);
    if r > PI {
        r - TAU
    } else {
        r
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: rotor_angle_drift SEED [EFFECT=S] [K1,...,K8] [MODEL_S]";
    let seed: u64 = args.first().ok_or(usage)?.parse()?;
    let (effects, mut model_effects) = parse_effect_both_sides(args.get(1).map(String::as_str))?;
    let k = args.get(2).map_or(Ok(FaultVector::HEALTHY), |a| parse_faults(a))?;
    let model_s: f32 = args.get(3).map_or(Ok(0.0), |a| a.parse())?;
    let term = model_effects.active().next().map(|(term, _)| term);
    if let Some(term) = term {
        model_effects.set(term, model_s)?;
    }
    // seed 0: the sensors without noise
    let cfg = SimConfig { seed: seed.max(1), noise: seed != 0, effects, faults: k, ..SimConfig::default() };
    // the actuator's electrical angle at every sample instant
    let mut sim = Simulator::new(&cfg)?;
    let actuator: Vec<f64> = (0..sim.sample_count())
        .map(|_| {
            let angle = sim.sample().1.electrical_angle_rad;
            sim.advance_period();
            angle
        })
        .collect();
    let recording = Recording::from_reference(&simulate(&cfg)?, vec![]);
    let trace = condition_recording(&recording, Path::new("in-memory.csv"), &Profile::STANDARD)?;
    let model = series(&trace, &EmaParams::NOMINAL, &Profile::STANDARD, &k, &model_effects);
    println!("t (s)  model ω_m (rad/s)  model θ_e  actuator θ_e  Δθ_e (rad)  cogging phase 6·Δθ_e (rad)");
    for (i, t) in model.time_s.iter().enumerate().step_by(125) {
        // the model's state is the block's end: the sample after its last one
        let Some(&a) = actuator.get((i + 1) * DECIMATION) else { break };
        let m = model.electrical_angle_rad[i];
        println!(
            "{t:.3}  {:17.1}  {m:9.3}  {a:12.3}  {:10.3}  {:10.2}",
            model.speed_rad_s[i],
            wrapped(m - a),
            wrapped(6.0 * (m - a))
        );
    }
    Ok(())
}
