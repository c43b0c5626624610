//! Each unmodelled effect moves the signals in its documented direction (docs/model.md), with the
//! magnitudes of the crate-level table where they can be predicted.

mod common;

use std::f64::consts::TAU;
use std::sync::OnceLock;

use common::*;
use ema_monitor::{FaultVector, Profile};
use ema_reference::analysis::{mean, moving_average, order_component, rms, window};
use ema_reference::{Effect, Effects, Recording};

fn full(e: Effect) -> Effects {
    Effects::NONE.with(e, 1.0).expect("valid severity")
}

fn healthy(profile: fn() -> Profile, slot: &'static OnceLock<Recording>) -> &'static Recording {
    slot.get_or_init(|| run(profile(), FaultVector::HEALTHY, Effects::NONE))
}

fn standard() -> &'static Recording {
    static R: OnceLock<Recording> = OnceLock::new();
    healthy(|| Profile::STANDARD, &R)
}

fn loaded() -> &'static Recording {
    static R: OnceLock<Recording> = OnceLock::new();
    healthy(loaded_ramp, &R)
}

fn slow() -> &'static Recording {
    static R: OnceLock<Recording> = OnceLock::new();
    healthy(slow_ramp, &R)
}

fn symmetric() -> &'static Recording {
    static R: OnceLock<Recording> = OnceLock::new();
    healthy(symmetric_steps, &R)
}

/// Order-`n` amplitude (per motor revolution) of the true motor speed on the slow ramp (0.1–0.5 s).
fn slow_speed_order(r: &Recording, n: f64) -> f64 {
    let w = window(&times(r), 0.1, 0.5);
    let th: Vec<f64> = r.truth[w.clone()].iter().map(|t| t.motor_angle_rad).collect();
    let om: Vec<f64> = r.truth[w].iter().map(|t| t.motor_speed_rad_per_s).collect();
    let (a, b) = order_component(&th, &om, n);
    a.hypot(b)
}

/// Loaded-ramp current ratio (effect / healthy), mean ACE reference over 0.1–0.45 s.
fn loaded_ratio(e: Effect) -> f64 {
    mean_current_ref(&run(loaded_ramp(), FaultVector::HEALTHY, full(e)), 0.1, 0.45)
        / mean_current_ref(loaded(), 0.1, 0.45)
}

/// Cogging: a 24-per-revolution speed ripple at low speed (×10 the healthy level) that the
/// motor-current reference partly follows.
#[test]
fn cogging_ripples_at_24_per_revolution() {
    let r = run(slow_ramp(), FaultVector::HEALTHY, full(Effect::Cogging));
    let (h, c) = (slow_speed_order(slow(), 24.0), slow_speed_order(&r, 24.0));
    println!("cogging: order-24 speed ripple {h:.3} → {c:.3} rad/s");
    assert!(c > 10.0 * h, "{h} → {c}");
    // Predicted amplitude of the speed ripple, T_cog/(J_eq·Ω) with Ω = 24·ω̄ (the loop barely acts at ~75 Hz).
    let w_mean = mean(&r.truth.iter().map(|t| t.motor_speed_rad_per_s).collect::<Vec<_>>()[1000..]);
    let predicted = 0.04 / (1.52e-4 * 24.0 * w_mean);
    assert!((c / predicted - 1.0).abs() < 0.5, "{c} vs predicted {predicted}");
}

/// Stribeck: stiction (breakaway 2×FSJ) makes the slow ramp stick far more often; at speed the
/// friction is back to FDJ (loaded ramp at ≈ 500 rad/s: current unchanged within 2 %).
#[test]
fn stribeck_adds_stick_slip_at_low_speed_only() {
    let stuck = |r: &Recording| r.truth.iter().filter(|t| t.motor_speed_rad_per_s == 0.0).count();
    let r = run(slow_ramp(), FaultVector::HEALTHY, full(Effect::Stribeck));
    println!("stribeck: stuck samples on the slow ramp {} → {}", stuck(slow()), stuck(&r));
    assert!(stuck(&r) > 2 * stuck(slow()), "{} → {}", stuck(slow()), stuck(&r));
    let ratio = loaded_ratio(Effect::Stribeck);
    assert!((ratio - 1.0).abs() < 0.02, "{ratio}");
}

/// Viscous: current ∝ ω: on the loaded ramp (ω_m ≈ 500 rad/s) the drive needs ΔC·ω/Kt more.
#[test]
fn viscous_adds_current_in_proportion_to_speed() {
    let r = run(loaded_ramp(), FaultVector::HEALTHY, full(Effect::Viscous));
    let w = window(&times(&r), 0.1, 0.45);
    let speed = mean(&r.truth[w].iter().map(|t| t.motor_speed_rad_per_s).collect::<Vec<_>>());
    let delta = mean_current_ref(&r, 0.1, 0.45) - mean_current_ref(loaded(), 0.1, 0.45);
    let expected = 5.0e-4 * speed / 0.26;
    println!("viscous: ΔI {delta:.3} A at {speed:.0} rad/s, expected {expected:.3}");
    assert!((delta / expected - 1.0).abs() < 0.25, "{delta} vs {expected}");
}

