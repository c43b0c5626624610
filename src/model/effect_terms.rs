//! The optional effect terms of the monitor model ([`crate::effects`]) that are not tied to the
//! Hall sector: the parameter effects (winding temperature, viscous friction, hinge stiffness),
//! which change the model's constants, and the step terms (cogging, Stribeck friction, magnetic
//! saturation, inverter dead time), whose constants are precomputed here; plus the model's use of
//! the current loop on measured currents ([`SensorLoop`]).
//!
//! ```text
//! winding_temperature  R_j ×(1 + α·ΔT),  k_j ×(1 + β·ΔT),  ΔT = s·100 K
//! viscous              C_m += s·5e-4 N·m·s/rad
//! hinge_stiffness      K_h ×(1 + s)
//! cogging     T_cog = A·sin(24·θ_m),  A = s·0.04 N·m (θ_m from 0 at rest, as in the reference);
//!             the model uses its step mean A·sin(24θ_m + x/2)·sin(x/2)/(x/2), x = 24·ω·T
//! stribeck    breakaway FSJ·(1 + s),  sliding FDJ + S·exp(−ω²/ω_s²),  S = s·(2·FSJ − FDJ)
//! saturation  k_j ×1/(1 + (I/I_sat)²),  1/I_sat² = (s/30 A)²  (I = |I| of the conducting pair)
//! dead_time   −sign(i_j)·ΔV on both conducting phases: the pair loses 2ΔV·sign(I), ΔV = s·8 V
//! ```
//!
//! Every term is guarded by its severity being non-zero, so a model without effects runs the
//! paper's model exactly.

use super::sensor_loop::{Hold, SensorLoop};
use super::{ModelState, MonitorModel};
use crate::effects::{maxima, EffectId, ModelEffects};
use crate::faults::FaultPhysics;
use crate::params::EmaParams;
use crate::six_step::{ideal_emf_shapes, sector_phases};

/// Constants of the cogging, Stribeck, saturation and dead-time terms (0 = off), precomputed from
/// the severities (equations in the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct StepTerms {
    /// Any of the four on ([`MonitorModel::has_step_terms`]).
    pub(super) on: bool,
    /// Cogging amplitude `A`.
    pub(super) cogging_torque_n_m: f32,
    /// `24·T`: cogging phase advance per step per rad/s.
    cogging_phase_per_speed_s: f32,
    /// Stribeck excess `S` at zero speed.
    pub(super) stribeck_excess_n_m: f32,
    /// `1/ω_s²`.
    pub(super) stribeck_inv_speed_sq_s2: f32,
    /// `1/I_sat²`.
    pub(super) saturation_inv_current_sq_per_a2: f32,
    /// `2ΔV`: the pair's dead-time voltage against its current.
    pub(super) dead_time_pair_v: f32,
}

/// `params` with the parameter effects of `effects` applied (winding temperature, viscous
/// friction, hinge stiffness; the same mapping as the reference model).
pub(super) fn with_parameter_effects(params: &EmaParams, effects: &ModelEffects) -> EmaParams {
    let mut nominal = *params;
    let temperature_rise_k = effects.get(EffectId::WindingTemperature) * maxima::WINDING_TEMPERATURE_RISE_K;
    if temperature_rise_k != 0.0 {
        nominal.phase_resistance_ohm *= 1.0 + maxima::COPPER_ALPHA_PER_K * temperature_rise_k;
        nominal.phase_emf_constant_v_s_per_rad *= 1.0 + maxima::MAGNET_BETA_PER_K * temperature_rise_k;
    }
    let viscous = effects.get(EffectId::Viscous);
    if viscous != 0.0 {
        nominal.viscous_friction_n_m_s_per_rad += viscous * maxima::VISCOUS_N_M_S_PER_RAD;
    }
    let hinge = effects.get(EffectId::HingeStiffness);
    if hinge != 0.0 {
        nominal.hinge_stiffness_n_m_per_rad *= 1.0 + hinge * maxima::HINGE_STIFFNESS_GAIN;
    }
    nominal
}

