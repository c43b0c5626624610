//! The monitor model (MM): a light EMA model run thousands of times per identification
//! (Dalla Vedova, Berri, Re, ICSRS 2018; equations in `docs/model.md`).
//!
//! Simplifications against the reference model: the three-phase inverter with hysteresis control
//! becomes one equivalent DC motor (the conducting pair in series) with an ideal, slew- and
//! voltage-limited first-order current loop; motor faults enter through *shape functions* of the
//! rotor angle. The controller (ACE) is the same algorithm as the real one. Above a speed the
//! three phase currents are resolved instead (the fast regime).
//!
//! One [`MonitorModel::step`] advances one control period `T` (100 µs); each line is one part,
//! one submodule:
//!
//! ```text
//! sensor  θ_meas: the surface angle θ_u through the transducer's first-order lag τ_θ, exact for
//!         θ_u linear over the step: θ_meas⁺ = θ_u⁺ − m·τ_θ + e^{−T/τ_θ}(θ_meas − θ_u + m·τ_θ),
//!         m = (θ_u⁺ − θ_u)/T                                                     (controller)
//! ACE     e = θ_cmd − θ_meas;  D += (T/τ_D)((θ_meas − θ_meas,prev)/T − D);  I_int += e·T
//!         u = Kp·e + Ki·I_int − Kd·D;  |u| > I_max ⇒ I_int −= e·T (conditional integration)
//!         I_ref = clamp(u, ±I_max)                                               (controller)
//! shape   sector s = ⌊((θ_e − π/6) mod 2π)/(π/3)⌋ → conducting pair (p, q)      (six_step)
//!         k_j(θ_m) = k_0(1−s_j)[1 + ζ cos(θ_m − φ − j·2π/3)]
//!         K_eq = k_p + k_q,  R_eq = R_0(2 − s_p − s_q),  L_eq = L_0((1−s_p)² + (1−s_q)²)
//! current below the fast regime: I⁺ = I_ref + (I − I_ref)·e^{−T/τ_c}, its change clamped to the
//!         voltage left across the pair, with the commutation dip and the commutation-limited
//!         rise above ω = V_dc/(4k)                                                    (pair)
//!         above it: the three phase currents in substeps                   (phase_resolved)
//! torque  T_m = K_eq·(I_out − ½(I⁺ − I)) (the step's mean: its current change ramps in over the
//!         step);  T_R = −K_h·θ_u/N (hinge load at the motor)
//! motion  Borello dry friction (stick/slip, load-dependent; a driven reversal passes through 0
//!         within the step), viscous C_m: ω⁺ from the friction step; θ_m += ½(ω + ω⁺)·T
//! play    θ_u = clamp(θ_u, θ_m/N − BL/2, θ_m/N + BL/2); end stops ±θ_max         (mechanics)
//! ```
//!
//! The rotor angle advances by the trapezoid rule `½(ω + ω⁺)·T`: the semi-implicit `ω⁺·T` would
//! run the rotor `½ω·T` ahead after any acceleration from rest (0.16 rad electrical at 800 rad/s)
//! and put the commutation ripple half a period early.
//!
//! The electrical and mechanical time constants (4 ms, 2.2 ms) are ≥ 20 T, so explicit steps at
//! the control period are accurate; the current loop lag (8 µs) and the position transducer's lag
//! (0.2 ms) are integrated exactly. The 0.2 ms lag sits in the position transducer, inside the
//! loop, as in the actuator, whose hysteresis current loop follows its reference at the voltage's
//! slew rate: a current loop lagged by 0.2 ms (the paper's model) makes the current rise 0.1 ms
//! late at each step of the command.
//!
//! Optional effect terms ([`crate::effects`]) switch on through [`MonitorModel::with_effects`];
//! with none on the model runs the paper's model, bit for bit and at its cost
//! ([`MonitorModel::step_with`]).

mod controller;
mod effect_terms;
mod emf_shape;
mod mechanics;
mod pair;
mod phase_resolved;
mod sensor_loop;

pub use phase_resolved::{PHASE_RESOLVED_ONSET_FRACTION, PHASE_SUBSTEPS};