/// Winding temperature +100 K: k_e −11 % → ≈ +12 % current for the same torque, symmetric; R +39 %.
#[test]
fn winding_temperature_raises_the_current() {
    let ratio = loaded_ratio(Effect::WindingTemperature);
    println!("winding_temperature: loaded-ramp current ratio {ratio:.3} (1/0.89 = 1.124)");
    assert!((ratio - 1.0 / 0.89).abs() < 0.04, "{ratio}");
}

/// Back-EMF harmonics (80° flat top): mean Kt −6.7 % (current +7 %) and a 6θ_e (= 24 per revolution
/// for p = 4) torque ripple at low speed.
#[test]
fn emf_harmonics_lower_kt_and_ripple_at_six_per_electrical_turn() {
    let ratio = loaded_ratio(Effect::EmfHarmonics);
    println!("emf_harmonics: loaded-ramp current ratio {ratio:.3} (1/0.933 = 1.071)");
    assert!((ratio - 1.0 / 0.9333).abs() < 0.025, "{ratio}");
    let r = run(slow_ramp(), FaultVector::HEALTHY, full(Effect::EmfHarmonics));
    let (h, c) = (slow_speed_order(slow(), 24.0), slow_speed_order(&r, 24.0));
    assert!(c > 3.0 * h, "order-24 ripple {h} → {c}");
}

/// Dead time (8 V): lower top speed in the fast reversal (the exact no-load value is in tests/analytic.rs).
#[test]
fn dead_time_lowers_the_top_speed() {
    let r = run(Profile::STANDARD, FaultVector::HEALTHY, full(Effect::DeadTime));
    let (h, d) = (peak_speed(standard(), 0.15, 0.3, -1.0), peak_speed(&r, 0.15, 0.3, -1.0));
    println!("dead_time: reversal peak speed {h:.1} → {d:.1} rad/s");
    assert!(d < h - 5.0, "{h} → {d}");
}

/// Sensor offset and gain: the recorded currents no longer sum to zero: mean Σi_meas ≈ Σo_j = 0.25 A.
#[test]
fn sensor_offset_biases_the_recorded_currents() {
    let r = run(Profile::STANDARD, FaultVector::HEALTHY, full(Effect::SensorOffset));
    let sum = |r: &Recording| mean(&r.samples.iter().map(|s| s.phase_current_a.iter().sum()).collect::<Vec<f64>>());
    println!("sensor_offset: mean Σi_meas {:.4} → {:.4} A", sum(standard()), sum(&r));
    assert!(sum(standard()).abs() < 0.01);
    assert!((sum(&r) - 0.25).abs() < 0.03, "{}", sum(&r));
    // The drive regulates the measured current. In the initial hold (I_ref ≈ 0, sector 5: B and C
    // commanded) phase C's +0.15 A offset pulls its true current negative (phase B's −0.1 A pulls it
    // the same way, as i_b = −i_c).
    let hold_true_c = |r: &Recording| {
        let w = window(&times(r), 0.0, 0.01);
        mean(&r.truth[w].iter().map(|t| t.phase_current_a[2]).collect::<Vec<_>>())
    };
    println!("sensor_offset: true i_c in the initial hold {:.4} → {:.4} A", hold_true_c(standard()), hold_true_c(&r));
    assert!(hold_true_c(&r) < hold_true_c(standard()) - 0.05, "{} → {}", hold_true_c(standard()), hold_true_c(&r));
}

/// Hinge stiffness 2×: the load part of the current doubles: ΔI ≈ K_h·θ̄_u/(N·η_O·Kt) on the loaded ramp.
#[test]
fn hinge_stiffness_raises_the_current_with_position() {
    let r = run(loaded_ramp(), FaultVector::HEALTHY, full(Effect::HingeStiffness));
    let w = window(&times(&r), 0.1, 0.45);
    let theta = mean(&r.samples[w].iter().map(|s| s.position_rad).collect::<Vec<_>>());
    let delta = mean_current_ref(&r, 0.1, 0.45) - mean_current_ref(loaded(), 0.1, 0.45);
    let expected = 800.0 * theta / (500.0 * 0.85 * 0.26);
    println!("hinge_stiffness: ΔI {delta:.3} A at mean θ {theta:.3} rad, expected {expected:.3}");
    assert!((delta / expected - 1.0).abs() < 0.2, "{delta} vs {expected}");
}

