//! The monitor model's effect terms against the reference model that plays the effect.
//!
//! For each effect: a reference recording of the standard profile with the effect on (noise on,
//! seed 3), then the `I_3eq` residual of the monitor model with the **true** faults, without and
//! with the effect term at the true severity, smoothed over 5 conditioned blocks (the identification
//! compares block means; the raw residual is dominated by the sensor noise). The clean floor (no
//! effect in either model, [`floor`]) is measured on the same seed.
//!
//! Where the signature is well above the floor (saturation, dead time, viscous, winding temperature,
//! hinge stiffness, Stribeck on a worn joint) the term must at least halve the residual; every term
//! must bring it back within 1.3× the floor. Cogging is below the floor even at `s = 1` (its 24·θ_m
//! ripple is filtered by the rotor inertia while moving and held by the breakaway friction at rest):
//! only the "near the floor, not worse" part is checked. So is Stribeck on a healthy joint.

use std::sync::OnceLock;

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::effects::{EffectId, ModelEffects};
use ema_monitor::fitness::{simulate_window, simulate_window_with_effects};
use ema_monitor::model::{ModelState, MonitorModel};
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, Effect, Effects, SimConfig};

/// Window capacity of the conditioned standard profile.
const W: usize = 2200;

/// Conditioned `I_3eq` of a reference recording (noise on, seed 3).
fn reference_trace(effects: Effects, k: &FaultVector) -> Box<ConditionedWindow<W>> {
    let rec = simulate(&SimConfig { seed: 3, effects, faults: *k, ..SimConfig::default() }).expect("valid config");
    let mut trace = Box::new(ConditionedWindow::<W>::new());
    for s in &rec.samples {
        let i = s.phase_current_a;
        trace.push(i[0] as f32, i[1] as f32, i[2] as f32).expect("the standard profile fits the window");
    }
    trace.finish().expect("a complete recording");
    trace
}

/// RMS of the monitor model's residual, smoothed over `blocks` conditioned blocks.
fn residual_rms(trace: &ConditionedWindow<W>, k: &FaultVector, effects: &ModelEffects, blocks: usize) -> f64 {
    let n = trace.len();
    let mut r = vec![0.0f64; n];
    let measured: Vec<f32> = trace.current_a().collect();
    simulate_window_with_effects(&EmaParams::NOMINAL, &Profile::STANDARD, k, effects, n, |i, v, _| {
        r[i] = f64::from(measured[i] - v);
        true
    });
    let means: Vec<f64> = r.chunks(blocks).map(|c| c.iter().sum::<f64>() / c.len() as f64).collect();
    (means.iter().map(|m| m * m).sum::<f64>() / means.len() as f64).sqrt()
}

fn faults(k1: f32) -> FaultVector {
    let mut k = FaultVector::HEALTHY;
    k.0[0] = k1;
    k
}

/// Clean floor (5-block residual, no effect in either model) of the fault `k1`.
fn floor(k1: f32) -> f64 {
    static HEALTHY: OnceLock<f64> = OnceLock::new();
    static WORN: OnceLock<f64> = OnceLock::new();
    let cell = if k1 == 0.0 { &HEALTHY } else { &WORN };
    assert!(k1 == 0.0 || k1 == 1.0, "floors cached for k1 = 0 and 1 only");
    *cell.get_or_init(|| {
        let k = faults(k1);
        residual_rms(&reference_trace(Effects::NONE, &k), &k, &ModelEffects::NONE, 5)
    })
}

/// 5-block residuals `(without the term, with the term)` of `id` at `severity`, friction fault `k1`.
fn residuals(id: &str, severity: f32, k1: f32) -> (f64, f64) {
    let effect: Effect = id.parse().expect("a reference effect");
    let model_effect = EffectId::from_id(id).expect("a monitor-model effect");
    let k = faults(k1);
    let trace = reference_trace(Effects::NONE.with(effect, f64::from(severity)).expect("valid severity"), &k);
    let on = ModelEffects::NONE.with(model_effect, severity).expect("valid severity");
    (residual_rms(&trace, &k, &ModelEffects::NONE, 5), residual_rms(&trace, &k, &on, 5))
}

