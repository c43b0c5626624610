//! Analytic limits: the locked-rotor current step of one phase pair and the no-load speed.

use ema_monitor::profile::Segment;
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::analysis::{mean, window};
use ema_reference::{simulate, Effect, Effects, SimConfig};

fn hold(value_rad: f32, duration_s: f32) -> Profile {
    Profile::new(&[Segment::Hold { start_s: 0.0, value_rad }], duration_s, 0.6).expect("valid profile")
}

/// Rotor locked by a huge dry friction at θ_m = 0 (sector 5: phase C high, phase B low, A open), bus
/// lowered to 5 V so that the current (5 V / R_eq) stays under the saturated reference minus the
/// hysteresis band: the upper C and lower B switches stay on and
/// `i_c(t) = V/R_eq·(1 − e^{−t·R_eq/L_eq})`, `R_eq = R_b + R_c`, `L_eq = L_b + L_c`.
/// Checked healthy and with 30 % of phase C shorted (`R_c = 0.7 R_0`, `L_c = 0.49 L_0`: the neutral
/// formula's `1/L_j` weighting matters).
#[test]
fn locked_rotor_current_step_of_one_phase_pair() {
    let mut p = EmaParams::NOMINAL;
    p.supply_voltage_v = 5.0;
    p.static_friction_n_m = 1.0e3;
    p.dynamic_friction_n_m = 1.0e3;
    for shorted_c in [0.0f32, 0.6] {
        let faults = FaultVector([0.0, 0.0, 0.0, 0.0, shorted_c, 0.0, 0.5, 0.5]);
        let cfg = SimConfig { params: p, faults, profile: hold(0.05, 0.02), noise: false, ..SimConfig::default() };
        let r = simulate(&cfg).expect("valid configuration");
        let s = f64::from(0.5 * shorted_c);
        let (r0, l0) = (f64::from(p.phase_resistance_ohm), f64::from(p.phase_inductance_h));
        let r_eq = r0 + r0 * (1.0 - s);
        let l_eq = l0 + l0 * (1.0 - s) * (1.0 - s);
        let v = f64::from(p.supply_voltage_v);
        let mut worst: f64 = 0.0;
        for (smp, t) in r.samples.iter().zip(&r.truth) {
            assert_eq!(t.motor_speed_rad_per_s, 0.0, "the rotor must stay locked");
            assert_eq!(t.hall_sector, 5);
            let expected = v / r_eq * (1.0 - (-smp.time_s * r_eq / l_eq).exp());
            let i = t.phase_current_a;
            assert_eq!(i[0], 0.0, "phase A is open");
            assert!((i[1] + i[2]).abs() < 1e-12);
            worst = worst.max((i[2] - expected).abs());
        }
        let final_a = r.truth.last().map_or(0.0, |t| t.phase_current_a[2]);
        assert!(final_a > 0.9 * v / r_eq, "reached {final_a} A of {} A", v / r_eq);
        // Explicit Euler at the default dt = 0.25 µs on τ = L/R = 4 ms: relative error ≈ dt/(2τ) ≈ 3e-5.
        assert!(worst < 1e-3 * v / r_eq, "s_c = {s}: max error {worst} A");
    }
}

fn no_load(effects: Effects) -> f64 {
    let mut p = EmaParams::NOMINAL;
    p.static_friction_n_m = 0.0;
    p.dynamic_friction_n_m = 0.0;
    p.viscous_friction_n_m_s_per_rad = 0.0;
    p.hinge_stiffness_n_m_per_rad = 0.0;
    // A far command keeps I_ref saturated: the drive runs at its voltage limit.
    let cfg = SimConfig { params: p, effects, profile: hold(0.5, 0.2), noise: false, ..SimConfig::default() };
    let r = simulate(&cfg).expect("valid configuration");
    let t: Vec<f64> = r.samples.iter().map(|s| s.time_s).collect();
    let w = window(&t, 0.15, 0.2);
    assert!(r.truth[w.clone()].iter().all(|x| x.current_ref_a == f64::from(p.current_limit_a)));
    mean(&r.truth[w].iter().map(|x| x.motor_speed_rad_per_s).collect::<Vec<_>>())
}

/// No friction, no load: the motor runs up to `ω_0 = V_dc/(2 k_0)` (both conducting phases on their
/// flat tops in every sector), within 0.3 %; with 8 V of dead time per phase the pair sees
/// `V_dc − 2ΔV`: `ω_0 = (V_dc − 2ΔV)/(2 k_0)`.
#[test]
fn no_load_speed() {
    let v = f64::from(EmaParams::NOMINAL.supply_voltage_v);
    let k0 = f64::from(EmaParams::NOMINAL.phase_emf_constant_v_s_per_rad);
    let w = no_load(Effects::NONE);
    let expected = v / (2.0 * k0);
    assert!((w / expected - 1.0).abs() < 3e-3, "{w} rad/s vs {expected}");
    let w_dt = no_load(Effects::NONE.with(Effect::DeadTime, 1.0).expect("valid"));
    let expected_dt = (v - 2.0 * 8.0) / (2.0 * k0);
    assert!((w_dt / expected_dt - 1.0).abs() < 5e-3, "{w_dt} rad/s vs {expected_dt}");
}