use crate::effects::ModelEffects;
use crate::faults::{FaultPhysics, FaultVector};
use crate::params::EmaParams;
use crate::six_step::{sector_of, sector_phases, wrap, PAIRS, TWO_PI};
use core::f32::consts::{FRAC_PI_3, FRAC_PI_6};
use effect_terms::StepTerms;
use emf_shape::EmfShape;
use sensor_loop::SensorLoop;

/// `(cos ψ_j, sin ψ_j)` for `ψ_j = j·2π/3`.
const PHASE_SHIFT: [(f32, f32); 3] = [(1.0, 0.0), (-0.5, 0.866_025_4), (-0.5, -0.866_025_4)];

/// State of the monitor model (also the controller's memory).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModelState {
    /// Equivalent (conducting-pair) current `I` regulated by the current loop (while the phases
    /// are resolved, [`ModelState::phase_resolved`]: the loop's lagged reference).
    pub current_a: f32,
    /// Sector-mean equivalent current after the commutation dip, `I_out`: what produces torque and
    /// what the measured `I_3eq` is compared with.
    pub output_current_a: f32,
    /// Motor speed `ω_m`.
    pub motor_speed_rad_s: f32,
    /// Motor angle `θ_m` (unwrapped).
    pub motor_angle_rad: f32,
    /// Motor angle wrapped into `[0, 2π)`, for the cogging term.
    pub motor_angle_wrapped_rad: f32,
    /// `(cos θ_m, sin θ_m)` of the wrapped motor angle, for the eccentricity shape function;
    /// advanced by a rotation each step (no sine per step), and only while the model has an
    /// eccentricity ([`ModelState::set_motor_angle`] sets both).
    pub rotor_phasor: (f32, f32),
    /// Hall angle `θ_e − π/6` wrapped into `[0, 2π)`: the sector is `⌊·/(π/3)⌋`.
    pub hall_angle_rad: f32,
    /// Surface angle `θ_u`.
    pub surface_angle_rad: f32,
    /// Controller integrator state `∫e dt`.
    pub integral_rad_s: f32,
    /// Controller filtered derivative of the measured position.
    pub derivative_rad_per_s: f32,
    /// Position measured at the previous control sample.
    pub previous_position_rad: f32,
    /// The position transducer's output (lagged surface angle) at the step's start.
    pub measured_position_rad: f32,
    /// Current reference `I_ref` computed by the controller.
    pub current_ref_a: f32,
    /// Signed phase currents `i_a, i_b, i_c` while the electrical step resolves the phases (fast
    /// regime, above [`PHASE_RESOLVED_ONSET_FRACTION`] of the dip onset); zero otherwise.
    pub phase_current_a: [f32; 3],
    /// `true` while the electrical step resolves the phases.
    pub phase_resolved: bool,
    /// Motor torque `T_m` over the last step (its mean while the phases are resolved).
    pub motor_torque_n_m: f32,
    /// Mean phase currents the current loop's freewheel adds over the last step, `δ_j` (A): `+i_r`
    /// on the idle phase, `−i_r` on the pair phase the loop does not regulate; zero unless the
    /// `sensor_offset` term is on (the current loop on measured currents).
    pub freewheel_shift_a: [f32; 3],
}

impl ModelState {
    /// At rest, with the hall angle of `θ_e = 0`.
    pub fn at_rest() -> Self {
        Self { hall_angle_rad: TWO_PI - FRAC_PI_6, rotor_phasor: (1.0, 0.0), ..Self::default() }
    }

    /// Sets the wrapped motor angle `θ_m ∈ [0, 2π)` and its phasor.
    pub fn set_motor_angle(&mut self, theta_m_rad: f32) {
        let (sin_t, cos_t) = crate::trig::sin_cos(theta_m_rad);
        self.motor_angle_wrapped_rad = theta_m_rad;
        self.rotor_phasor = (cos_t, sin_t);
    }
}

