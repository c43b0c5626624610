//! Actuator control electronics: the PID position loop (docs/model.md), identical in the monitor model.
//!
//! Sampled every `T` at `t_k = k·T`, output held (ZOH) until the next sample:
//! ```text
//! e   = θ_cmd(t_k) − θ_meas,k
//! D_k = D_{k−1} + (T/τ_D)·((θ_meas,k − θ_meas,k−1)/T − D_{k−1})      (D_0 = 0, θ_meas,−1 = θ_meas,0)
//! I  += e·T
//! u   = Kp·e + Ki·I − Kd·D_k
//! |u| > I_max → I −= e·T;  u = Kp·e + Ki·I − Kd·D_k                 (conditional integration)
//! I_ref = clamp(u, −I_max, +I_max)
//! ```

/// PID state and gains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ace {
    kp: f64,
    ki: f64,
    kd: f64,
    period_s: f64,
    filter_s: f64,
    limit_a: f64,
    integral: f64,
    derivative: f64,
    previous: Option<f64>,
}

impl Ace {
    /// Controller with gains `Kp`, `Ki`, `Kd`, period `T`, derivative filter `τ_D` and limit `I_max`.
    pub fn new(kp: f64, ki: f64, kd: f64, period_s: f64, filter_s: f64, limit_a: f64) -> Self {
        Self { kp, ki, kd, period_s, filter_s, limit_a, integral: 0.0, derivative: 0.0, previous: None }
    }

    /// One sample: command and measured position in, current reference out.
    pub fn update(&mut self, command_rad: f64, measured_rad: f64) -> f64 {
        let t = self.period_s;
        let e = command_rad - measured_rad;
        let prev = self.previous.unwrap_or(measured_rad);
        self.derivative += (t / self.filter_s) * ((measured_rad - prev) / t - self.derivative);
        self.previous = Some(measured_rad);
        self.integral += e * t;
        let mut u = self.kp * e + self.ki * self.integral - self.kd * self.derivative;
        if u.abs() > self.limit_a {
            self.integral -= e * t;
            u = self.kp * e + self.ki * self.integral - self.kd * self.derivative;
        }
        u.clamp(-self.limit_a, self.limit_a)
    }

    /// Integrator state `I`.
    pub fn integral(&self) -> f64 {
        self.integral
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proportional_then_saturated_then_antiwindup() {
        let mut a = Ace::new(700.0, 1500.0, 25.0, 1e-4, 1e-3, 15.0);
        // Small error: linear, P + I of one sample.
        let u = a.update(0.001, 0.0);
        assert!((u - (0.7 + 1500.0 * 1e-7)).abs() < 1e-12);
        // Large error: saturated, integrator not advanced.
        let i0 = a.integral();
        assert_eq!(a.update(0.5, 0.0), 15.0);
        assert!((a.integral() - i0).abs() < 1e-15);
        // Derivative on measurement: a measured jump pulls the output down.
        let mut b = Ace::new(0.0, 0.0, 25.0, 1e-4, 1e-3, 15.0);
        b.update(0.0, 0.0);
        let u = b.update(0.0, 1e-5);
        assert!((u - (-25.0 * 0.1 * 0.1)).abs() < 1e-12, "{u}");
    }
}