impl StepTerms {
    /// The step terms of `effects` for the model of `params` with the faults `f`, and the
    /// breakaway friction `FSJ·(1 + s)` the Stribeck term raises (`FSJ` when it is off).
    pub(super) fn of(params: &EmaParams, f: &FaultPhysics, effects: &ModelEffects) -> (Self, f32) {
        let s_stribeck = effects.get(EffectId::Stribeck);
        let (static_friction_n_m, stribeck_excess_n_m) = if s_stribeck != 0.0 {
            let (fsj, fdj, gain) = (f.static_friction_n_m, f.dynamic_friction_n_m, maxima::STRIBECK_STICTION_GAIN);
            (fsj * (1.0 + s_stribeck * gain), s_stribeck * ((1.0 + gain) * fsj - fdj))
        } else {
            (f.static_friction_n_m, 0.0)
        };
        let s_saturation = effects.get(EffectId::Saturation) * (1.0 / maxima::SATURATION_CURRENT_A);
        let mut terms = Self {
            cogging_torque_n_m: effects.get(EffectId::Cogging) * maxima::COGGING_TORQUE_N_M,
            cogging_phase_per_speed_s: maxima::COGGING_CYCLES_PER_REV * params.control_period_s,
            stribeck_excess_n_m,
            stribeck_inv_speed_sq_s2: 1.0 / (maxima::STRIBECK_SPEED_RAD_PER_S * maxima::STRIBECK_SPEED_RAD_PER_S),
            saturation_inv_current_sq_per_a2: s_saturation * s_saturation,
            dead_time_pair_v: 2.0 * effects.get(EffectId::DeadTime) * maxima::DEAD_TIME_V,
            on: false,
        };
        terms.on = terms.cogging_torque_n_m != 0.0
            || terms.stribeck_excess_n_m != 0.0
            || terms.saturation_inv_current_sq_per_a2 != 0.0
            || terms.dead_time_pair_v != 0.0;
        (terms, static_friction_n_m)
    }
}

impl MonitorModel {
    /// Saturation effect: `k_j ×1/(1 + (I/I_sat)²)` with the current `I` flowing at the step's
    /// start, as the reference model's `I = ½Σ|i_j|`: the pair current, or while the phases are
    /// resolved their `½Σ|i_j|` (not the loop's lagged reference, which stays at the current limit
    /// while the fast reversal's current collapses under the back-EMF).
    pub(super) fn saturate(&self, k: &mut [f32; 3], i: f32) {
        let factor = 1.0 / (1.0 + i * i * self.step_terms.saturation_inv_current_sq_per_a2);
        for kj in k.iter_mut() {
            *kj *= factor;
        }
    }

    /// Cogging effect: the mean of `A·sin(24·θ_m)` over the step from `θ_m` at speed `ω`,
    /// `A·sin(24θ_m + x/2)·sin(x/2)/(x/2)` with `x = 24·ω·T` (the control step spans up to a third
    /// of a cogging period at full speed, where the reference model, at its 0.25 µs step, sees
    /// its mean).
    pub(super) fn cogging_n_m(&self, motor_angle_wrapped_rad: f32, w: f32) -> f32 {
        let fx = &self.step_terms;
        let half = 0.5 * fx.cogging_phase_per_speed_s * w;
        let phase = maxima::COGGING_CYCLES_PER_REV * motor_angle_wrapped_rad + half;
        let (sin_phase, _) = crate::trig::sin_cos(phase);
        let mean = if libm::fabsf(half) > 1e-3 { crate::trig::sin_cos(half).0 / half } else { 1.0 };
        fx.cogging_torque_n_m * sin_phase * mean
    }

    /// What the current loop on measured currents holds in this step (`sensor_offset` on,
    /// [`SensorLoop::hold`]), the idle phase's EMF taken at the step's midpoint. Out of line, so
    /// that the step of every other effect term does not grow with it.
    #[inline(never)]
    pub(super) fn sensor_hold(
        &self,
        sensors: &SensorLoop,
        s: &ModelState,
        k_phase: &[f32; 3],
        sector: usize,
        i_ref: f32,
        back_v: f32,
    ) -> Hold {
        let (_, _, r) = sector_phases(sector);
        let w = s.motor_speed_rad_s;
        let mid_hall = s.hall_angle_rad + 0.5 * self.pole_pairs * w * self.dt_s;
        let idle_emf_v = k_phase[r] * ideal_emf_shapes(sector, mid_hall)[r] * w;
        sensors.hold(sector, i_ref, back_v, idle_emf_v)
    }

