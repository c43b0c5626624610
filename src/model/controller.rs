//! The actuator control electronics (ACE) as the monitor model runs it: the position transducer's
//! lag and the PID position loop with conditional-integration anti-windup, the same algorithm as
//! the real controller.
//!
//! ```text
//! transducer  θ_meas⁺ = θ_u⁺ − m·τ_θ + e^{−T/τ_θ}(θ_meas − θ_u + m·τ_θ),  m = (θ_u⁺ − θ_u)/T
//! PID         e = θ_cmd − θ_meas;  D += (T/τ_D)((θ_meas − θ_meas,prev)/T − D);  I_int += e·T
//!             u = Kp·e + Ki·I_int − Kd·D   (derivative on measurement)
//! anti-windup |u| > I_max ⇒ I_int −= e·T and u recomputed (conditional integration)
//!             I_ref = clamp(u, ±I_max)
//! ```

use super::{clamp, ModelState, MonitorModel};

impl MonitorModel {
    /// The controller (ACE): returns `I_ref` for the coming period, from the measured position.
    pub fn control(&self, s: &mut ModelState, command_rad: f32, position_rad: f32) -> f32 {
        let dt = self.dt_s;
        let e = command_rad - position_rad;
        s.derivative_rad_per_s +=
            self.derivative_gain * ((position_rad - s.previous_position_rad) * self.inv_dt - s.derivative_rad_per_s);
        s.previous_position_rad = position_rad;
        s.integral_rad_s += e * dt;
        let mut u = self.kp * e + self.ki * s.integral_rad_s - self.kd * s.derivative_rad_per_s;
        if libm::fabsf(u) > self.current_limit_a {
            s.integral_rad_s -= e * dt;
            u = self.kp * e + self.ki * s.integral_rad_s - self.kd * s.derivative_rad_per_s;
        }
        s.current_ref_a = clamp(u, -self.current_limit_a, self.current_limit_a);
        s.current_ref_a
    }

    /// The position transducer's first-order lag `τ_θ` over the step, exact for the surface angle
    /// linear between `surface_start_rad` and the state's new surface angle.
    #[inline(always)]
    pub(super) fn measure_position(&self, s: &mut ModelState, surface_start_rad: f32) {
        let lag_ramp_rad = self.position_lag_ramp * (s.surface_angle_rad - surface_start_rad);
        s.measured_position_rad = s.surface_angle_rad - lag_ramp_rad
            + self.position_lag_factor * (s.measured_position_rad - surface_start_rad + lag_ramp_rad);
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::model;
    use super::*;

    #[test]
    fn gain_drift_changes_the_step_response() {
        let run = |gain: f32| {
            let m = model([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, gain]);
            let mut s = ModelState::at_rest();
            let mut err = 0.0;
            for _ in 0..1500 {
                m.step(&mut s, 0.01); // small step: stays in the linear range of the loop
                err += libm::fabsf(0.01 - s.surface_angle_rad);
            }
            err
        };
        assert!(run(0.1) > 1.2 * run(0.5), "a lower gain tracks worse");
    }

    #[test]
    fn the_integrator_stops_while_the_output_saturates() {
        let m = model(crate::faults::FaultVector::HEALTHY.0);
        let mut s = ModelState::at_rest();
        // a 0.5 rad error asks Kp·0.5 = 350 A ≫ I_max: the integrator must not wind up
        for _ in 0..10 {
            assert_eq!(m.control(&mut s, 0.5, 0.0), 15.0);
        }
        assert_eq!(s.integral_rad_s, 0.0);
    }
}