/// The term brings the residual back within 1.3× the floor and, when `halves`, at least halves it.
fn check(id: &str, severity: f32, k1: f32, halves: bool) {
    let (without, with) = residuals(id, severity, k1);
    let floor = floor(k1);
    eprintln!("{id} s={severity} k1={k1}: without {without:.4} A, with {with:.4} A, floor {floor:.4} A");
    assert!(with <= 1.3 * floor, "{id}: {with:.4} A with the term, floor {floor:.4} A");
    if halves {
        assert!(with <= 0.5 * without, "{id}: {with:.4} A with the term vs {without:.4} A without");
    } else {
        assert!(with <= 1.02 * without, "{id}: the term makes it worse: {with:.4} vs {without:.4} A");
    }
}

#[test]
fn saturation_term_captures_the_saturation() {
    check("saturation", 1.0, 0.0, true);
}

#[test]
fn dead_time_term_captures_the_dead_time() {
    check("dead_time", 1.0, 0.0, true);
}

#[test]
fn viscous_term_captures_the_viscous_friction() {
    check("viscous", 1.0, 0.0, true);
}

#[test]
fn winding_temperature_term_captures_the_hot_winding() {
    check("winding_temperature", 1.0, 0.0, true);
}

#[test]
fn hinge_stiffness_term_captures_the_stiffer_hinge() {
    check("hinge_stiffness", 1.0, 0.0, true);
}

#[test]
fn stribeck_term_captures_the_stiction_of_a_worn_joint() {
    // Healthy friction: the signature is near the floor (checked without the halving).
    check("stribeck", 1.0, 1.0, true);
    check("stribeck", 1.0, 0.0, false);
}

#[test]
fn cogging_term_stays_at_the_floor() {
    check("cogging", 1.0, 0.0, false);
}

#[test]
fn no_effect_is_the_paper_model_bit_for_bit() {
    let k = FaultVector([0.3, 0.7, 0.2, 0.9, 0.1, 0.8, 0.1, 0.35]);
    let plain = MonitorModel::new(&EmaParams::NOMINAL, &k);
    let none = MonitorModel::with_effects(&EmaParams::NOMINAL, &k, &ModelEffects::NONE);
    assert!(!none.has_step_terms());
    // and the step compiled with the effect terms, run with every severity 0
    let (mut a, mut b, mut c) = (ModelState::at_rest(), ModelState::at_rest(), ModelState::at_rest());
    let profile = Profile::STANDARD;
    let steps = (profile.duration_s() / plain.dt_s()) as usize;
    let bits = |s: &ModelState| {
        [
            s.current_a,
            s.output_current_a,
            s.motor_speed_rad_s,
            s.motor_angle_rad,
            s.motor_angle_wrapped_rad,
            s.rotor_phasor.0,
            s.rotor_phasor.1,
            s.hall_angle_rad,
            s.surface_angle_rad,
            s.integral_rad_s,
            s.derivative_rad_per_s,
            s.current_ref_a,
        ]
        .map(f32::to_bits)
    };
    for step in 0..steps {
        let command = profile.command_rad(step as f32 * plain.dt_s());
        plain.step(&mut a, command);
        none.step(&mut b, command);
        none.step_with::<true>(&mut c, command);
        assert_eq!(bits(&a), bits(&b), "step {step}");
        assert_eq!(bits(&a), bits(&c), "step {step}");
    }
    let mut window = Vec::new();
    simulate_window(&EmaParams::NOMINAL, &profile, &k, 2000, |_, v, _| {
        window.push(v.to_bits());
        true
    });
    let mut with_none = Vec::new();
    simulate_window_with_effects(&EmaParams::NOMINAL, &profile, &k, &ModelEffects::NONE, 2000, |_, v, _| {
        with_none.push(v.to_bits());
        true
    });
    assert_eq!(window, with_none);
}