    /// Stores the freewheel's idle-phase current in [`ModelState::freewheel_shift_a`] (`+i_r` on
    /// the idle phase, `−i_r` on the pair phase that does not regulate) and returns the torque it
    /// adds, `(k_r f_r − k_u f_u)·i_r`. The idle phase conducts only outside a commutation (its
    /// current is then zero).
    #[inline(never)]
    pub(super) fn freewheel_torque(&self, s: &mut ModelState, hold: &Hold, k_phase: &[f32; 3], sector: usize) -> f32 {
        let (p, q, r) = sector_phases(sector);
        s.freewheel_shift_a = [0.0; 3];
        if hold.idle_a == 0.0 || (s.phase_resolved && s.phase_current_a[r] != 0.0) {
            return 0.0;
        }
        let f = ideal_emf_shapes(sector, s.hall_angle_rad);
        let returning = if hold.regulated_p { q } else { p };
        s.freewheel_shift_a[r] = hold.idle_a;
        s.freewheel_shift_a[returning] = -hold.idle_a;
        (k_phase[r] * f[r] - k_phase[returning] * f[returning]) * hold.idle_a
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{locked_rotor, model, with_effect};
    use super::*;
    use crate::faults::FaultVector;
    use core::f32::consts::FRAC_PI_3;

    #[test]
    fn effect_terms_are_off_by_default() {
        let m = model(FaultVector::HEALTHY.0);
        assert_eq!(m.step_terms.cogging_torque_n_m, 0.0);
        assert_eq!(m.step_terms.stribeck_excess_n_m, 0.0);
        assert_eq!(m.step_terms.saturation_inv_current_sq_per_a2, 0.0);
        assert_eq!(m.step_terms.dead_time_pair_v, 0.0);
        assert!(!m.has_step_terms());
        assert!(!with_effect(FaultVector::HEALTHY.0, EffectId::Viscous, 1.0).has_step_terms(), "a parameter");
        for e in [EffectId::Cogging, EffectId::Stribeck, EffectId::Saturation, EffectId::DeadTime] {
            assert!(with_effect(FaultVector::HEALTHY.0, e, 0.1).has_step_terms(), "{e:?}");
        }
        assert_eq!(m.sliding_friction_n_m::<true>(0.0), m.dynamic_friction_n_m);
        let none = MonitorModel::with_effects(&EmaParams::NOMINAL, &FaultVector::HEALTHY, &ModelEffects::NONE);
        assert_eq!(none, m);
    }

    #[test]
    fn cogging_term_is_the_step_mean_of_the_sine() {
        let m = with_effect(FaultVector::HEALTHY.0, EffectId::Cogging, 0.5); // A = 0.02 N·m
                                                                             // At rest: A·sin(24θ_m), positive in the torque balance as in the reference model.
        let theta = 0.3f32;
        assert!((m.cogging_n_m(theta, 0.0) - 0.02 * libm::sinf(24.0 * theta)).abs() < 1e-6);
        // at 300 rad/s one step spans 0.72 rad of cogging phase: the mean of 200 sub-steps
        let w = 300.0f32;
        let n = 200;
        let mean: f32 =
            (0..n).map(|j| 0.02 * libm::sinf(24.0 * (theta + w * m.dt_s() * (j as f32 + 0.5) / n as f32))).sum::<f32>()
                / n as f32;
        assert!((m.cogging_n_m(theta, w) - mean).abs() < 1e-5, "{} vs {mean}", m.cogging_n_m(theta, w));
    }

    #[test]
    fn saturation_costs_a_fifth_of_the_torque_constant_at_15_a() {
        let m = with_effect(FaultVector::HEALTHY.0, EffectId::Saturation, 1.0); // I_sat = 30 A
        let mut k = [0.13f32; 3];
        m.saturate(&mut k, -15.0);
        assert!(k.iter().all(|&kj| (kj - 0.13 * 0.8).abs() < 1e-6), "{k:?}");
        let mut k = [0.13f32; 3];
        with_effect(FaultVector::HEALTHY.0, EffectId::Saturation, 0.5).saturate(&mut k, 15.0);
        assert!((k[0] - 0.13 / (1.0 + 0.0625)).abs() < 1e-6, "I_sat = 60 A: {k:?}");
    }

    #[test]
    fn dead_time_lowers_the_locked_rotor_current_by_2_delta_v_over_r() {
        // As rl_current_step_at_locked_rotor: 20 V over R_eq = 1 Ω, ΔV = 8 V per phase
        // → steady state (20 − 16)/1 = 4 A instead of 20 A.
        let mut p = EmaParams::NOMINAL;
        p.current_loop_lag_s = 1e-9;
        p.current_limit_a = 1e6;
        p.supply_voltage_v = 20.0;
        let m = locked_rotor(&p, &ModelEffects::NONE.with(EffectId::DeadTime, 1.0).unwrap());
        let mut s = ModelState::at_rest();
        for _ in 0..2000 {
            m.step(&mut s, 0.5);
        }
        assert!((s.current_a - 4.0).abs() < 0.01, "{}", s.current_a);
    }

    #[test]
    fn sensor_offset_moves_the_regulated_current() {
        // Locked rotor, sector 0 (a+, b−): the legs' measured-current targets are
        // T_a = (I_ref − 0.2)/1.02 and T_b = (I_ref − 0.1)/0.98. The 0 V drift is only R_eq·I,
        // 0.02 A per control period against the controller's jitter of 0.29 A, so the loop holds
        // the current halfway between them ([`SensorLoop`]), not on the lower one.
        let p = EmaParams::NOMINAL;
        let m = locked_rotor(&p, &ModelEffects::NONE.with(EffectId::SensorOffset, 1.0).unwrap());
        let mut s = ModelState::at_rest();
        s.hall_angle_rad = 0.5 * FRAC_PI_3;
        for _ in 0..2000 {
            m.step(&mut s, 0.001);
        }
        let (t_a, t_b) = ((s.current_ref_a - 0.2) / 1.02, (s.current_ref_a - 0.1) / 0.98);
        assert!(t_b - t_a > 0.08, "{t_a} {t_b}");
        let halfway = 0.5 * (t_a + t_b);
        assert!((s.current_a - halfway).abs() < 0.01, "{} vs {halfway} (T_a {t_a})", s.current_a);
        assert_eq!(s.freewheel_shift_a, [0.0; 3], "no EMF, no idle-phase current");
    }
}
