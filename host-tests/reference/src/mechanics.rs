//! Motor, gearbox and surface mechanics (docs/model.md): Borello dry friction with the
//! load-dependent term, viscous friction, hinge load, backlash, end stops; rigid (1-DOF, play operator)
//! or compliant (2-DOF, dead-zone spring) transmission.
//!
//! Rigid, at the motor shaft (`J_eq = J_m + J_u/N²`):
//! ```text
//! J_eq·dω_m/dt = T_m + T_cog − C_m·ω_m + T_R − T_F,      T_R = −K_h·θ_u/N
//! θ_u ← clamp(θ_u, θ_m/N − BL/2, θ_m/N + BL/2)           (play operator)
//! ```
//! Compliant (surface inertia of its own, `DZ(x, b)` = dead zone of half width `b = BL/2`):
//! ```text
//! T_tr = K_tr·DZ(θ_m/N − θ_u, BL/2) + C_tr·(ω_m/N − ω_u)   in contact, never pulling
//! J_m·dω_m/dt = T_m + T_cog − C_m·ω_m − T_tr/N − T_F,     J_u·dω_u/dt = T_tr − K_h·θ_u
//! ```
//! Friction (Borello, fixed step, semi-implicit Euler; `T_R` is the load torque acting on the motor):
//! ```text
//! slipping (ω ≠ 0): d = sign(ω), T_f = FDJ + S·exp(−(ω/ω_s)²) + L(T_R, d);  ω' = ω + dt·(T_act + T_R − d·T_f)/J;
//!                   ω'·ω < 0 → ω' = 0                                   (friction stops, never reverses)
//! stuck (ω = 0):    T_n = T_act + T_R, d = sign(T_n);  |T_n| ≤ FSJ + L(T_R, d) → ω' = 0,
//!                   else ω' = dt·(T_n − d·(FDJ + S + L(T_R, d)))/J
//! L(T_R, d) = (1/η_O − 1)·|T_R| if T_R·d < 0 (load opposing), else (1 − η_A)·|T_R|
//! ```
//! `S` is the Stribeck excess (0 unless the effect is on). End stops are inelastic on `θ_u`.

use crate::params::{Plant, Transmission};

/// Dry-friction law of the motor shaft.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrictionLaw {
    /// Breakaway level `FSJ`.
    pub static_n_m: f64,
    /// Sliding level `FDJ`.
    pub dynamic_n_m: f64,
    /// Stribeck excess `S` at zero speed.
    pub stribeck_excess_n_m: f64,
    /// Stribeck velocity `ω_s`.
    pub stribeck_speed_rad_per_s: f64,
    /// `η_O`.
    pub efficiency_opposing: f64,
    /// `η_A`.
    pub efficiency_aiding: f64,
}

impl FrictionLaw {
    /// The friction of `plant`.
    pub fn of(plant: &Plant) -> Self {
        Self {
            static_n_m: plant.static_friction_n_m,
            dynamic_n_m: plant.dynamic_friction_n_m,
            stribeck_excess_n_m: plant.stribeck_excess_n_m,
            stribeck_speed_rad_per_s: plant.stribeck_speed_rad_per_s,
            efficiency_opposing: plant.efficiency_opposing,
            efficiency_aiding: plant.efficiency_aiding,
        }
    }

    /// Load-dependent term `L(T_R, d)`.
    pub fn load_term(&self, load_n_m: f64, direction: f64) -> f64 {
        if load_n_m * direction < 0.0 {
            (1.0 / self.efficiency_opposing - 1.0) * load_n_m.abs()
        } else {
            (1.0 - self.efficiency_aiding) * load_n_m.abs()
        }
    }

    /// Sliding friction at speed `omega` (without the load term).
    pub fn sliding(&self, omega: f64) -> f64 {
        if self.stribeck_excess_n_m > 0.0 {
            let r = omega / self.stribeck_speed_rad_per_s;
            self.dynamic_n_m + self.stribeck_excess_n_m * (-r * r).exp()
        } else {
            self.dynamic_n_m
        }
    }

    /// One Borello step: the new speed from `omega`, the active torque `t_act`, the load torque on the
    /// motor `t_load`, the inertia and the step. Returns `(ω', stop)` where `stop` is `true` when
    /// friction forced the speed to zero (or kept it there).
    pub fn step(&self, omega: f64, t_act: f64, t_load: f64, inertia: f64, dt: f64) -> (f64, bool) {
        if omega != 0.0 {
            let d = omega.signum();
            let t_f = self.sliding(omega) + self.load_term(t_load, d);
            let next = omega + dt * (t_act + t_load - d * t_f) / inertia;
            if next * omega < 0.0 {
                (0.0, true)
            } else {
                (next, false)
            }
        } else {
            let t_n = t_act + t_load;
            let d = if t_n > 0.0 {
                1.0
            } else if t_n < 0.0 {
                -1.0
            } else {
                return (0.0, true);
            };
            let load = self.load_term(t_load, d);
            if t_n.abs() <= self.static_n_m + load {
                (0.0, true)
            } else {
                let t_f = self.sliding(0.0) + load;
                (dt * (t_n - d * t_f) / inertia, false)
            }
        }
    }
}

