//! Each fault k1…k8 moves the signals in its documented direction (docs/model.md).

mod common;

use std::sync::OnceLock;

use common::*;
use ema_monitor::{FaultVector, Profile};
use ema_reference::analysis::{mean, order_component, window};
use ema_reference::{Effects, Recording};

fn with(i: usize, v: f32) -> FaultVector {
    let mut f = FaultVector::HEALTHY;
    f.0[i] = v;
    f
}

fn healthy_standard() -> &'static Recording {
    static R: OnceLock<Recording> = OnceLock::new();
    R.get_or_init(|| run(Profile::STANDARD, FaultVector::HEALTHY, Effects::NONE))
}

fn healthy_loaded() -> &'static Recording {
    static R: OnceLock<Recording> = OnceLock::new();
    R.get_or_init(|| run(loaded_ramp(), FaultVector::HEALTHY, Effects::NONE))
}

/// k1 (dry friction ×(1 + 2k1)): more current on the slow ramp of the standard profile, growing with
/// k1, by about ΔFDJ/Kt (0.14 N·m / 0.26 N·m/A ≈ 0.54 A at k1 = 1).
#[test]
fn friction_raises_the_ramp_current() {
    let i0 = mean_measured_current(healthy_standard(), 0.35, 0.6);
    let half = mean_measured_current(&run(Profile::STANDARD, with(0, 0.5), Effects::NONE), 0.35, 0.6);
    let full = mean_measured_current(&run(Profile::STANDARD, with(0, 1.0), Effects::NONE), 0.35, 0.6);
    let expected = 2.0 * 0.07 / 0.26;
    println!("ramp current k1 = 0, 0.5, 1: {i0:.3} {half:.3} {full:.3} A (expected rise {expected:.3})");
    assert!(i0 < half && half < full, "{i0} {half} {full}");
    assert!(
        (full - i0) > 0.6 * expected && (full - i0) < 1.4 * expected,
        "ΔI = {} A, expected ≈ {expected}",
        full - i0
    );
}

/// k2 (backlash up to 5 mrad): the motor crosses the whole gap at each reversal (true twist
/// `θ_m/N − θ_u` spans BL), and the measured position falls further behind the command at the
/// reversals of the 4 Hz sine.
#[test]
fn backlash_opens_a_gap_and_worsens_reversals() {
    let faulty = run(Profile::STANDARD, with(1, 1.0), Effects::NONE);
    for (r, bl) in [(healthy_standard(), 5.0e-5), (&faulty, 5.0e-3)] {
        let twist: Vec<f64> = r.truth.iter().map(|t| t.motor_angle_rad / 500.0 - t.surface_angle_rad).collect();
        let span = twist.iter().cloned().fold(f64::MIN, f64::max) - twist.iter().cloned().fold(f64::MAX, f64::min);
        println!("gap span {span:.3e} rad, BL {bl:.1e}");
        assert!((span / bl - 1.0).abs() < 0.05, "gap span {span} vs BL {bl}");
    }
    let peak_error = |r: &Recording| {
        let w = window(&times(r), 0.65, 0.85);
        r.samples[w].iter().map(|s| (s.command_rad - s.position_rad).abs()).fold(0.0, f64::max)
    };
    let (e0, e1) = (peak_error(healthy_standard()), peak_error(&faulty));
    println!("peak sine tracking error {e0:.4} → {e1:.4} rad");
    assert!(e1 > e0 + 1e-3, "peak sine tracking error {e0} → {e1} rad");
}