/// Saturation: Kt falls at high current only (−20 % at 15 A): the saturated step is slower, the
/// low-current loaded ramp is unchanged.
#[test]
fn saturation_acts_at_high_current_only() {
    let r = run(Profile::STANDARD, FaultVector::HEALTHY, full(Effect::Saturation));
    let kt_high = |r: &Recording| mean(&torque_constants(r, 12.0).iter().map(|k| k.0).collect::<Vec<_>>());
    let ratio_high = kt_high(&r) / kt_high(standard());
    let (t0, _) = step_metrics(standard());
    let (t1, _) = step_metrics(&r);
    println!("saturation: Kt ratio above 12 A {ratio_high:.3}, step t90 {t0:.4} → {t1:.4} s");
    assert!(ratio_high > 0.78 && ratio_high < 0.88, "{ratio_high}");
    assert!(t1 > t0 + 1e-3, "{t0} → {t1}");
    let low = loaded_ratio(Effect::Saturation);
    assert!((low - 1.0).abs() < 0.02, "{low}");
}

/// Hall misalignment (10° el.): an advance in one direction is a lag in the other: the top speeds of
/// the mirror-symmetric steps differ (they agree within 0.3 % when healthy).
#[test]
fn hall_misalignment_is_direction_dependent() {
    let asym = |r: &Recording| {
        let up = peak_speed(r, 0.15, 0.3, 1.0);
        let down = peak_speed(r, 0.3, 0.45, -1.0);
        (up - down) / (up + down)
    };
    let r = run(symmetric_steps(), FaultVector::HEALTHY, full(Effect::HallMisalignment));
    println!("hall_misalignment: speed asymmetry {:.4} → {:.4}", asym(symmetric()), asym(&r));
    assert!(asym(symmetric()).abs() < 3e-3);
    assert!(asym(&r) > 8e-3, "{}", asym(&r));
}

/// Compliance: the transmission rings at f_r = 50 Hz/s after the fast reversal (zero crossings of
/// the detrended true twist), and the measured position gains content near f_r.
#[test]
fn compliance_rings_at_the_transmission_mode() {
    let ringing = |r: &Recording| {
        let w = window(&times(r), 0.15, 0.3);
        let twist: Vec<f64> =
            r.truth[w.clone()].iter().map(|t| t.motor_angle_rad / 500.0 - t.surface_angle_rad).collect();
        let hp: Vec<f64> = twist.iter().zip(moving_average(&twist, 100)).map(|(a, b)| a - b).collect();
        let crossings = hp.windows(2).filter(|p| p[0] * p[1] < 0.0).count();
        let pos: Vec<f64> = r.samples[w.clone()].iter().map(|s| s.position_rad).collect();
        let pos_hp: Vec<f64> = pos.iter().zip(moving_average(&pos, 100)).map(|(a, b)| a - b).collect();
        let t: Vec<f64> = times(r)[w].to_vec();
        let band: f64 = [40.0, 50.0]
            .iter()
            .map(|f| {
                let (a, b) = order_component(&t, &pos_hp, TAU * f);
                a.hypot(b)
            })
            .sum();
        (rms(&hp), crossings as f64 / 2.0 / 0.15, band)
    };
    let h = ringing(standard());
    for (s, f_r) in [(1.0, 50.0), (0.5, 100.0)] {
        let r = run(Profile::STANDARD, FaultVector::HEALTHY, Effects::NONE.with(Effect::Compliance, s).expect("valid"));
        let c = ringing(&r);
        println!("compliance s = {s}: twist ringing {:.2e} rad at {:.0} Hz (healthy {:.2e}); position 40–50 Hz {:.2e} (healthy {:.2e})", c.0, c.1, h.0, c.2, h.2);
        assert!(c.0 > 3.0 * h.0, "{c:?} vs {h:?}");
        assert!((c.1 / f_r - 1.0).abs() < 0.25, "ringing at {} Hz, mode {f_r} Hz", c.1);
        if s == 1.0 {
            assert!(c.2 > 1.3 * h.2, "{c:?} vs {h:?}");
        }
    }
}

/// Bus sag (3 Ω): the DC link sags under the acceleration current and the top speed falls.
#[test]
fn bus_sag_lowers_the_voltage_and_top_speed() {
    let r = run(Profile::STANDARD, FaultVector::HEALTHY, full(Effect::BusSag));
    let v_min = r.truth.iter().map(|t| t.bus_voltage_v).fold(f64::MAX, f64::min);
    let (h, d) = (peak_speed(standard(), 0.15, 0.3, -1.0), peak_speed(&r, 0.15, 0.3, -1.0));
    println!("bus_sag: minimum bus {v_min:.1} V, reversal peak speed {h:.1} → {d:.1} rad/s");
    assert!(v_min < 260.0, "{v_min}");
    assert!(standard().truth.iter().all(|t| t.bus_voltage_v == 270.0));
    assert!(d < h - 5.0, "{h} → {d}");
}