/// Mechanical state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mechanics {
    /// Motor angle `θ_m`.
    pub motor_angle_rad: f64,
    /// Motor speed `ω_m`.
    pub motor_speed_rad_per_s: f64,
    /// Surface angle `θ_u`.
    pub surface_angle_rad: f64,
    /// Surface speed `ω_u` (rigid: `ω_m/N` in contact, 0 inside the gap).
    pub surface_speed_rad_per_s: f64,
}

/// Energy flows of one mechanical step (joules).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MechanicalEnergy {
    /// `T_m·ω_mid·dt`: work of the electromagnetic torque.
    pub motor_work_j: f64,
    /// Work of the cogging torque on the rotor (conservative: minus its potential change).
    pub cogging_work_j: f64,
    /// `C_m·ω·ω_mid·dt`.
    pub viscous_loss_j: f64,
    /// Work dissipated by dry friction (law value while sliding; the remainder of the step when friction stops the shaft).
    pub friction_loss_j: f64,
    /// Work delivered to the hinge load: rigid model `−T_R·ω_mid·dt` through the gear (also inside the
    /// gap, as the play operator reflects the load there too); compliant model the change of `½K_h θ_u²`.
    pub load_work_j: f64,
    /// Kinetic energy destroyed by the inelastic end stops.
    pub end_stop_loss_j: f64,
    /// Compliant model: energy dissipated by the transmission damper.
    pub transmission_loss_j: f64,
}

/// Inputs of one mechanical step.
#[derive(Clone, Copy, Debug)]
pub struct MechanicalInputs {
    /// Electromagnetic torque `T_m`.
    pub motor_torque_n_m: f64,
    /// Cogging torque `T_cog`.
    pub cogging_torque_n_m: f64,
}

impl Mechanics {
    /// At rest at zero.
    pub fn new() -> Self {
        Self::default()
    }

    /// Torque of the hinge on the surface, `K_h·θ_u` (positive pushes the surface negative).
    pub fn hinge_moment_n_m(&self, plant: &Plant) -> f64 {
        plant.hinge_stiffness_n_m_per_rad * self.surface_angle_rad
    }

    /// Transmission torque of the compliant model at the current state.
    pub fn transmission_torque_n_m(&self, plant: &Plant, tr: &Transmission) -> f64 {
        let n = plant.gear_ratio;
        let b = 0.5 * plant.backlash_rad;
        let delta = self.motor_angle_rad / n - self.surface_angle_rad;
        let rate = self.motor_speed_rad_per_s / n - self.surface_speed_rad_per_s;
        if delta > b {
            (tr.stiffness_n_m_per_rad * (delta - b) + tr.damping_n_m_s_per_rad * rate).max(0.0)
        } else if delta < -b {
            (tr.stiffness_n_m_per_rad * (delta + b) + tr.damping_n_m_s_per_rad * rate).min(0.0)
        } else {
            0.0
        }
    }

    /// Spring energy of the compliant transmission, `½·K_tr·DZ²`.
    pub fn transmission_energy_j(&self, plant: &Plant) -> f64 {
        let Some(tr) = plant.transmission else { return 0.0 };
        let b = 0.5 * plant.backlash_rad;
        let delta = self.motor_angle_rad / plant.gear_ratio - self.surface_angle_rad;
        let dz = if delta > b {
            delta - b
        } else if delta < -b {
            delta + b
        } else {
            0.0
        };
        0.5 * tr.stiffness_n_m_per_rad * dz * dz
    }

    /// Kinetic energy (rigid: `½ J_eq ω_m²`; compliant: `½ J_m ω_m² + ½ J_u ω_u²`).
    pub fn kinetic_energy_j(&self, plant: &Plant) -> f64 {
        let w = self.motor_speed_rad_per_s;
        match plant.transmission {
            None => 0.5 * plant.equivalent_inertia_kg_m2() * w * w,
            Some(_) => {
                let wu = self.surface_speed_rad_per_s;
                0.5 * plant.motor_inertia_kg_m2 * w * w + 0.5 * plant.surface_inertia_kg_m2 * wu * wu
            }
        }
    }

    /// Energy stored in the hinge "spring", `½ K_h θ_u²`.
    pub fn hinge_energy_j(&self, plant: &Plant) -> f64 {
        0.5 * plant.hinge_stiffness_n_m_per_rad * self.surface_angle_rad * self.surface_angle_rad
    }