/// k3, k4, k5 (partial short of phase A, B, C, s = 0.5·k): the torque constant drops to
/// `k_0(2 − s)` in the four sectors where the shorted phase conducts and stays `2k_0` in the two where
/// it is off; on the loaded ramp the drive needs ≈ 1/(1 − s/3) more current (mean K_eq).
#[test]
fn short_circuit_lowers_the_torque_constant_where_the_phase_conducts() {
    let k0 = 0.13;
    let i0 = mean_current_ref(healthy_loaded(), 0.1, 0.45);
    for phase in 0..3 {
        let r = run(Profile::STANDARD, with(2 + phase, 1.0), Effects::NONE);
        let kts = torque_constants(&r, 2.0);
        let conducts = |sector: u8| ema_reference::electrical::COMMUTATION[usize::from(sector)][phase] != 0;
        let on: Vec<f64> = kts.iter().filter(|k| conducts(k.2)).map(|k| k.0).collect();
        let off: Vec<f64> = kts.iter().filter(|k| !conducts(k.2)).map(|k| k.0).collect();
        assert!(on.len() > 100 && off.len() > 50);
        let (kon, koff) = (mean(&on) / (2.0 * k0), mean(&off) / (2.0 * k0));
        println!("phase {phase}: Kt/2k0 on {kon:.3} off {koff:.3}");
        assert!((kon - 0.75).abs() < 0.03, "phase {phase}: Kt/2k0 where it conducts {kon}");
        assert!((koff - 1.0).abs() < 0.03, "phase {phase}: Kt/2k0 where it is off {koff}");
        let loaded = run(loaded_ramp(), with(2 + phase, 1.0), Effects::NONE);
        let ratio = mean_current_ref(&loaded, 0.1, 0.45) / i0;
        println!("phase {phase}: loaded-ramp current ratio {ratio:.3} (expected 1.2)");
        assert!((ratio - 1.0 / (1.0 - 0.5 / 3.0)).abs() < 0.06, "phase {phase}: current ratio {ratio}");
    }
}

/// Order-(2p+1) = 9 component (per motor revolution) of the torque constant over the standard profile.
fn kt_order_9(r: &Recording) -> (f64, f64, f64) {
    let kts = torque_constants(r, 1.0);
    let th: Vec<f64> = kts.iter().map(|k| k.1).collect();
    let kt: Vec<f64> = kts.iter().map(|k| k.0).collect();
    let (a, b) = order_component(&th, &kt, 9.0);
    (a, b, mean(&kt))
}

/// k6 (eccentricity ζ = 0.5·k6): a torque-constant ripple of order 2p+1 = 9 per revolution whose
/// amplitude grows in proportion to ζ, with no change of the mean (docs/model.md).
/// k7 (its angle φ = 2πk7 − π) turns the ripple: half a turn of φ flips its sign.
#[test]
fn eccentricity_ripple_grows_with_magnitude_and_turns_with_phase() {
    let ecc = |k6: f32, k7: f32| {
        let mut f = FaultVector::HEALTHY;
        f.0[5] = k6;
        f.0[6] = k7;
        kt_order_9(&run(Profile::STANDARD, f, Effects::NONE))
    };
    let h = kt_order_9(healthy_standard());
    let half = ecc(0.5, 0.25);
    let full = ecc(1.0, 0.25);
    let turned = ecc(1.0, 0.75);
    let amp = |x: (f64, f64, f64)| x.0.hypot(x.1);
    println!(
        "order-9 Kt ripple: healthy {:.4}, k6=0.5 {:.4}, k6=1 {:.4} N·m/A; cos(angle) φ vs φ+π {:.3}",
        amp(h),
        amp(half),
        amp(full),
        (full.0 * turned.0 + full.1 * turned.1) / (amp(full) * amp(turned))
    );
    assert!(amp(h) < 0.1 * amp(full), "healthy {h:?} vs {full:?}");
    assert!((amp(full) / amp(half) - 2.0).abs() < 0.3, "{half:?} {full:?}");
    for x in [half, full, turned] {
        assert!((x.2 / h.2 - 1.0).abs() < 0.02, "mean Kt changed: {x:?} vs {h:?}");
    }
    let dot = (full.0 * turned.0 + full.1 * turned.1) / (amp(full) * amp(turned));
    assert!(dot < -0.9, "φ + π must flip the ripple: {full:?} {turned:?}");
}

/// k8 (Kp = Kp_0·(0.5 + k8)): a lower gain gives a slower step with less overshoot, a higher gain a
/// faster step.
#[test]
fn gain_drift_changes_step_speed_and_overshoot() {
    let (t0, o0) = step_metrics(healthy_standard());
    let (t_lo, o_lo) = step_metrics(&run(Profile::STANDARD, with(7, 0.0), Effects::NONE));
    let (t_hi, _) = step_metrics(&run(Profile::STANDARD, with(7, 1.0), Effects::NONE));
    println!("t90 k8=0/0.5/1: {t_lo:.4} {t0:.4} {t_hi:.4} s; overshoot k8=0/0.5: {o_lo:.4} {o0:.4}");
    assert!(t_lo > t0 + 5e-3, "t90 {t0} → {t_lo} s");
    assert!(o_lo < o0, "overshoot {o0} → {o_lo}");
    assert!(t_hi < t0 - 5e-3, "t90 {t0} → {t_hi} s");
}
