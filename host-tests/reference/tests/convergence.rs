//! Step-size convergence study that justifies `DEFAULT_STEP_S` = 0.25 µs.
//!
//! The standard profile is run at dt = 1, 0.5 and 0.25 µs and at 0.05 µs (the "finest" run) with
//! noise and quantization off (the 16-bit position code, amplified by the derivative term — one
//! code is 0.46 A of `Kd·D` — makes the closed loop hop between neighbouring trajectories and
//! would measure the sensor, not the integrator). Compared with the finest run:
//! * the true surface angle,
//! * the **sampled** equivalent current `½Σ|i_j|` of the recorded phase currents (what the monitor
//!   reads, ripple and all) in 2 ms means (the monitor's smoothing, `discover::SMOOTH_BLOCKS`),
//!   after the fast reversal (t ≥ 0.32 s): there the loop is not chaotic, so what differs is the
//!   integrator.
//!
//! Why not 1 µs: the hysteresis comparators switch on the step grid, the ripple's switching
//! instants lock to it and to the 100 µs sample period, and the samples alias the ripple into the
//! 2 ms means: 0.040 A RMS off the finest run after 0.32 s, 7× the 0.25 µs step's 0.0055 A and
//! twice the monitor model's whole mismatch with the actuator. Per-period means of every step hide
//! that aliasing, so the study compares the sampled current (`docs/decisions/0004-reference-step.md`;
//! the `reference_step` investigation prints the table for any steps).
//!
//! Tolerance: the chosen step's sampled 2 ms means within 0.01 A of the finest run's (a quarter
//! of the sensor noise of a 2 ms mean, 0.045 A) and at most half the 1 µs step's difference; the
//! surface angle within 10 % of the healthy floor's 3.4e-4 rad. The energy-balance residual must
//! fall roughly in proportion to dt (first-order method).

use ema_reference::analysis::{equivalent_current_magnitude, moving_average, rms_difference};
use ema_reference::{simulate, Recording, SimConfig, DEFAULT_STEP_S};

/// Samples in 2 ms at the 10 kHz ACE rate.
const MEAN_SAMPLES: usize = 20;
/// Start of the slow part of the standard profile, after the fast reversal.
const SLOW_FROM_S: f64 = 0.32;

fn run(dt: f64) -> Recording {
    simulate(&SimConfig { noise: false, quantization: false, step_s: dt, ..SimConfig::default() }).expect("valid")
}

fn angle(r: &Recording) -> Vec<f64> {
    r.truth.iter().map(|t| t.surface_angle_rad).collect()
}

/// The sampled `½Σ|i_j|` in 2 ms means, from [`SLOW_FROM_S`] on.
fn sampled_current(r: &Recording) -> Vec<f64> {
    let sampled: Vec<f64> = r.samples.iter().map(|s| equivalent_current_magnitude(s.phase_current_a, 1.0)).collect();
    let means = moving_average(&sampled, MEAN_SAMPLES);
    r.samples.iter().zip(means).filter(|(s, _)| s.time_s >= SLOW_FROM_S).map(|(_, m)| m).collect()
}

#[test]
fn chosen_step_is_converged() {
    assert_eq!(DEFAULT_STEP_S, 0.25e-6);
    let fine = run(0.05e-6);
    let old = run(1.0e-6);
    let half = run(0.5e-6);
    let chosen = run(DEFAULT_STEP_S);
    let d_pos = [&old, &half, &chosen].map(|r| rms_difference(&angle(r), &angle(&fine)));
    let d_i = [&old, &half, &chosen].map(|r| rms_difference(&sampled_current(r), &sampled_current(&fine)));
    let report = format!(
        "position RMS diff: 1 µs {:.3e}, 0.5 µs {:.3e}, 0.25 µs {:.3e} rad; \
         sampled ½Σ|i| 2 ms means after {SLOW_FROM_S} s: 1 µs {:.4}, 0.5 µs {:.4}, 0.25 µs {:.4} A",
        d_pos[0], d_pos[1], d_pos[2], d_i[0], d_i[1], d_i[2]
    );
    println!("{report}");
    assert!(d_i[2] < 0.01, "{report}");
    assert!(d_i[2] < 0.5 * d_i[0], "{report}");
    assert!(d_pos[2] < 0.1 * 3.4e-4, "{report}");

    let res = [&old, &half, &chosen].map(|r| r.energy.residual_j().abs());
    let e_in = fine.energy.electrical_in_j;
    assert!(res[0] > 1.5 * res[1] && res[1] > 1.5 * res[2], "energy residuals {res:?} J");
    assert!(res[2] < 1e-3 * e_in, "energy residual at 0.25 µs {} of {e_in} J", res[2]);
}
