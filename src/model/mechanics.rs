//! Mechanics of the monitor model: the torque balance at the motor shaft with Borello's dry
//! friction, the rotor's kinematics, the gear's backlash and the surface's end stops.
//!
//! ```text
//! load    T_R = −K_h·θ_u/N                          (hinge moment at the motor)
//! balance J·dω/dt = T_m − C_m·ω + T_R − friction    (Borello: stick/slip, load-dependent)
//! rotor   θ_m += ½(ω + ω⁺)·T,  θ_H += p·½(ω + ω⁺)·T (the trapezoid rule)
//! play    θ_u = clamp(θ_u, θ_m/N − BL/2, θ_m/N + BL/2);  end stops ±θ_max
//! ```
//!
//! Borello's friction model (the paper's): the dry friction opposes the motion with
//! `F_D + load term` while slipping and holds the shaft until the net torque passes
//! `F_S + load term`; the load term is `|T_R|·(1/η_O − 1)` when the load opposes the motion and
//! `|T_R|·(1 − η_A)` when it aids it.

use super::{clamp, sign, ModelState, MonitorModel};
use crate::six_step::wrap;

impl MonitorModel {
    /// The mechanical part of a step driven by the step's motor torque `torque_motor`, from the
    /// speed `w` at the step's start: the friction step, the rotor angle, Hall angle and phasor,
    /// then the play and the end stops on the surface.
    #[inline(always)]
    pub(super) fn mechanical_step<const EFFECTS: bool>(&self, s: &mut ModelState, torque_motor: f32, w: f32) {
        let torque_load = -self.hinge_at_motor_n_m_per_rad * s.surface_angle_rad;
        let mut torque_active = torque_motor - self.viscous_n_m_s * w;
        if EFFECTS && self.step_terms.cogging_torque_n_m != 0.0 {
            torque_active += self.cogging_n_m(s.motor_angle_wrapped_rad, w);
        }
        let w_new = self.friction_step_with::<EFFECTS>(w, torque_active, torque_load);
        s.motor_speed_rad_s = w_new;
        let d_theta = 0.5 * (w + w_new) * self.dt_s;
        s.motor_angle_rad += d_theta;
        s.motor_angle_wrapped_rad = wrap(s.motor_angle_wrapped_rad + d_theta);
        if self.eccentricity > 0.0 {
            s.rotor_phasor = rotate(s.rotor_phasor, d_theta);
        }
        s.hall_angle_rad = wrap(s.hall_angle_rad + self.pole_pairs * d_theta);

        // Backlash (play operator) and end stops on the surface.
        let x = s.motor_angle_rad / self.gear_ratio;
        s.surface_angle_rad = clamp(s.surface_angle_rad, x - self.half_backlash_rad, x + self.half_backlash_rad);
        if s.surface_angle_rad > self.end_stop_rad {
            s.surface_angle_rad = self.end_stop_rad;
            s.motor_angle_rad = s.motor_angle_rad.min((self.end_stop_rad + self.half_backlash_rad) * self.gear_ratio);
            if s.motor_speed_rad_s > 0.0 {
                s.motor_speed_rad_s = 0.0;
            }
        } else if s.surface_angle_rad < -self.end_stop_rad {
            s.surface_angle_rad = -self.end_stop_rad;
            s.motor_angle_rad = s.motor_angle_rad.max(-(self.end_stop_rad + self.half_backlash_rad) * self.gear_ratio);
            if s.motor_speed_rad_s < 0.0 {
                s.motor_speed_rad_s = 0.0;
            }
        }
    }

    /// Sliding friction without the load term: `FDJ`, plus the Stribeck excess `S·exp(−ω²/ω_s²)`
    /// when that effect is on (negligible, < 1e-7·S, and skipped beyond `4ω_s`).
    pub(super) fn sliding_friction_n_m<const EFFECTS: bool>(&self, w: f32) -> f32 {
        let fx = &self.step_terms;
        if !EFFECTS || fx.stribeck_excess_n_m == 0.0 {
            return self.dynamic_friction_n_m;
        }
        let r2 = w * w * fx.stribeck_inv_speed_sq_s2;
        if r2 < 16.0 {
            self.dynamic_friction_n_m + fx.stribeck_excess_n_m * libm::expf(-r2)
        } else {
            self.dynamic_friction_n_m
        }
    }