/// The monitor model for one candidate fault vector: constants precomputed once per evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MonitorModel {
    dt_s: f32,
    pole_pairs: f32,
    gear_ratio: f32,
    half_backlash_rad: f32,
    end_stop_rad: f32,
    supply_voltage_v: f32,
    current_limit_a: f32,
    lag_factor: f32,
    /// `e^{−T/τ_θ}` of the position transducer.
    position_lag_factor: f32,
    /// `τ_θ/T`.
    position_lag_ramp: f32,
    kp: f32,
    ki: f32,
    kd: f32,
    derivative_gain: f32,
    viscous_n_m_s: f32,
    static_friction_n_m: f32,
    dynamic_friction_n_m: f32,
    opposing_load_factor: f32,
    aiding_load_factor: f32,
    hinge_at_motor_n_m_per_rad: f32,
    /// Per phase `k_0(1 − s_j)`.
    phase_k: [f32; 3],
    /// Per phase `1/L_j`, `L_j = L_0(1 − s_j)²` (the commutation's neutral-point weights).
    phase_inv_l: [f32; 3],
    /// Per sector `R_eq` and `T/L_eq` of the conducting pair (precomputed: no division per step).
    pair_r: [f32; 6],
    pair_dt_over_l: [f32; 6],
    /// Per sector `L_eq` (for reports and tests).
    pair_l: [f32; 6],
    inv_dt: f32,
    dt_over_j: f32,
    /// One sector in motor angle, `(π/3)/p`.
    sector_angle_rad: f32,
    /// Its inverse, sectors per motor radian.
    sectors_per_rad: f32,
    eccentricity: f32,
    /// `(cos, sin)` of `φ + ψ_j` per phase.
    ecc_phase: [(f32, f32); 3],
    /// Per phase `R_j`.
    phase_r: [f32; 3],
    /// `1/ΣY_j`.
    inv_y_sum: f32,
    /// `|ω|` above which the electrical step resolves the phases ([`PHASE_RESOLVED_ONSET_FRACTION`]).
    phase_resolved_speed_rad_s: f32,
    /// The optional effect terms switched on ([`crate::effects`]).
    effects: ModelEffects,
    /// Back-EMF shape and Hall offset (`emf_harmonics`, `hall_misalignment`), `None` when off.
    #[cfg(feature = "effect-terms")]
    emf_shape: Option<EmfShape>,
    /// Current loop on measured currents (`sensor_offset`), `None` when off.
    #[cfg(feature = "effect-terms")]
    sensor_loop: Option<SensorLoop>,
    /// Cogging, Stribeck, saturation and dead-time terms (all zero when off).
    step_terms: StepTerms,
}

impl MonitorModel {
    /// The model of `params` with the faults `k`.
    pub fn new(params: &EmaParams, k: &FaultVector) -> Self {
        Self::from_physics(params, &k.physical(params))
    }

    /// The model of `params` with the faults `k` and the effect terms `effects`
    /// ([`ModelEffects::NONE`]: exactly [`MonitorModel::new`]).
    pub fn with_effects(params: &EmaParams, k: &FaultVector, effects: &ModelEffects) -> Self {
        Self::from_physics_with_effects(params, &k.physical(params), effects)
    }

    /// The model of `params` with the physical fault parameters `f`.
    pub fn from_physics(params: &EmaParams, f: &FaultPhysics) -> Self {
        Self::from_physics_with_effects(params, f, &ModelEffects::NONE)
    }

