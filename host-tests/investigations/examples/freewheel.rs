//! How the actuator's hysteresis loop behaves when its current sensors disagree (the
//! `sensor_offset` effect), next to what the monitor model's term predicts
//! ([`ema_monitor::model::ModelState::freewheel_shift_a`]). The reference model records the
//! standard manoeuvre with noise seeds `1..=N`; every control period that stays inside one Hall
//! sector counts:
//!
//! - **held current**: where the regulating phase's mean current sits between the two legs'
//!   targets, `(I_reg − T_held)/(T_other − T_held)`, binned by the 0 V drift per control period
//!   `a = |K_eq ω + R_eq I|·T/L_eq`, next to the model's share `½·exp(−(a/σ_J)²)`;
//! - **idle phase**: how often the phase the Hall table leaves idle conducts (above 0.02 A) and its
//!   mean `|i_r|`, per speed band, next to the model's mean `|i_r|` over the same manoeuvre;
//! - **loop states**: the share of integration steps with the pair voltage at `+V` against the 0 V
//!   drift (the regulating leg's pulse), at 0 V (freewheel), and at `V` with the drift (the other
//!   leg, which the term takes as latched, pulsing), with and without the idle phase conducting.
//!
//! Produces the sensor-offset term's held-current and idle-phase figures of `docs/model.md`.
//! From `host-tests/`:
//!
//! ```text
//! cargo run --release -p ema-investigations --example freewheel -- N [EFFECT=S] [K1,...,K8]
//! cargo run --release -p ema-investigations --example freewheel -- 4
//! ```
//! Without `EFFECT=S`: `sensor_offset=0.9`. The healthy actuator's idle phase, for comparison:
//! `EFFECT` = `cogging=0` (no effect).

use ema_cli::simulate::{parse_effect_both_sides, parse_faults};
use ema_monitor::conditioning::MeasuredEnvelope;
use ema_monitor::fitness::simulate_window_with_effects;
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::electrical::{hall_sector, COMMUTATION};
use ema_reference::sim::Simulator;
use ema_reference::SimConfig;

/// Upper edges of the drift bins (A per control period); above 1.5 A the pair voltage limits the
/// current (fast regime), and the held current is no longer between the targets.
const DRIFT_EDGES_A: [f64; 8] = [0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5];
/// Upper edges of the speed bands (rad/s).
const SPEED_EDGES_RAD_S: [f64; 7] = [20.0, 40.0, 60.0, 80.0, 100.0, 120.0, 240.0];
/// Speeds at which the loop states are counted (rad/s).
const STATE_SPEEDS_RAD_S: (f64, f64) = (20.0, 300.0);
/// Target differences below this do not count for the held current (A).
const MIN_TARGET_GAP_A: f64 = 0.05;
/// Idle-phase current counted as conducting (A).
const CONDUCTING_A: f64 = 0.02;

