//! Shared helpers of the reference-model tests: test profiles, runs, signal metrics.
#![allow(dead_code)]

use ema_monitor::profile::Segment;
use ema_monitor::{FaultVector, Profile};
use ema_reference::analysis::{equivalent_current_magnitude, mean, window};
use ema_reference::{simulate, Effects, Recording, SimConfig};

/// Loaded ramp: 0 → 0.45 rad at 1 rad/s (motor ≈ 500 rad/s against a growing hinge load), then hold.
pub fn loaded_ramp() -> Profile {
    Profile::new(
        &[
            Segment::Hold { start_s: 0.0, value_rad: 0.0 },
            Segment::Ramp { start_s: 0.01, start_rad: 0.0, rate_rad_per_s: 1.0 },
            Segment::Hold { start_s: 0.46, value_rad: 0.45 },
        ],
        0.6,
        0.6,
    )
    .expect("valid profile")
}

/// Slow ramp: 0.04 rad/s at the surface (motor ≈ 20 rad/s), for low-speed ripple and stick-slip.
pub fn slow_ramp() -> Profile {
    Profile::new(
        &[
            Segment::Hold { start_s: 0.0, value_rad: 0.0 },
            Segment::Ramp { start_s: 0.01, start_rad: 0.0, rate_rad_per_s: 0.04 },
        ],
        0.5,
        0.6,
    )
    .expect("valid profile")
}

/// Mirror-symmetric steps −0.05 → +0.05 → −0.05 rad (the hinge load is symmetric about 0).
pub fn symmetric_steps() -> Profile {
    Profile::new(
        &[
            Segment::Hold { start_s: 0.0, value_rad: -0.05 },
            Segment::Hold { start_s: 0.15, value_rad: 0.05 },
            Segment::Hold { start_s: 0.3, value_rad: -0.05 },
        ],
        0.45,
        0.6,
    )
    .expect("valid profile")
}

/// Simulates `profile` with `faults` and `effects` (noise on, seed 1).
pub fn run(profile: Profile, faults: FaultVector, effects: Effects) -> Recording {
    simulate(&SimConfig { profile, faults, effects, ..SimConfig::default() }).expect("valid configuration")
}

/// Sample times.
pub fn times(r: &Recording) -> Vec<f64> {
    r.samples.iter().map(|s| s.time_s).collect()
}

/// Mean ACE current reference over `[a, b)`.
pub fn mean_current_ref(r: &Recording, a: f64, b: f64) -> f64 {
    let w = window(&times(r), a, b);
    mean(&r.truth[w].iter().map(|t| t.current_ref_a).collect::<Vec<_>>())
}

/// Mean measured equivalent current (magnitude form, from the recorded ADC currents) over `[a, b)`.
pub fn mean_measured_current(r: &Recording, a: f64, b: f64) -> f64 {
    let w = window(&times(r), a, b);
    mean(&r.samples[w].iter().map(|s| equivalent_current_magnitude(s.phase_current_a, 1.0)).collect::<Vec<_>>())
}

/// Largest motor speed (signed extreme with the sign of `direction`) over `[a, b)`.
pub fn peak_speed(r: &Recording, a: f64, b: f64, direction: f64) -> f64 {
    let w = window(&times(r), a, b);
    r.truth[w].iter().map(|t| t.motor_speed_rad_per_s * direction).fold(f64::MIN, f64::max)
}

/// Step metrics of the 0.01 s step to 0.05 rad of the standard profile: (t90 after the step, overshoot ratio).
pub fn step_metrics(r: &Recording) -> (f64, f64) {
    let t = times(r);
    let w = window(&t, 0.01, 0.15);
    let t90 = w.clone().find(|&k| r.samples[k].position_rad >= 0.045).map_or(f64::INFINITY, |k| t[k] - 0.01);
    let peak = r.samples[w].iter().map(|s| s.position_rad).fold(f64::MIN, f64::max);
    (t90, (peak - 0.05) / 0.05)
}

/// Instantaneous torque constant `T_m / I_3eq` (truth) with its motor angle and sector, where `|I_3eq| > min_a`.
pub fn torque_constants(r: &Recording, min_a: f64) -> Vec<(f64, f64, u8)> {
    r.truth
        .iter()
        .filter(|t| t.equivalent_current_a.abs() > min_a)
        .map(|t| (t.motor_torque_n_m / t.equivalent_current_a, t.motor_angle_rad, t.hall_sector))
        .collect()
}