    /// The model of `params` with the physical fault parameters `f` and the effect terms `effects`.
    /// Parameter effects change the constants here (same mapping as the reference model):
    ///
    /// ```text
    /// winding_temperature  R_j ×(1 + α·ΔT),  k_j ×(1 + β·ΔT),  ΔT = s·100 K
    /// viscous              C_m += s·5e-4 N·m·s/rad
    /// hinge_stiffness      K_h ×(1 + s)
    /// ```
    ///
    /// Cogging, Stribeck, saturation and dead time are terms of [`MonitorModel::step`] whose
    /// constants are precomputed here (equations in the `effect_terms` module).
    pub fn from_physics_with_effects(params: &EmaParams, f: &FaultPhysics, effects: &ModelEffects) -> Self {
        let nominal = effect_terms::with_parameter_effects(params, effects);
        let (step_terms, static_friction_n_m) = StepTerms::of(params, f, effects);
        let p = &nominal;
        let mut phase_k = [0.0; 3];
        let mut phase_r = [0.0f32; 3];
        let mut phase_l = [0.0f32; 3];
        let mut ecc_phase = [(1.0, 0.0); 3];
        // the crate's f32 sine and cosine, as in the step: libm's `sinf`/`cosf` would bring their
        // large-argument reduction (`rem_pio2f`, a 768-byte frame) onto every model run's stack
        let (sphi, cphi) = crate::trig::sin_cos(f.eccentricity_phase_rad);
        for j in 0..3 {
            let healthy = 1.0 - f.shorted_fraction[j];
            phase_k[j] = p.phase_emf_constant_v_s_per_rad * healthy;
            phase_r[j] = p.phase_resistance_ohm * healthy;
            phase_l[j] = p.phase_inductance_h * healthy * healthy;
            let (cpsi, spsi) = PHASE_SHIFT[j];
            // cos/sin of (φ + ψ_j)
            ecc_phase[j] = (cphi * cpsi - sphi * spsi, sphi * cpsi + cphi * spsi);
        }
        let mut pair_r = [0.0; 6];
        let mut pair_l = [0.0; 6];
        let mut pair_dt_over_l = [0.0; 6];
        for sector in 0..6 {
            let (a, b, _) = sector_phases(sector); // phases below 3 the compiler knows: no bounds check
            pair_r[sector] = phase_r[a] + phase_r[b];
            pair_l[sector] = phase_l[a] + phase_l[b];
            pair_dt_over_l[sector] = p.control_period_s / pair_l[sector];
        }
        Self {
            dt_s: p.control_period_s,
            pole_pairs: p.pole_pairs,
            gear_ratio: p.gear_ratio,
            half_backlash_rad: 0.5 * f.backlash_rad,
            end_stop_rad: p.end_stop_rad,
            supply_voltage_v: p.supply_voltage_v,
            current_limit_a: p.current_limit_a,
            lag_factor: libm::expf(-p.control_period_s / p.current_loop_lag_s),
            position_lag_factor: libm::expf(-p.control_period_s / p.position_lag_s),
            position_lag_ramp: p.position_lag_s / p.control_period_s,
            kp: f.kp_a_per_rad,
            ki: p.ki_a_per_rad_s,
            kd: p.kd_a_s_per_rad,
            derivative_gain: p.control_period_s / p.derivative_filter_s,
            viscous_n_m_s: p.viscous_friction_n_m_s_per_rad,
            static_friction_n_m,
            dynamic_friction_n_m: f.dynamic_friction_n_m,
            opposing_load_factor: 1.0 / p.efficiency_opposing - 1.0,
            aiding_load_factor: 1.0 - p.efficiency_aiding,
            hinge_at_motor_n_m_per_rad: p.hinge_stiffness_n_m_per_rad / p.gear_ratio,
            phase_k,
            phase_inv_l: phase_l.map(|l| 1.0 / l),
            phase_r,
            inv_y_sum: 1.0 / (1.0 / phase_l[0] + 1.0 / phase_l[1] + 1.0 / phase_l[2]),
            phase_resolved_speed_rad_s: PHASE_RESOLVED_ONSET_FRACTION * p.supply_voltage_v
                / (4.0 * p.phase_emf_constant_v_s_per_rad),
            pair_r,
            pair_dt_over_l,
            pair_l,
            inv_dt: 1.0 / p.control_period_s,
            sector_angle_rad: FRAC_PI_3 / p.pole_pairs,
            sectors_per_rad: p.pole_pairs / FRAC_PI_3,
            dt_over_j: p.control_period_s / p.equivalent_inertia_kg_m2(),
            eccentricity: f.eccentricity,
            ecc_phase,
            effects: *effects,
            #[cfg(feature = "effect-terms")]
            emf_shape: EmfShape::of(effects),
            #[cfg(feature = "effect-terms")]
            sensor_loop: SensorLoop::of(effects, p, &phase_l, p.controller_jitter_a()),
            step_terms,
        }
    }

    /// The effect terms of this model.
    pub fn effects(&self) -> &ModelEffects {
        &self.effects
    }

    /// The back-EMF shape terms; always `None` without the `effect-terms` feature.
    #[inline(always)]
    fn emf_shape(&self) -> Option<&EmfShape> {
        #[cfg(feature = "effect-terms")]
        return self.emf_shape.as_ref();
        #[cfg(not(feature = "effect-terms"))]
        None
    }

    /// The current loop on measured currents; always `None` without the `effect-terms` feature.
    #[inline(always)]
    fn sensor_loop(&self) -> Option<&SensorLoop> {
        #[cfg(feature = "effect-terms")]
        return self.sensor_loop.as_ref();
        #[cfg(not(feature = "effect-terms"))]
        None
    }

