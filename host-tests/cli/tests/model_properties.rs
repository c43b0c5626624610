//! Property test of the monitor model over its whole input space: every fault vector of the box
//! `k ∈ [0, 1]^8` (`ema_monitor::faults`) with every effect term at any severity in
//! `[0, MAX_SEVERITY]` (`ema_monitor::effects`, all ten library effects) runs the standard
//! manoeuvre without a NaN or an infinity anywhere in its state, with bounded currents.
//!
//! The bounds come from the current limit `I_max` (15 A) and the hysteresis half band `h`
//! (0.3 A), not from a fit to what the model does:
//! - the current reference: `|I_ref| ≤ I_max`, the controller's clamp;
//! - every modelled current (the pair current, the sector-mean output current `½Σ|i_j|`, each
//!   phase current): `2·(I_max + h)`. Each commanded phase is regulated to the reference within
//!   the band, so a phase carries at most `I_max + h` of its own; in a commutation the common
//!   phase carries the incoming phase's current and the outgoing one's until it has decayed
//!   through its diode, and while braking the back-EMF drives it past its target even with its
//!   switch at the opposite rail (`src/model/phase_resolved.rs`), so it carries at most the sum
//!   of two such currents. The supply voltage over the smallest pair resistance,
//!   `V_dc/(R_0·(2 − s_p − s_q))` (540 A with both conducting phases half shorted), bounds them
//!   too, but loosely: the bound used here also catches a current loop that runs away;
//! - the expected measured envelope the fitness compares with the measurement (block means of
//!   `I_3eq` through the sensors): that current bound through the largest sensor gain error, plus
//!   the largest sensor offset (the `sensor_offset` term at `MAX_SEVERITY`), plus `3σ` for the
//!   rectified noise of the three phases (`σ` the current sensor noise; a rectified zero-mean
//!   reading averages `σ·√(2/π)`).
//!
//! Cases: the corners of the box and the healthy vector (all faults 0, all 1, or healthy; every
//! effect off or at `MAX_SEVERITY`), then seeded random vectors, each effect off or at a random
//! severity with equal odds (so that the model's loops with and without the step's effect terms
//! both run).

use ema_monitor::effects::{maxima, ModelEffects, EFFECT_COUNT, MAX_SEVERITY};
use ema_monitor::fitness::simulate_window_with_effects;
use ema_monitor::model::{ModelState, MonitorModel};
use ema_monitor::profile::ProfileCursor;
use ema_monitor::{EmaParams, FaultVector, Profile, FAULT_COUNT};

/// Random cases after the corners.
const RANDOM_CASES: usize = 2000;

/// The core's SplitMix64 as a small seeded generator, so that every run checks the same cases.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        ema_monitor::optimizer::rng::splitmix64(&mut self.0)
    }

    /// Uniform in `[0, 1]`, both ends reachable.
    fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / ((1u64 << 24) - 1) as f32
    }
}

/// The bound on every modelled current: `2·(I_max + h)`.
fn current_bound_a(p: &EmaParams) -> f32 {
    2.0 * (p.current_limit_a + p.hysteresis_half_band_a)
}

/// The bound on the expected measured envelope: the current bound through the largest sensor
/// gain error, plus the largest offset of `sensor_offset` at `MAX_SEVERITY`, plus `3σ` of noise.
fn envelope_bound_a(p: &EmaParams) -> f32 {
    let gain = maxima::SENSOR_GAIN.iter().fold(0.0f32, |m, g| m.max(g.abs())) * MAX_SEVERITY;
    let offset = maxima::SENSOR_OFFSET_A.iter().fold(0.0f32, |m, o| m.max(o.abs())) * MAX_SEVERITY;
    current_bound_a(p) * (1.0 + gain) + offset + 3.0 * p.current_noise_a
}

fn cases() -> Vec<(FaultVector, ModelEffects)> {
    let all_at = |s: f32| ModelEffects::from_severities([s; EFFECT_COUNT]).expect("a valid severity");
    let mut out = Vec::new();
    for k in [[0.0; FAULT_COUNT], [1.0; FAULT_COUNT], FaultVector::HEALTHY.0] {
        for effects in [ModelEffects::NONE, all_at(MAX_SEVERITY)] {
            out.push((FaultVector(k), effects));
        }
    }
    let mut rng = Rng(0x0E3A_2018);
    for _ in 0..RANDOM_CASES {
        let mut k = [0.0f32; FAULT_COUNT];
        k.iter_mut().for_each(|x| *x = rng.unit());
        let mut severity = [0.0f32; EFFECT_COUNT];
        for s in &mut severity {
            if rng.next_u64() & 1 == 1 {
                *s = MAX_SEVERITY * rng.unit();
            }
        }
        out.push((FaultVector(k), ModelEffects::from_severities(severity).expect("in [0, MAX_SEVERITY]")));
    }
    out
}

/// Every field of the state that must be a number is finite.
fn finite(s: &ModelState) -> bool {
    let scalars = [
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
        s.previous_position_rad,
        s.measured_position_rad,
        s.current_ref_a,
        s.motor_torque_n_m,
    ];
    scalars.iter().chain(&s.phase_current_a).chain(&s.freewheel_shift_a).all(|x| x.is_finite())
}

#[test]
fn the_monitor_model_is_finite_and_bounded_over_the_fault_box_and_effect_severities() {
    let p = EmaParams::NOMINAL;
    let profile = Profile::STANDARD;
    let steps = (profile.duration_s() / p.control_period_s).round() as u32;
    let window = steps as usize / ema_monitor::conditioning::DECIMATION;
    let (bound, envelope_bound) = (current_bound_a(&p), envelope_bound_a(&p));
    let (mut peak, mut envelope_peak) = (0.0f32, 0.0f32);
    let cases = cases();
    for (case, (k, effects)) in cases.iter().enumerate() {
        let what = || format!("case {case}: k = {:?}, effects = {effects:?}", k.0);
        let model = MonitorModel::with_effects(&p, k, effects);
        let mut s = ModelState::at_rest();
        let mut command = ProfileCursor::new(&profile);
        for step in 0..steps {
            model.step(&mut s, command.command_rad(step as f32 * p.control_period_s));
            assert!(finite(&s), "{} at step {step}: {s:?}", what());
            assert!(s.current_ref_a.abs() <= p.current_limit_a, "{} at step {step}: {s:?}", what());
            let largest =
                [s.current_a, s.output_current_a].iter().chain(&s.phase_current_a).fold(0.0f32, |m, i| m.max(i.abs()));
            assert!(largest <= bound, "{} at step {step}: {largest} A above {bound} A: {s:?}", what());
            peak = peak.max(largest);
        }
        // the fitness's view: block means of the expected measured envelope
        let mut blocks = 0;
        simulate_window_with_effects(&p, &profile, k, effects, window, |i, value, _| {
            assert!(value.is_finite() && value.abs() <= envelope_bound, "{} block {i}: {value} A", what());
            envelope_peak = envelope_peak.max(value.abs());
            blocks += 1;
            true
        });
        assert_eq!(blocks, window);
    }
    eprintln!(
        "{} cases: peak current {peak} A (bound {bound} A), peak envelope {envelope_peak} A (bound {envelope_bound} A)",
        cases.len()
    );
}