    /// Borello dry friction: the four cases stuck/breakaway/slip/stop. `torque_active` = motor
    /// torque minus viscous; `torque_load` = load reflected to the motor. The motor is stuck only
    /// when `ω` is exactly 0. A slip step that would reverse `ω` reaches 0 at the fraction
    /// `f = ω/(ω − ω⁺)` of the step; there the breakaway decides as from rest, over the step's
    /// remaining `1 − f`: the motor stays stopped when `|T_net|` does not pass it, and otherwise
    /// leaves the other way, `ω⁺ = (1 − f)·T/J·(T_net − d·(F_D + load))`. (Stopping for the rest
    /// of the step instead would lose up to a whole control period at every driven reversal, a
    /// loss that jumps by a period as any parameter moves the zero crossing across a step
    /// boundary: the fast reversal's rotor angle, and the commutation ripple after it, would then
    /// jump with it.)
    pub fn friction_step(&self, w: f32, torque_active: f32, torque_load: f32) -> f32 {
        if self.step_terms.on {
            self.friction_step_with::<true>(w, torque_active, torque_load)
        } else {
            self.friction_step_with::<false>(w, torque_active, torque_load)
        }
    }

    /// [`MonitorModel::friction_step`] with (`EFFECTS`) or without the Stribeck term.
    #[inline(always)]
    fn friction_step_with<const EFFECTS: bool>(&self, w: f32, torque_active: f32, torque_load: f32) -> f32 {
        let dt_over_j = self.dt_over_j;
        let load_term = |direction: f32| -> f32 {
            let opposing = torque_load * direction < 0.0;
            libm::fabsf(torque_load) * if opposing { self.opposing_load_factor } else { self.aiding_load_factor }
        };
        let net = torque_active + torque_load;
        // The part of the step left from rest: all of it when stuck at its start; what remains
        // after `ω` reaches 0 when a slip step would reverse it.
        let mut from_rest = 1.0;
        if w != 0.0 {
            let d = sign(w);
            let friction = self.sliding_friction_n_m::<EFFECTS>(w) + load_term(d);
            let w_new = w + dt_over_j * (net - d * friction);
            if w_new * w >= 0.0 {
                return w_new;
            }
            // ω passes 0 at the fraction w/(w − w_new) of the step
            from_rest = w_new / (w_new - w);
        }
        let d = sign(net);
        let breakaway = self.static_friction_n_m + load_term(d);
        if libm::fabsf(net) <= breakaway {
            0.0
        } else {
            let friction = self.sliding_friction_n_m::<EFFECTS>(0.0) + load_term(d);
            from_rest * dt_over_j * (net - d * friction)
        }
    }
}

/// The unit phasor `(cos θ, sin θ)` turned by a step's small angle `δ` (|δ| ≤ 0.1 rad: ≤ 1000 rad/s
/// at 100 µs):
///
/// ```text
/// sin δ ≈ δ(1 − δ²/6),  cos δ ≈ 1 − δ²(1/2 − δ²/24)     (truncation < δ⁵/120 ≤ 1e-7)
/// (c, s) ← (c cos δ − s sin δ, s cos δ + c sin δ)·g,  g = (3 − |·|²)/2
/// ```
///
/// `g` (one Newton step towards `|·| = 1`) keeps the rounding from growing the modulus over the
/// ~10⁴ steps of a run. A third of the cost of a sine and cosine, and exact IEEE `+ − ×` only.
#[cfg_attr(not(target_os = "none"), inline)]
fn rotate((c, s): (f32, f32), delta_rad: f32) -> (f32, f32) {
    let d2 = delta_rad * delta_rad;
    let sin_d = delta_rad * (1.0 - d2 * (1.0 / 6.0));
    let cos_d = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0));
    let (c, s) = (c * cos_d - s * sin_d, s * cos_d + c * sin_d);
    let g = 1.5 - 0.5 * (c * c + s * s);
    (c * g, s * g)
}

#[cfg(test)]
mod tests {
    use super::super::tests::{model, with_effect};
    use super::*;
    use crate::effects::EffectId;
    use crate::faults::FaultVector;

    #[test]
    fn the_rotor_phasor_follows_the_angle_over_a_long_run() {
        // 10⁵ steps of |δ| ≤ 0.1 rad, both ways: ten times a standard run, at twice its top speed.
        let (mut phasor, mut theta) = ((1.0f32, 0.0f32), 0.0f64);
        let mut worst = 0.0f32;
        for k in 0..100_000u32 {
            let delta = 0.1 * libm::sinf(k as f32 * 1e-3) * if k % 7 == 0 { -0.3 } else { 1.0 };
            phasor = rotate(phasor, delta);
            theta += delta as f64;
            let (c, s) = (libm::cos(theta) as f32, libm::sin(theta) as f32);
            worst = worst.max((phasor.0 - c).abs()).max((phasor.1 - s).abs());
        }
        // (an f32 wrapped angle drifts as much: ~4e-7 of rounding per step)
        assert!(worst < 1e-4, "phasor drifted by {worst}");
        let modulus = phasor.0 * phasor.0 + phasor.1 * phasor.1;
        assert!((modulus - 1.0).abs() < 1e-6, "modulus² {modulus}");
    }