    /// Model step (control period `T`).
    pub fn dt_s(&self) -> f32 {
        self.dt_s
    }

    /// Commutation (Hall) sector `0..6` of the state's rotor angle: the Hall angle advanced by
    /// `δ_H` when `hall_misalignment` is on.
    pub fn commutation_sector(&self, s: &ModelState) -> usize {
        match self.emf_shape() {
            Some(shape) if shape.hall_offset_rad != 0.0 => sector_of(wrap(s.hall_angle_rad + shape.hall_offset_rad)),
            _ => sector_of(s.hall_angle_rad),
        }
    }

    /// Back-EMF constants `k_j(θ_m)` of the three phases at the state's rotor angle.
    #[cfg_attr(not(target_os = "none"), inline)]
    fn phase_emf_constants(&self, s: &ModelState) -> [f32; 3] {
        let mut k = self.phase_k;
        if self.eccentricity > 0.0 {
            let (cos_t, sin_t) = s.rotor_phasor;
            // cos(θ − (φ+ψ_j)) = cos θ cos(φ+ψ_j) + sin θ sin(φ+ψ_j)
            for (kj, (c, sn)) in k.iter_mut().zip(self.ecc_phase) {
                *kj *= 1.0 + self.eccentricity * (cos_t * c + sin_t * sn);
            }
        }
        k
    }

    /// Shape functions of the conducting pair at the state's rotor angle: `(K_eq, R_eq, L_eq)`.
    pub fn shape(&self, s: &ModelState) -> (f32, f32, f32) {
        let sector = self.commutation_sector(s);
        let k = self.phase_emf_constants(s);
        (self.pair_k(&k, sector, s), self.pair_r[sector], self.pair_l[sector])
    }

    /// `K_eq` of `sector`'s pair: `k_p + k_q` on flat tops, `k_p·f_p(θ_e) − k_q·f_q(θ_e)` with the
    /// back-EMF shape terms ([`EmfShape`]).
    fn pair_k(&self, k: &[f32; 3], sector: usize, s: &ModelState) -> f32 {
        match self.emf_shape() {
            Some(shape) => shape.pair_k(k, sector, s.hall_angle_rad),
            None => {
                let (p, q) = PAIRS[sector];
                k[p] + k[q]
            }
        }
    }

    /// Advances the model one control period under the surface command `command_rad`.
    pub fn step(&self, s: &mut ModelState, command_rad: f32) {
        if self.has_step_terms() {
            self.step_with::<true>(s, command_rad);
        } else {
            self.step_with::<false>(s, command_rad);
        }
    }

    /// [`MonitorModel::step_with`] as one out-of-line function per `EFFECTS`: the step of every
    /// loop but the objective's (the shared window loop, the lockstep runs of the uncertainty and
    /// of commissioning). Inlined, the step would be compiled into each of them, a few kB of
    /// flash each; the call costs a few instructions of the step's several hundred.
    #[inline(never)]
    pub(crate) fn step_out_of_line<const EFFECTS: bool>(&self, s: &mut ModelState, command_rad: f32) {
        self.step_with::<EFFECTS>(s, command_rad);
    }

    /// `true` when an effect term of [`MonitorModel::step`] is on (cogging, Stribeck, saturation,
    /// dead time, back-EMF shape, Hall offset, sensor errors): a loop of steps should then run
    /// `step_with::<true>`, otherwise `::<false>`.
    pub fn has_step_terms(&self) -> bool {
        cfg!(feature = "effect-terms")
            && (self.step_terms.on || self.emf_shape().is_some() || self.sensor_loop().is_some())
    }

