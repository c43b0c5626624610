//! The reference model's three phase currents inside control periods: sensor noise off, the
//! standard manoeuvre run to `T0`, then `PERIODS` control periods printed every `EVERY`
//! integration steps (the reference model's step, 0.25 µs) with `½Σ|i_j|` (what the
//! conditioning measures) and the controller's current reference. It is how the braking commutation's bump was seen (README,
//! "the mismatch floor").
//!
//! ```text
//! cargo run --release -p ema-cli --example phase_currents -- T0 PERIODS [EVERY] [EFFECT=S] [K1,...,K8]
//! ```

use ema_cli::simulate::{parse_effects, parse_faults};
use ema_monitor::FaultVector;
use ema_reference::sim::Simulator;
use ema_reference::SimConfig;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: phase_currents T0 PERIODS [EVERY] [EFFECT=S] [K1,...,K8]";
    let args: Vec<String> = std::env::args().skip(1).collect();
    let t0: f64 = args.first().ok_or(usage)?.parse()?;
    let periods: usize = args.get(1).ok_or(usage)?.parse()?;
    let every: u32 = args.get(2).map_or(Ok(4), |a| a.parse())?;
    let effects = parse_effects(args.get(3..4).unwrap_or_default())?;
    let faults = args.get(4).map_or(Ok(FaultVector::HEALTHY), |a| parse_faults(a))?;
    let mut sim = Simulator::new(&SimConfig { effects, faults, noise: false, ..SimConfig::default() })?;
    let dt = sim.step_s();
    let mut started = false;
    let mut left = periods;
    for _ in 0..sim.sample_count() {
        if left == 0 {
            break;
        }
        let (sample, truth) = sim.sample();
        started |= sample.time_s >= t0;
        if !started {
            sim.advance_period();
            continue;
        }
        println!(
            "t {:.4} s: I_ref {:.3} A, ω_m {:.1} rad/s",
            sample.time_s, truth.current_ref_a, truth.motor_speed_rad_per_s
        );
        println!("   t (µs)   i_a      i_b      i_c (A)   ½Σ|i_j| (A)");
        for j in 0..sim.steps_per_sample() {
            sim.step();
            if (j + 1) % every == 0 {
                let i = sim.inverter().current_a;
                let half_sum = 0.5 * i.iter().map(|x| x.abs()).sum::<f64>();
                println!(
                    "   {:6.1} {:8.3} {:8.3} {:8.3}   {half_sum:8.3}",
                    1e6 * dt * f64::from(j + 1),
                    i[0],
                    i[1],
                    i[2]
                );
            }
        }
        left -= 1;
    }
    Ok(())
}