fn bin(edges: &[f64], x: f64) -> Option<usize> {
    edges.iter().position(|&e| x < e)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: freewheel N [EFFECT=S] [K1,...,K8]";
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seeds: u64 = args.first().ok_or(usage)?.parse()?;
    let effect = args.get(1).map_or("sensor_offset=0.9", String::as_str);
    let (effects, model_effects) = parse_effect_both_sides(Some(effect))?;
    let faults = args.get(2).map_or(Ok(FaultVector::HEALTHY), |a| parse_faults(a))?;
    let jitter_a = f64::from(MeasuredEnvelope::controller_jitter_a(&EmaParams::NOMINAL));

    // [periods, Σ share, Σ model share] per drift bin; [periods, conducting steps share, Σ|i_r|] per speed band.
    let mut held = [[0.0f64; 3]; DRIFT_EDGES_A.len()];
    let mut idle = [[0.0f64; 3]; SPEED_EDGES_RAD_S.len()];
    // Integration steps at 20-300 rad/s by pair voltage against the 0 V drift, without and with
    // the idle phase conducting: [steps, regulating pulse, 0 V, opposite pulse].
    let mut states = [[0.0f64; 4]; 2];
    for seed in 1..=seeds {
        let mut sim = Simulator::new(&SimConfig { effects, faults, seed, ..SimConfig::default() })?;
        let p = *sim.plant();
        let steps = sim.steps_per_sample();
        let sector_now = |sim: &Simulator| {
            usize::from(hall_sector(p.pole_pairs * sim.mechanics().motor_angle_rad + p.hall_offset_rad))
        };
        for _ in 0..sim.sample_count() {
            let (_, truth) = sim.sample();
            let sector = sector_now(&sim);
            let row = COMMUTATION[sector];
            let (Some(pp), Some(qq)) = (row.iter().position(|&c| c == 1), row.iter().position(|&c| c == -1)) else {
                continue;
            };
            let rr = 3 - pp - qq;
            let (r_eq, l_eq) = (
                p.phase_resistance_ohm[pp] + p.phase_resistance_ohm[qq],
                p.phase_inductance_h[pp] + p.phase_inductance_h[qq],
            );
            let k_eq = p.phase_emf_constant_v_s_per_rad[pp] + p.phase_emf_constant_v_s_per_rad[qq];
            let w = truth.motor_speed_rad_per_s;
            let counted = (STATE_SPEEDS_RAD_S.0..STATE_SPEEDS_RAD_S.1).contains(&w.abs());
            let (mut sum_p, mut sum_q, mut conducting, mut idle_sum) = (0.0, 0.0, 0u32, 0.0);
            let mut step_states = [[0.0f64; 4]; 2];
            let mut inside = true;
            for _ in 0..steps {
                sim.step();
                inside &= sector_now(&sim) == sector;
                let i = sim.inverter().current_a;
                sum_p += i[pp];
                sum_q -= i[qq];
                let idle_on = i[rr].abs() > CONDUCTING_A;
                conducting += u32::from(idle_on);
                idle_sum += i[rr].abs();
                if counted {
                    // The pair voltage, positive when it opposes the 0 V drift (a regulating pulse).
                    let v = sim.inverter().terminal_v;
                    let drift_down = r_eq * 0.5 * (i[pp] - i[qq]) + k_eq * w > 0.0;
                    let against = if drift_down { v[pp] - v[qq] } else { v[qq] - v[pp] };
                    let state = if against > 0.5 * p.supply_voltage_v {
                        1
                    } else if against < -0.5 * p.supply_voltage_v {
                        3
                    } else {
                        2
                    };
                    let x = &mut step_states[usize::from(idle_on)];
                    x[0] += 1.0;
                    x[state] += 1.0;
                }
            }
            if !inside {
                continue;
            }
            for (total, x) in states.iter_mut().zip(&step_states) {
                for (t, v) in total.iter_mut().zip(x) {
                    *t += v;
                }
            }
            let n = f64::from(steps);
            if let Some(b) = bin(&SPEED_EDGES_RAD_S, w.abs()) {
                idle[b][0] += 1.0;
                idle[b][1] += f64::from(conducting) / n;
                idle[b][2] += idle_sum / n;
            }
            let i_ref = truth.current_ref_a;
            let t_p = (i_ref - p.current_sensor_offset_a[pp]) / (1.0 + p.current_sensor_gain_error[pp]);
            let t_q = (i_ref + p.current_sensor_offset_a[qq]) / (1.0 + p.current_sensor_gain_error[qq]);
            let back_v = r_eq * 0.5 * (sum_p + sum_q) / n + k_eq * w;
            let regulated_p = (back_v > 0.0) == (t_p < t_q);
            let (i_reg, t_held, t_other) = if regulated_p { (sum_p / n, t_p, t_q) } else { (sum_q / n, t_q, t_p) };
            let a = back_v.abs() * f64::from(EmaParams::NOMINAL.control_period_s) / l_eq;
            if (t_other - t_held).abs() > MIN_TARGET_GAP_A {
                if let Some(b) = bin(&DRIFT_EDGES_A, a) {
                    held[b][0] += 1.0;
                    held[b][1] += (i_reg - t_held) / (t_other - t_held);
                    held[b][2] += 0.5 * (-(a / jitter_a).powi(2)).exp();
                }
            }
        }
    }

    // The model's idle-phase current over the same manoeuvre, per speed band.
    let mut model_idle = [[0.0f64; 2]; SPEED_EDGES_RAD_S.len()];
    let (params, profile) = (EmaParams::NOMINAL, Profile::STANDARD);
    let samples =
        (profile.duration_s() / (params.control_period_s * ema_monitor::conditioning::DECIMATION as f32)) as usize;
    simulate_window_with_effects(&params, &profile, &faults, &model_effects, samples, |_, _, state| {
        if let Some(b) = bin(&SPEED_EDGES_RAD_S, f64::from(state.motor_speed_rad_s).abs()) {
            model_idle[b][0] += 1.0;
            model_idle[b][1] += f64::from(state.freewheel_shift_a.iter().fold(0.0f32, |m, x| m.max(x.abs())));
        }
        true
    });

    println!("{effect}, {seeds} noise seeds, controller jitter σ_J = {jitter_a:.3} A");
    println!("held current between the targets, by 0 V drift per control period a:");
    println!("{:>14} {:>8} {:>10} {:>10}", "a (A)", "periods", "reference", "model");
    let mut lower = 0.0;
    for (edge, h) in DRIFT_EDGES_A.iter().zip(&held) {
        if h[0] > 0.0 {
            println!("{:>6.2}-{:<7.2} {:>8} {:>10.3} {:>10.3}", lower, edge, h[0], h[1] / h[0], h[2] / h[0]);
        }
        lower = *edge;
    }
    println!("idle phase, by |ω_m|:");
    println!(
        "{:>14} {:>8} {:>11} {:>14} {:>14}",
        "|ω| (rad/s)", "periods", "conducting", "ref mean|i_r|", "model mean|i_r|"
    );
    let mut lower = 0.0;
    for ((edge, x), m) in SPEED_EDGES_RAD_S.iter().zip(&idle).zip(&model_idle) {
        if x[0] > 0.0 {
            println!(
                "{:>6.0}-{:<7.0} {:>8} {:>10.1} % {:>12.4} A {:>12.4} A",
                lower,
                edge,
                x[0],
                100.0 * x[1] / x[0],
                x[2] / x[0],
                m[1] / m[0].max(1.0)
            );
        }
        lower = *edge;
    }
    println!(
        "loop states, {}-{} rad/s (share of the integration steps; pulses against / with the 0 V drift):",
        STATE_SPEEDS_RAD_S.0, STATE_SPEEDS_RAD_S.1
    );
    for (idle_on, x) in states.iter().enumerate() {
        if x[0] > 0.0 {
            println!(
                "  idle phase {:13} {:>9} steps: regulating pulse {:5.1} %, 0 V {:5.1} %, opposite pulse {:5.1} %",
                if idle_on == 1 { "conducting" } else { "not conducting" },
                x[0],
                100.0 * x[1] / x[0],
                100.0 * x[2] / x[0],
                100.0 * x[3] / x[0]
            );
        }
    }
    Ok(())
}