    /// [`MonitorModel::step`], compiled once without the effect terms (`EFFECTS = false`: the
    /// paper's model, bit for bit and at its cost) and once with them (cogging, Stribeck,
    /// saturation, dead time, back-EMF shape, Hall offset, sensor errors). Choose with
    /// [`MonitorModel::has_step_terms`] **outside** the loop: a run-time guard per term inside it
    /// (and the out-of-line `expf` it may call) would cost the on-board identification even with
    /// every term off.
    ///
    /// The parts, in order: the controller, the electrical step (the pair regime, or the
    /// phase-resolved fast regime above [`PHASE_RESOLVED_ONSET_FRACTION`] of the dip onset),
    /// the mechanics and the position transducer.
    #[inline(always)]
    pub fn step_with<const EFFECTS: bool>(&self, s: &mut ModelState, command_rad: f32) {
        let i_ref = self.control(s, command_rad, s.measured_position_rad);
        let surface_start_rad = s.surface_angle_rad;

        // Electrical: the back-EMF constants and the pair of the step's sector.
        let sector = if EFFECTS { self.commutation_sector(s) } else { sector_of(s.hall_angle_rad) };
        let mut k_phase = self.phase_emf_constants(s);
        if EFFECTS && self.step_terms.saturation_inv_current_sq_per_a2 != 0.0 {
            // while the phases are resolved `current_a` is the loop's lagged reference, not what
            // flows: their `½Σ|i_j|` is `output_current_a`
            let flowing_a = if s.phase_resolved { s.output_current_a } else { s.current_a };
            self.saturate(&mut k_phase, flowing_a);
        }
        let k_eq = if EFFECTS {
            self.pair_k(&k_phase, sector, s)
        } else {
            let (p, q) = PAIRS[sector];
            k_phase[p] + k_phase[q]
        };
        let w = s.motor_speed_rad_s;
        let resolved = libm::fabsf(w) > self.phase_resolved_speed_rad_s;
        if s.phase_resolved && !resolved {
            // Back to the pair model, from the measured current the phases left.
            s.phase_resolved = false;
            s.phase_current_a = [0.0; 3];
            s.current_a = s.output_current_a;
        }
        let i = s.current_a;
        let mut back = self.pair_r[sector] * i + k_eq * w;
        if EFFECTS && self.step_terms.dead_time_pair_v != 0.0 {
            back += self.step_terms.dead_time_pair_v * sign(i);
        }
        let hold = match self.sensor_loop() {
            Some(sensors) if EFFECTS => Some(self.sensor_hold(sensors, s, &k_phase, sector, i_ref, back)),
            _ => None,
        };
        let i_ref = hold.map_or(i_ref, |h| h.target_a);
        let mut torque_motor = if resolved {
            self.resolved_electrical_step::<EFFECTS>(s, &k_phase, sector, i_ref)
        } else {
            self.pair_electrical_step::<EFFECTS>(s, &k_phase, sector, k_eq, i_ref, back)
        };
        if EFFECTS {
            if let Some(hold) = &hold {
                torque_motor += self.freewheel_torque(s, hold, &k_phase, sector);
            }
        }
        s.motor_torque_n_m = torque_motor;

        self.mechanical_step::<EFFECTS>(s, torque_motor, w);
        self.measure_position(s, surface_start_rad);
    }
}

fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