    /// Advances the mechanics by `dt`.
    pub fn step(&mut self, plant: &Plant, friction: &FrictionLaw, u: &MechanicalInputs, dt: f64) -> MechanicalEnergy {
        match plant.transmission {
            None => self.step_rigid(plant, friction, u, dt),
            Some(tr) => self.step_compliant(plant, &tr, friction, u, dt),
        }
    }

    fn motor_side(
        &mut self,
        friction: &FrictionLaw,
        u: &MechanicalInputs,
        viscous: f64,
        t_load: f64,
        inertia: f64,
        dt: f64,
    ) -> (f64, MechanicalEnergy) {
        let mut e = MechanicalEnergy::default();
        let w = self.motor_speed_rad_per_s;
        let t_visc = viscous * w;
        let t_act = u.motor_torque_n_m + u.cogging_torque_n_m - t_visc;
        let (next, stop) = friction.step(w, t_act, t_load, inertia, dt);
        let mid = 0.5 * (w + next);
        e.motor_work_j = u.motor_torque_n_m * mid * dt;
        e.cogging_work_j = u.cogging_torque_n_m * mid * dt;
        e.viscous_loss_j = t_visc * mid * dt;
        e.friction_loss_j = if stop {
            // Friction took what the other torques did not: the work balance of this step.
            (t_act + t_load) * mid * dt - 0.5 * inertia * (next * next - w * w)
        } else {
            let d = w.signum();
            let d = if d == 0.0 { next.signum() } else { d };
            (friction.sliding(w) + friction.load_term(t_load, d)) * mid.abs() * dt
        };
        self.motor_speed_rad_per_s = next;
        self.motor_angle_rad += next * dt;
        (mid, e)
    }

    fn step_rigid(&mut self, plant: &Plant, friction: &FrictionLaw, u: &MechanicalInputs, dt: f64) -> MechanicalEnergy {
        let n = plant.gear_ratio;
        let j_eq = plant.equivalent_inertia_kg_m2();
        let t_load = -self.hinge_moment_n_m(plant) / n;
        let (mid, mut e) = self.motor_side(friction, u, plant.viscous_friction_n_m_s_per_rad, t_load, j_eq, dt);
        e.load_work_j = -t_load * mid * dt;
        let x = self.motor_angle_rad / n;
        let b = 0.5 * plant.backlash_rad;
        let before = self.surface_angle_rad;
        self.surface_angle_rad = self.surface_angle_rad.clamp(x - b, x + b);
        let lim = plant.end_stop_rad;
        if self.surface_angle_rad.abs() > lim {
            let side = self.surface_angle_rad.signum();
            self.surface_angle_rad = side * lim;
            // The gear output is held by the surface at the stop.
            self.motor_angle_rad = n * (side * lim + side * b);
            if self.motor_speed_rad_per_s * side > 0.0 {
                e.end_stop_loss_j = 0.5 * j_eq * self.motor_speed_rad_per_s * self.motor_speed_rad_per_s;
                self.motor_speed_rad_per_s = 0.0;
            }
        }
        self.surface_speed_rad_per_s = (self.surface_angle_rad - before) / dt;
        e
    }

    fn step_compliant(
        &mut self,
        plant: &Plant,
        tr: &Transmission,
        friction: &FrictionLaw,
        u: &MechanicalInputs,
        dt: f64,
    ) -> MechanicalEnergy {
        let n = plant.gear_ratio;
        let t_tr = self.transmission_torque_n_m(plant, tr);
        let spring_before = self.transmission_energy_j(plant);
        let wu = self.surface_speed_rad_per_s;
        let t_hinge = self.hinge_moment_n_m(plant);
        let (mid_m, mut e) = self.motor_side(
            friction,
            u,
            plant.viscous_friction_n_m_s_per_rad,
            -t_tr / n,
            plant.motor_inertia_kg_m2,
            dt,
        );
        let hinge_before = self.hinge_energy_j(plant);
        let mut wu_next = wu + dt * (t_tr - t_hinge) / plant.surface_inertia_kg_m2;
        self.surface_angle_rad += wu_next * dt;
        let lim = plant.end_stop_rad;
        if self.surface_angle_rad.abs() > lim {
            let side = self.surface_angle_rad.signum();
            self.surface_angle_rad = side * lim;
            if wu_next * side > 0.0 {
                e.end_stop_loss_j = 0.5 * plant.surface_inertia_kg_m2 * wu_next * wu_next;
                wu_next = 0.0;
            }
        }
        self.surface_speed_rad_per_s = wu_next;
        e.load_work_j = self.hinge_energy_j(plant) - hinge_before;
        let mid_u = 0.5 * (wu + wu_next);
        // Work into the transmission from the motor side minus work out to the surface, minus the spring's gain.
        let work_in = t_tr * (mid_m / n - mid_u) * dt;
        e.transmission_loss_j = work_in - (self.transmission_energy_j(plant) - spring_before);
        e
    }
}
