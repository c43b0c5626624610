//! Step-size convergence study that justifies `DEFAULT_STEP_S` = 1 µs.
//!
//! The standard profile is run at dt = 2, 1 and 0.5 µs with noise and quantization off (the 16-bit
//! position code, amplified by the derivative term — one code is 0.46 A of `Kd·D` — makes the
//! closed loop hop between neighbouring trajectories and would measure the sensor, not the
//! integrator). Compared with the finest run:
//! * the true surface angle,
//! * the equivalent current `½Σf_j i_j` averaged over each ACE period (every step, so without the
//!   aliasing of the hysteresis ripple) and then over 1 ms (physics.md §4.4).
//!
//! Tolerance: the chosen step must sit within 10 % of the healthy RM–MM mismatch floor of
//! physics.md §7.2 (3.4e-4 rad, 0.36 A) of the finest run, and the differences must shrink with dt.
//! The energy-balance residual must fall roughly in proportion to dt (first-order method).

use ema_reference::analysis::{moving_average, rms_difference};
use ema_reference::{simulate, Recording, SimConfig, DEFAULT_STEP_S};

fn run(dt: f64) -> Recording {
    simulate(&SimConfig { noise: false, quantization: false, step_s: dt, ..SimConfig::default() }).expect("valid")
}

fn angle(r: &Recording) -> Vec<f64> {
    r.truth.iter().map(|t| t.surface_angle_rad).collect()
}

fn current(r: &Recording) -> Vec<f64> {
    moving_average(&r.truth.iter().map(|t| t.mean_equivalent_current_a).collect::<Vec<_>>(), 10)
}

#[test]
fn chosen_step_is_converged() {
    assert_eq!(DEFAULT_STEP_S, 1.0e-6);
    let fine = run(0.5e-6);
    let mid = run(DEFAULT_STEP_S);
    let coarse = run(2.0e-6);
    let d_pos_mid = rms_difference(&angle(&mid), &angle(&fine));
    let d_pos_coarse = rms_difference(&angle(&coarse), &angle(&fine));
    let d_i_mid = rms_difference(&current(&mid), &current(&fine));
    let d_i_coarse = rms_difference(&current(&coarse), &current(&fine));
    let report = format!(
        "position RMS diff: 2 µs {d_pos_coarse:.3e}, 1 µs {d_pos_mid:.3e} rad; \
         current RMS diff: 2 µs {d_i_coarse:.4}, 1 µs {d_i_mid:.4} A"
    );
    println!("{report}");
    assert!(d_pos_coarse > d_pos_mid, "{report}");
    assert!(d_i_coarse > d_i_mid, "{report}");
    assert!(d_pos_mid < 0.1 * 3.4e-4, "{report}");
    assert!(d_i_mid < 0.1 * 0.36, "{report}");

    let res = [&coarse, &mid, &fine].map(|r| r.energy.residual_j().abs());
    let e_in = fine.energy.electrical_in_j;
    assert!(res[0] > 1.5 * res[1] && res[1] > 1.5 * res[2], "energy residuals {res:?} J");
    assert!(res[1] < 1e-3 * e_in, "energy residual at 1 µs {} of {e_in} J", res[1]);
}