fn sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::EffectId;
    use crate::profile::Profile;

    /// The model of the nominal actuator with the normalized fault vector `k`.
    pub(super) fn model(k: [f32; 8]) -> MonitorModel {
        MonitorModel::new(&EmaParams::NOMINAL, &FaultVector(k))
    }

    /// The model of `p` with its rotor locked by an enormous breakaway friction, `effects` on.
    pub(super) fn locked_rotor(p: &EmaParams, effects: &ModelEffects) -> MonitorModel {
        let mut f = FaultVector::HEALTHY.physical(p);
        f.static_friction_n_m = 1e9;
        f.dynamic_friction_n_m = 1e9;
        MonitorModel::from_physics_with_effects(p, &f, effects)
    }

    /// The nominal model with the faults `k` and one effect term at `severity`.
    pub(super) fn with_effect(k: [f32; 8], effect: EffectId, severity: f32) -> MonitorModel {
        let fx = ModelEffects::NONE.with(effect, severity).unwrap();
        MonitorModel::with_effects(&EmaParams::NOMINAL, &FaultVector(k), &fx)
    }

    #[test]
    fn healthy_shape_functions_are_constant() {
        let m = model(FaultVector::HEALTHY.0);
        let mut s = ModelState::at_rest();
        for k in 0..600 {
            s.hall_angle_rad = k as f32 * TWO_PI / 600.0;
            let (ke, re, le) = m.shape(&s);
            assert!((ke - 0.26).abs() < 1e-6 && (re - 1.0).abs() < 1e-6 && (le - 4e-3).abs() < 1e-9);
        }
    }

    #[test]
    fn short_circuit_lowers_the_pairs_that_use_the_phase() {
        let m = model([0.0, 0.0, 0.4, 0.0, 0.0, 0.0, 0.5, 0.5]); // s_a = 0.2
        let mut s = ModelState::at_rest();
        for sector in 0..6 {
            s.hall_angle_rad = (sector as f32 + 0.5) * FRAC_PI_3;
            let (ke, re, le) = m.shape(&s);
            let uses_a = PAIRS[sector].0 == 0 || PAIRS[sector].1 == 0;
            let expect_k = if uses_a { 0.13 * 1.8 } else { 0.26 };
            let expect_r = if uses_a { 0.5 * 1.8 } else { 1.0 };
            let expect_l = if uses_a { 2e-3 * (1.0 + 0.64) } else { 4e-3 };
            assert!((ke - expect_k).abs() < 1e-6, "sector {sector}: {ke}");
            assert!((re - expect_r).abs() < 1e-6);
            assert!((le - expect_l).abs() < 1e-9);
        }
    }

    #[test]
    fn eccentricity_ripple_averages_to_zero_over_an_electrical_turn() {
        // k_p + k_q = k_0[2 − ζ cos(θ_m − φ − ψ_r)]: the per-phase form averages out.
        let m = model([0.0, 0.0, 0.0, 0.0, 0.0, 0.6, 0.3, 0.5]);
        let mut s = ModelState::at_rest();
        let n = 36_000;
        let (mut sum, mut max, mut min) = (0.0f64, f32::MIN, f32::MAX);
        for k in 0..n {
            let theta_m = k as f32 * TWO_PI / n as f32;
            s.set_motor_angle(theta_m);
            s.hall_angle_rad = wrap(libm::fmodf(4.0 * theta_m, TWO_PI) - FRAC_PI_6 + TWO_PI);
            let (ke, _, _) = m.shape(&s);
            sum += ke as f64;
            max = max.max(ke);
            min = min.min(ke);
        }
        let mean = sum / n as f64;
        assert!((mean - 0.26).abs() < 2e-3, "mean {mean}");
        // ζ = 0.3: the ripple spans about ±ζ·k_0.
        assert!(max - min > 0.13 * 0.3 && max - min < 2.0 * 0.13 * 0.3 + 1e-3, "{min}..{max}");
    }

    #[test]
    fn rl_current_step_at_locked_rotor() {
        // Rotor locked by an enormous breakaway friction, ideal current loop, no current limit:
        // the voltage clamp alone shapes the current, i(t) = V/R_eq·(1 − e^{−R_eq t/L_eq}).
        let mut p = EmaParams::NOMINAL;
        p.current_loop_lag_s = 1e-9;
        p.current_limit_a = 1e6;
        p.supply_voltage_v = 10.0; // 10 A steady state through R_eq = 1 Ω
        let m = locked_rotor(&p, &ModelEffects::NONE);
        let mut s = ModelState::at_rest();
        let (r, l) = (1.0f32, 4e-3f32);
        for k in 1..=400 {
            m.step(&mut s, 0.5); // I_ref = Kp·0.5 ≫ 10 A: always voltage-limited
            assert_eq!(s.motor_speed_rad_s, 0.0);
            let t = k as f32 * m.dt_s();
            let exact = p.supply_voltage_v / r * (1.0 - libm::expf(-r * t / l));
            // explicit Euler with T·R/L = 0.025 lags the exact curve by < 1.3 % of the final value
            assert!((s.current_a - exact).abs() < 0.013 * 10.0, "t={t}: {} vs {exact}", s.current_a);
        }
        assert!((s.current_a - 10.0).abs() < 0.01);
    }

    #[test]
    fn the_torque_of_a_step_is_that_of_its_mean_current() {
        // From rest, a command step: the current rises over the first steps and the motor torque
        // of each is K_eq times the mean of its start and end currents (low speed: no dip).
        let m = model(FaultVector::HEALTHY.0);
        let mut s = ModelState::at_rest();
        let (k_eq, _, _) = m.shape(&s);
        let start = s.current_a;
        m.step(&mut s, 0.05);
        assert!(s.current_a > 1.0, "{}", s.current_a);
        let mean = 0.5 * (start + s.current_a);
        assert!((s.motor_torque_n_m - k_eq * mean).abs() < 1e-5, "{} vs {}", s.motor_torque_n_m, k_eq * mean);
        assert!(s.motor_torque_n_m < 0.9 * k_eq * s.current_a, "not the end current's");
    }

    #[test]
    fn healthy_step_response_is_well_damped() {
        // 0.05 rad step: overshoot ≈ 3.5 %, t90 ≈ 70 ms.
        let m = model(FaultVector::HEALTHY.0);
        let mut s = ModelState::at_rest();
        let (mut peak, mut t90) = (0.0f32, None);
        for k in 0..3000 {
            m.step(&mut s, 0.05);
            peak = peak.max(s.surface_angle_rad);
            if t90.is_none() && s.surface_angle_rad >= 0.045 {
                t90 = Some(k as f32 * m.dt_s());
            }
        }
        let t90 = t90.expect("reaches 90 %");
        assert!(t90 > 0.03 && t90 < 0.12, "t90 {t90}");
        assert!(peak < 0.05 * 1.10, "overshoot {}", peak / 0.05 - 1.0);
        assert!((s.surface_angle_rad - 0.05).abs() < 0.003, "final {}", s.surface_angle_rad);
    }

    #[test]
    fn standard_profile_runs_with_any_fault_and_stays_finite() {
        let profile = Profile::STANDARD;
        for k in [[0.0; 8], [1.0; 8], FaultVector::HEALTHY.0, [0.3, 0.7, 0.2, 0.9, 0.1, 0.8, 0.1, 0.0]] {
            let m = model(k);
            let mut s = ModelState::at_rest();
            let n = (profile.duration_s() / m.dt_s()) as usize;
            for step in 0..n {
                m.step(&mut s, profile.command_rad(step as f32 * m.dt_s()));
                assert!(s.current_a.is_finite() && s.motor_speed_rad_s.is_finite());
                assert!(libm::fabsf(s.current_a) <= 15.0 + 1e-3);
            }
            assert!((s.surface_angle_rad - profile.command_rad(profile.duration_s())).abs() < 0.01);
        }
    }

    #[test]
    fn sector_effect_terms_are_absent_when_off_and_shift_the_commutation_when_on() {
        let p = EmaParams::NOMINAL;
        let k = FaultVector::HEALTHY;
        assert_eq!(MonitorModel::with_effects(&p, &k, &ModelEffects::NONE), MonitorModel::new(&p, &k));
        let hall =
            MonitorModel::with_effects(&p, &k, &ModelEffects::NONE.with(EffectId::HallMisalignment, 1.0).unwrap());
        let plain = MonitorModel::new(&p, &k);
        let mut s = ModelState::at_rest();
        // 5° electrical before the ideal boundary 0 → 1: the 10° Hall advance has commutated already.
        s.hall_angle_rad = FRAC_PI_3 - 5f32.to_radians();
        assert_eq!((plain.commutation_sector(&s), hall.commutation_sector(&s)), (0, 1));
        // The advanced pair (a+, c−) has c 5° short of its flat top: K_eq = k_0(1 + 25/30).
        let (ke, _, _) = hall.shape(&s);
        assert!((ke - 0.13 * (1.0 + 25.0 / 30.0)).abs() < 1e-4, "{ke}");
        // Direction: forward the advance commutates while the outgoing phase is still on its flat
        // top (its current decays faster), backward (a lag) when it is already on its ramp
        // (slower decay, smaller dip of the common phase).
        let (kp, w) = ([0.13f32; 3], 700.0);
        let fwd_plain = plain.commutation::<true>(&kp, 1, w);
        let fwd_hall = hall.commutation::<true>(&kp, 1, w);
        assert!(fwd_hall.time_s_per_a < fwd_plain.time_s_per_a);
        let bwd_plain = plain.commutation::<true>(&kp, 0, -w);
        let bwd_hall = hall.commutation::<true>(&kp, 0, -w);
        assert!(bwd_hall.drop_fraction < bwd_plain.drop_fraction);
        assert!(bwd_hall.time_s_per_a > bwd_plain.time_s_per_a, "the outgoing phase decays slower");
    }
}
