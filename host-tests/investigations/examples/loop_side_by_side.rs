//! The monitor model and the actuator side by side: the reference model runs the standard
//! manoeuvre (sensor noise off, so what differs is structure), the monitor model runs it at the
//! true fault vector, and between `T0` and `T1` each block of `EVERY` control periods prints the
//! means of both controllers' current reference `I_ref`, of both currents (the actuator's `½Σ|i_j|`
//! of its true phase currents, the model's pair current) and of both motor torques, and at the
//! block's end both motor speeds and the surface angles' difference. `EFFECT=S` puts an
//! unmodelled effect into the actuator and, when the library has its term, that term at the same
//! severity into the model: where the two still disagree, the term's physics does.
//!
//! Produces the loop comparisons of `docs/model.md` (the end of the fast reversal, the
//! commutation loss). From `host-tests/`:
//!
//! ```text
//! cargo run --release -p ema-investigations --example loop_side_by_side -- T0 T1 [EVERY] [EFFECT=S] [K1,...,K8]
//! cargo run --release -p ema-investigations --example loop_side_by_side -- 0.165 0.19 20
//! ```

use ema_cli::simulate::{parse_effect_both_sides, parse_faults};
use ema_monitor::model::{ModelState, MonitorModel};
use ema_monitor::profile::ProfileCursor;
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::sim::Simulator;
use ema_reference::SimConfig;

/// Sums over a block of the two loops' `I_ref`, current and torque (actuator, model).
#[derive(Default)]
struct Block {
    sums: [f64; 6],
    periods: usize,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: loop_side_by_side T0 T1 [EVERY] [EFFECT=S] [K1,...,K8]";
    let args: Vec<String> = std::env::args().skip(1).collect();
    let t0: f64 = args.first().ok_or(usage)?.parse()?;
    let t1: f64 = args.get(1).ok_or(usage)?.parse()?;
    let every: usize = args.get(2).map_or(Ok(1), |a| a.parse())?;
    let (effects, model_effects) = parse_effect_both_sides(args.get(3).map(String::as_str))?;
    let k = args.get(4).map_or(Ok(FaultVector::HEALTHY), |a| parse_faults(a))?;
    let params = EmaParams::NOMINAL;
    let profile = Profile::STANDARD;
    let mut sim = Simulator::new(&SimConfig { effects, faults: k, noise: false, ..SimConfig::default() })?;
    let model = MonitorModel::with_effects(&params, &k, &model_effects);
    let mut state = ModelState::at_rest();
    let mut command = ProfileCursor::new(&profile);
    let dt = model.dt_s();
    let (mut squares, mut count) = ([0.0f64; 3], 0usize);
    let mut block = Block::default();
    // the model's torque over the previous period, which the actuator's sample reports now
    let mut model_torque_previous = 0.0;
    println!(
        "t end (s)  I_ref act  mod (A)   I act  mod (A)   T_m act  mod (N·m)   ω_m act  mod (rad/s)  θ_u act−mod (µrad)"
    );
    for step in 0..sim.sample_count() {
        let (sample, truth) = sim.sample();
        let current_act = 0.5 * truth.phase_current_a.iter().map(|i| i.abs()).sum::<f64>();
        let current_mod = f64::from(state.output_current_a).abs();
        let torque_previous = model_torque_previous;
        let (speed_mod, surface_mod) = (state.motor_speed_rad_s, state.surface_angle_rad);
        model.step(&mut state, command.command_rad(step as f32 * dt));
        model_torque_previous = f64::from(state.motor_torque_n_m);
        if (t0..t1).contains(&sample.time_s) {
            let pair = [
                truth.current_ref_a,
                f64::from(state.current_ref_a),
                current_act,
                current_mod,
                truth.mean_motor_torque_n_m,
                torque_previous,
            ];
            for (j, square) in squares.iter_mut().enumerate() {
                *square += (pair[2 * j] - pair[2 * j + 1]).powi(2);
            }
            count += 1;
            block.sums.iter_mut().zip(pair).for_each(|(s, x)| *s += x);
            block.periods += 1;
            if block.periods == every {
                let m = block.sums.map(|s| s / every as f64);
                println!(
                    "{:.4}    {:8.3} {:8.3}   {:6.3} {:6.3}   {:7.4} {:7.4}    {:7.1} {:7.1}      {:8.1}",
                    sample.time_s,
                    m[0],
                    m[1],
                    m[2],
                    m[3],
                    m[4],
                    m[5],
                    truth.motor_speed_rad_per_s,
                    speed_mod,
                    1e6 * (truth.surface_angle_rad - f64::from(surface_mod)),
                );
                block = Block::default();
            }
        }
        sim.advance_period();
    }
    let rms = squares.map(|s| (s / count.max(1) as f64).sqrt());
    println!(
        "rms over [{t0}, {t1}) s, {count} periods: I_ref {:.4} A, I {:.4} A, T_m {:.4} N·m (actuator − model)",
        rms[0], rms[1], rms[2]
    );
    Ok(())
}