    #[test]
    fn the_rotor_advances_by_the_mean_of_its_start_and_end_speeds() {
        // Accelerating from rest at the current limit: each step's angle is the trapezoid of the
        // speeds; ω⁺·T (semi-implicit) would put the rotor ½ω·T ahead, 0.16 rad electrical at
        // 800 rad/s.
        let m = model(FaultVector::HEALTHY.0);
        let mut s = ModelState::at_rest();
        let mut lead_rad = 0.0f32;
        for _ in 0..40 {
            let (w, angle) = (s.motor_speed_rad_s, s.motor_angle_rad);
            m.step(&mut s, 0.3);
            let step_rad = s.motor_angle_rad - angle;
            assert!((step_rad - 0.5 * (w + s.motor_speed_rad_s) * m.dt_s()).abs() < 1e-6, "{step_rad}");
            lead_rad += s.motor_speed_rad_s * m.dt_s() - step_rad;
        }
        assert!(s.motor_speed_rad_s > 50.0, "{}", s.motor_speed_rad_s);
        assert!((lead_rad - 0.5 * s.motor_speed_rad_s * m.dt_s()).abs() < 1e-3, "{lead_rad}");
    }

    #[test]
    fn friction_stick_slip_cases() {
        let m = model(FaultVector::HEALTHY.0); // FSJ 0.10, FDJ 0.07 N·m
        let dt_over_j = m.dt_over_j;
        // 1. stuck, below breakaway: stays stuck
        assert_eq!(m.friction_step(0.0, 0.09, 0.0), 0.0);
        assert_eq!(m.friction_step(0.0, -0.099, 0.0), 0.0);
        // 2. stuck, above breakaway: moves with the sliding friction
        let w = m.friction_step(0.0, 0.2, 0.0);
        assert!((w - dt_over_j * (0.2 - 0.07)).abs() < 1e-6, "{w}");
        // 3. slipping keeps slipping, friction opposes the motion
        let w = m.friction_step(10.0, 0.0, 0.0);
        assert!((w - (10.0 - dt_over_j * 0.07)).abs() < 1e-4, "{w}");
        // 4. slipping that would reverse, with a torque below breakaway: stops exactly at zero
        assert_eq!(m.friction_step(0.01, -0.09, 0.0), 0.0);
        // 5. driven through zero: stops at the fraction f of the step, then leaves the other way
        //    over the remaining 1 − f with the sliding friction reversed
        let (w0, net) = (0.01, -1.0);
        let w_slip = w0 + dt_over_j * (net - 0.07);
        let f = w0 / (w0 - w_slip);
        let w = m.friction_step(w0, net, 0.0);
        assert!(w < 0.0, "{w}");
        assert!((w - (1.0 - f) * dt_over_j * (net + 0.07)).abs() < 1e-6, "{w}");
        // the crossing's place in the step moves the speed continuously: no jump of a period
        // (crossing at the step's start: a whole step the other way; at its end: almost nothing)
        let decel = dt_over_j * (0.07 - net);
        let (early, late) = (m.friction_step(1e-6, net, 0.0), m.friction_step(0.999 * decel, net, 0.0));
        assert!((early - dt_over_j * (net + 0.07)).abs() < 1e-4, "{early}");
        assert!(late < 0.0 && late > 0.01 * dt_over_j * (net + 0.07), "{late}");
        // load-dependent: an opposing load raises the breakaway by (1/η_O − 1)|T_R|
        let opposing = 0.3; // load pushes negative (−0.3), motor pushes positive
        let net_needed = 0.10 + (1.0 / 0.85 - 1.0) * opposing;
        assert_eq!(m.friction_step(0.0, opposing + net_needed - 1e-4, -opposing), 0.0);
        assert!(m.friction_step(0.0, opposing + net_needed + 1e-3, -opposing) > 0.0);
    }

    #[test]
    fn stribeck_doubles_the_breakaway_and_decays_to_the_sliding_level() {
        let m = with_effect(FaultVector::HEALTHY.0, EffectId::Stribeck, 1.0); // FSJ 0.10, FDJ 0.07
        assert!((m.static_friction_n_m - 0.20).abs() < 1e-6);
        assert!((m.sliding_friction_n_m::<true>(0.0) - 0.20).abs() < 1e-6, "FDJ + S = 2·FSJ at rest");
        assert!((m.sliding_friction_n_m::<true>(5.0) - (0.07 + 0.13 * libm::expf(-1.0))).abs() < 1e-6);
        assert_eq!(m.sliding_friction_n_m::<true>(-30.0), 0.07);
        // 0.15 N·m breaks the healthy shaft loose, not the one with stiction
        assert_eq!(m.friction_step(0.0, 0.15, 0.0), 0.0);
        assert!(model(FaultVector::HEALTHY.0).friction_step(0.0, 0.15, 0.0) > 0.0);
    }
}
