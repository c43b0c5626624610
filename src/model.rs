//! The monitor model (MM): a light EMA model run thousands of times per identification.
//!
//! Simplifications against the reference model (physics.md §4): the three-phase inverter with
//! hysteresis control becomes one equivalent DC motor (the conducting pair in series) with an
//! ideal, slew- and voltage-limited first-order current loop; motor faults enter through *shape
//! functions* of the rotor angle. The controller (ACE) is the same algorithm as the real one.
//!
//! One [`MonitorModel::step`] advances one control period `T` (100 µs):
//!
//! ```text
//! sensor  θ_meas: the surface angle θ_u through the transducer's first-order lag τ_θ, exact for
//!         θ_u linear over the step: θ_meas⁺ = θ_u⁺ − m·τ_θ + e^{−T/τ_θ}(θ_meas − θ_u + m·τ_θ),
//!         m = (θ_u⁺ − θ_u)/T
//! ACE     e = θ_cmd − θ_meas;  D += (T/τ_D)((θ_meas − θ_meas,prev)/T − D);  I_int += e·T
//!         u = Kp·e + Ki·I_int − Kd·D;  |u| > I_max ⇒ I_int −= e·T (conditional integration)
//!         I_ref = clamp(u, ±I_max)
//! shape   sector s = ⌊((θ_e − π/6) mod 2π)/(π/3)⌋ → conducting pair (p, q)
//!         k_j(θ_m) = k_0(1−s_j)[1 + ζ cos(θ_m − φ − j·2π/3)]
//!         K_eq = k_p + k_q,  R_eq = R_0(2 − s_p − s_q),  L_eq = L_0((1−s_p)² + (1−s_q)²)
//! current I⁺ = I_ref + (I − I_ref)·e^{−T/τ_c}, its change clamped to the available voltage:
//!         T·(−V_dc − R_eq·I − K_eq·ω)/L_eq ≤ ΔI ≤ T·(V_dc − R_eq·I − K_eq·ω)/L_eq
//!         and, motoring above ω = V_dc/(4k), the commutation-limited rise (see below)
//! dip     commutation dip above ω = V_dc/(4k): I_out = I − ΔĪ (sector mean, see below)
//! torque  T_m = K_eq·(I_out − ½(I⁺ − I)) (the step's mean: its current change ramps in over the
//!         step);  T_R = −K_h·θ_u/N (hinge load at the motor)
//! motion  Borello dry friction (stick/slip, load-dependent; a driven reversal passes through 0
//!         within the step), viscous C_m: ω⁺ from the friction step; θ_m += ½(ω + ω⁺)·T
//!         (trapezoidal: the semi-implicit ω⁺·T ran the rotor ½ω·T ahead after any acceleration
//!         from rest, 0.16 rad electrical at 800 rad/s, and the commutation ripple half a period
//!         early)
//! play    θ_u = clamp(θ_u, θ_m/N − BL/2, θ_m/N + BL/2); end stops ±θ_max
//! ```
//!
//! **Commutation dip** (Carlson, Lajoie-Mazenc, Fagundes, "Analysis of torque ripple due to phase
//! commutation in brushless dc machines", IEEE T-IA 28(3), 1992): at each of the 6 commutations per
//! electrical turn the outgoing phase decays through its diode while the incoming one rises; with
//! per-phase EMF `E = K_eq·|ω|/2` and inductance `L = L_eq/2`, when `4E > V_dc` the current of the
//! third (non-commutated) phase — the one `I_3eq` and the torque follow — falls during the
//! commutation time `t_c = 3L·I/(V_dc + 2E)` by `ΔI = I·(4E − V_dc)/(V_dc + 2E)`, then recovers at
//! `(V_dc − 2E − R_eq I)/(2L)` in `t_r`. The monitor keeps `I` (what the current loop regulates)
//! and outputs the sector mean `I_out = I − ½ΔI·min(t_c + t_r, T_s)/T_s`, `T_s = (π/3)/(p|ω|)`.
//! The outgoing phase's back-EMF is already on its 30° ramp while its current decays over `t_c`,
//! so commutation also costs torque beyond the current dip: `∫(1 − f_out)·i_out dt` over `t_c`
//! averages, per sector and in equivalent current, to `1.5·(p·ω·t_c)²·I/π²` (at every speed,
//! ∝ ω²), which the torque (not `I_out`, which follows the third phase) loses. With the Hall
//! edges a signed angle `a` ahead of the EMFs (`hall_misalignment`, `a = δ_H·sign ω`) the
//! outgoing phase decays partly on its flat top and the incoming one rises partly on its ramp:
//! against the new pair's instantaneous `K_eq` at full current (the step's torque) the loss is
//! `k·i_out·(f_in − f_out)` with `f_in − f_out = (6/π)(φ − a)` at the angle `φ` into the
//! commutation, which averages to `1.5·α·(α − 3a)·I/π²` (`α = p·ω·t_c`; a gain when `a > α/3`).
//! Until session 20 the loss stayed `1.5·α²·I/π²` with the offset on, on top of the incoming
//! ramp's deficit at full current: the model's torque ran 1–1.7 % low at 15 A and 180–370 rad/s
//! with `δ_H` = 8° (`loop_side_by_side` example).
//! Motoring only: when braking (`I·ω < 0`) the EMF helps the incoming phase and there is no dip.
//! **Commutation-limited current**: above the onset the current loses `ΔI` at every commutation
//! and regains it only at `(V_dc − 2E − R_eq I)/(2L)` for the rest of the sector, so the current
//! the loop can sustain falls with speed; the rise of `|I|` per step is capped at
//! `T·[(V_dc − 2E − R_eq|I|)/(2L)·(T_s − t_c) − ΔI]/T_s` (negative: `|I|` decays to the
//! sustainable level). Without it the model held 12–15 A at 800–950 rad/s where the reference
//! model's current collapses (the fast reversal: healthy residual 0.183 A RMS, was 0.388).
//! It was the dominant healthy RM–MM mismatch (the fast reversal of the standard profile; `ema
//! compare` shows it before and after in the README).
//!
//! **Phase-resolved fast regime** ([`MonitorModel::phase_resolved_step`]): above
//! [`PHASE_RESOLVED_ONSET_FRACTION`] of the dip onset (311 rad/s nominal), the sector means above
//! are replaced by the three phase currents themselves, integrated in [`PHASE_SUBSTEPS`] substeps
//! of 20 µs with the trapezoidal back-EMFs, the six-step inverter, the outgoing phase's diode and
//! each commanded phase's hysteresis loop (averaged: held at its target). A commutation then
//! starts at its Hall edge inside the step, the measured `½Σ|i_j|` is taken at the sample instant
//! as the ADC takes it, and the torque is the step mean of `Σ k_j f_j i_j`. Sector means had left
//! the monitor model's eccentricity signature about 20 % too weak in the fast reversal (the
//! reference model's sector-to-sector pattern 1.6× the model's: throw-away programs, session 9,
//! README), so the identification read high
//! eccentricities high; they also let the shorts' commutations drift. `ema compare`'s reversal
//! residual: eccentricity high 0.246 → 0.179 A, short A high 0.223 → 0.204 A (README).
//! Braking too, since session 16 (until then braking, `I_ref·ω ≤ 0`, stayed on the pair model):
//! there the back-EMF helps the current, and at each commutation it drives the common phase past
//! its target even with its switch at the opposite rail, so the measured `½Σ|i_j|` bumps up
//! (by 1.3 A at 730 rad/s and 7.8 A) where the pair model held it. After the fast reversal the
//! actuator's current ran 0.1–0.35 A (2 ms means) above its reference and the model's did not;
//! with the phases resolved the healthy floor falls 0.054 → 0.052 A (seed 8), the model's
//! mismatch with the sensor noise taken out 0.027 → 0.022 A (README, "the mismatch floor"). It
//! costs 21 % more instructions per evaluation on board.
//!
//! The electrical and mechanical time constants (4 ms, 2.2 ms) are ≥ 20 T, so explicit steps at
//! the control period are accurate; the current loop lag (8 µs) and the position transducer's lag
//! (0.2 ms) are integrated exactly.
//!
//! **Where the 0.2 ms lag sits** (found in session 14): the paper's model lags the current loop by
//! `τ_c` = 0.2 ms; the actuator's hysteresis loop has no such lag (its current rises at the
//! voltage's slew rate, 67 A/ms at rest), but its position transducer lags 0.2 ms, inside the
//! loop. The loop's dynamics are nearly the same either way, the current is not: at each step of
//! the command the lagged model rose 0.1 ms late, and those two onsets held 30 % of a healthy
//! recording's structural residual. With the lag moved to the transducer (session 15, with the
//! fast regime's substeps taking their EMFs at their midpoints, [`MonitorModel::phase_resolved_step`])
//! the healthy floor of 2 ms means falls 0.068 → 0.054 A (README, "the mismatch floor").

use crate::effects::{maxima, EffectId, ModelEffects};
use crate::faults::{FaultPhysics, FaultVector};
use crate::params::EmaParams;
use crate::sector_effects::{trapezoid_in_a_turn, EmfShape, Hold, SensorLoop};
use core::f32::consts::{FRAC_PI_3, FRAC_PI_6, PI};

const TWO_PI: f32 = 2.0 * PI;

/// The electrical step resolves the three phases ([`MonitorModel::phase_resolved_step`]) above
/// this fraction of the healthy dip onset `V_dc/(4k_0)` (519 rad/s nominal): an eccentric phase
/// reaches its own onset from `1/(1 + ζ_max)` = 0.67 of it.
pub const PHASE_RESOLVED_ONSET_FRACTION: f32 = 0.6;

/// Substeps of the phase-resolved electrical step (20 µs at the 100 µs control period). 10
/// substeps lower `ema compare`'s reversal residuals by only 0.000–0.013 A (healthy 0.182 → 0.177,
/// short A high 0.204 → 0.191) and cost the on-board identification about 1e9 more instructions,
/// close to its 1e10 bar.
pub const PHASE_SUBSTEPS: usize = 5;

/// Conducting pair `(positive phase, negative phase)` per Hall sector (physics.md §3.2).
pub(crate) const PAIRS: [(usize, usize); 6] = [(0, 1), (0, 2), (1, 2), (1, 0), (2, 0), (2, 1)];

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
    /// regime, [`MonitorModel::phase_resolved_step`]); zero otherwise.
    pub phase_current_a: [f32; 3],
    /// `true` while the electrical step resolves the phases.
    pub phase_resolved: bool,
    /// Motor torque `T_m` over the last step (its mean while the phases are resolved).
    pub motor_torque_n_m: f32,
    /// Mean phase currents the current loop's freewheel adds over the last step, `δ_j` (A): `+i_r`
    /// on the idle phase, `−i_r` on the pair phase the loop does not regulate; zero unless the
    /// `sensor_offset` term is on ([`crate::sector_effects`], `SensorLoop`).
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
    emf_shape: Option<EmfShape>,
    /// Current loop on measured currents (`sensor_offset`), `None` when off.
    sensor_loop: Option<SensorLoop>,
    /// Mechanical and drive effect terms (all zero when off).
    mech_effects: MechEffects,
}

/// Constants of the cogging, Stribeck, saturation and dead-time terms (0 = off), precomputed from
/// the severities in [`MonitorModel::from_physics_with_effects`]:
///
/// ```text
/// cogging     T_cog = A·sin(24·θ_m),  A = s·0.04 N·m (θ_m from 0 at rest, as in the reference);
///             the model uses its step mean A·sin(24θ_m + x/2)·sin(x/2)/(x/2), x = 24·ω·T
/// stribeck    breakaway FSJ·(1 + s),  sliding FDJ + S·exp(−ω²/ω_s²),  S = s·(2·FSJ − FDJ)
/// saturation  k_j ×1/(1 + (I/I_sat)²),  1/I_sat² = (s/30 A)²  (I = |I| of the conducting pair)
/// dead_time   −sign(i_j)·ΔV on both conducting phases: the pair loses 2ΔV·sign(I), ΔV = s·8 V
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct MechEffects {
    /// Any of the four on ([`MonitorModel::has_step_terms`]).
    on: bool,
    /// Cogging amplitude `A`.
    cogging_torque_n_m: f32,
    /// `24·T`: cogging phase advance per step per rad/s.
    cogging_phase_per_speed_s: f32,
    /// Stribeck excess `S` at zero speed.
    stribeck_excess_n_m: f32,
    /// `1/ω_s²`.
    stribeck_inv_speed_sq_s2: f32,
    /// `1/I_sat²`.
    saturation_inv_current_sq_per_a2: f32,
    /// `2ΔV`: the pair's dead-time voltage against its current.
    dead_time_pair_v: f32,
}

/// The commutation into a sector, per ampere of the current it carries
/// (see [`MonitorModel::commutation`]).
#[derive(Clone, Copy, Debug)]
struct Commutation {
    /// `t_c/|I|`: the outgoing phase's decay time per ampere.
    time_s_per_a: f32,
    /// `ΔI/|I|`: the dip of the common phase (0 below the onset).
    drop_fraction: f32,
    /// `T_s`: time spent in one sector.
    sector_time_s: f32,
    /// `1/T_s` (a product, not a division: the step divides by `T_s` up to twice).
    sectors_per_s: f32,
    /// `K_eq|ω|`: the new pair's back-EMF.
    pair_emf_v: f32,
}

/// `(common, outgoing, incoming)` phases of the commutation into `sector`, from `sector − 1` when
/// turning forward, from `sector + 1` when turning backward.
fn commutation_roles(sector: usize, forward: bool) -> (usize, usize, usize) {
    let previous = if forward { (sector + 5) % 6 } else { (sector + 1) % 6 };
    let (a, b) = PAIRS[sector % 6];
    let (x, y) = PAIRS[previous];
    let common = if a == x || a == y { a } else { b };
    let incoming = if common == a { b } else { a };
    let outgoing = if common == x { y } else { x };
    (common, outgoing, incoming)
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
    /// constants are precomputed here (equations at `MechEffects`).
    pub fn from_physics_with_effects(params: &EmaParams, f: &FaultPhysics, effects: &ModelEffects) -> Self {
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
        let s_stribeck = effects.get(EffectId::Stribeck);
        let (static_friction_n_m, stribeck_excess_n_m) = if s_stribeck != 0.0 {
            let (fsj, fdj, gain) = (f.static_friction_n_m, f.dynamic_friction_n_m, maxima::STRIBECK_STICTION_GAIN);
            (fsj * (1.0 + s_stribeck * gain), s_stribeck * ((1.0 + gain) * fsj - fdj))
        } else {
            (f.static_friction_n_m, 0.0)
        };
        let s_saturation = effects.get(EffectId::Saturation) * (1.0 / maxima::SATURATION_CURRENT_A);
        let mut mech_effects = MechEffects {
            cogging_torque_n_m: effects.get(EffectId::Cogging) * maxima::COGGING_TORQUE_N_M,
            cogging_phase_per_speed_s: maxima::COGGING_CYCLES_PER_REV * params.control_period_s,
            stribeck_excess_n_m,
            stribeck_inv_speed_sq_s2: 1.0 / (maxima::STRIBECK_SPEED_RAD_PER_S * maxima::STRIBECK_SPEED_RAD_PER_S),
            saturation_inv_current_sq_per_a2: s_saturation * s_saturation,
            dead_time_pair_v: 2.0 * effects.get(EffectId::DeadTime) * maxima::DEAD_TIME_V,
            on: false,
        };
        let fx = &mech_effects;
        mech_effects.on = fx.cogging_torque_n_m != 0.0
            || fx.stribeck_excess_n_m != 0.0
            || fx.saturation_inv_current_sq_per_a2 != 0.0
            || fx.dead_time_pair_v != 0.0;
        let p = &nominal;
        let mut phase_k = [0.0; 3];
        let mut phase_r = [0.0f32; 3];
        let mut phase_l = [0.0f32; 3];
        let mut ecc_phase = [(1.0, 0.0); 3];
        let (cphi, sphi) = (libm::cosf(f.eccentricity_phase_rad), libm::sinf(f.eccentricity_phase_rad));
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
        for (sector, &(a, b)) in PAIRS.iter().enumerate() {
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
            emf_shape: EmfShape::of(effects),
            sensor_loop: SensorLoop::of(
                effects,
                p,
                &phase_l,
                crate::conditioning::MeasuredEnvelope::controller_jitter_a(p),
            ),
            mech_effects,
        }
    }

    /// The effect terms of this model.
    pub fn effects(&self) -> &ModelEffects {
        &self.effects
    }

    /// Model step (control period `T`).
    pub fn dt_s(&self) -> f32 {
        self.dt_s
    }

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

    /// Commutation (Hall) sector `0..6` of the state's rotor angle: the Hall angle advanced by
    /// `δ_H` when `hall_misalignment` is on (module `sector_effects`).
    pub fn commutation_sector(&self, s: &ModelState) -> usize {
        match &self.emf_shape {
            Some(shape) if shape.hall_offset_rad != 0.0 => {
                Self::sector_of(wrap(s.hall_angle_rad + shape.hall_offset_rad))
            }
            _ => Self::sector_of(s.hall_angle_rad),
        }
    }

    /// Hall sector `0..6` of a Hall angle in `[0, 2π)`.
    fn sector_of(hall_angle_rad: f32) -> usize {
        let sector = (hall_angle_rad * (1.0 / FRAC_PI_3)) as usize;
        if sector < 6 {
            sector
        } else {
            5
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
    /// back-EMF shape terms ([`crate::sector_effects`]).
    fn pair_k(&self, k: &[f32; 3], sector: usize, s: &ModelState) -> f32 {
        match &self.emf_shape {
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

    /// `true` when an effect term of [`MonitorModel::step`] is on (cogging, Stribeck, saturation,
    /// dead time, back-EMF shape, Hall offset, sensor errors): a loop of steps should then run `step_with::<true>`, otherwise `::<false>`.
    pub fn has_step_terms(&self) -> bool {
        self.mech_effects.on || self.emf_shape.is_some() || self.sensor_loop.is_some()
    }

    /// [`MonitorModel::step`], compiled once without (`MECH = false`: the paper model, bit for bit
    /// and at its cost) and once with the cogging, Stribeck, saturation and dead-time terms. Choose
    /// with [`MonitorModel::has_step_terms`] **outside** the loop: a run-time guard per term inside
    /// it (and the out-of-line `expf` it may call) cost 5–9 % of the on-board identification even
    /// with every term off (QEMU instruction count).
    #[inline(always)]
    pub fn step_with<const MECH: bool>(&self, s: &mut ModelState, command_rad: f32) {
        let i_ref = self.control(s, command_rad, s.measured_position_rad);
        let surface_start_rad = s.surface_angle_rad;

        // Electrical: first-order loop toward I_ref, limited by the voltage left across the pair.
        let sector = if MECH { self.commutation_sector(s) } else { Self::sector_of(s.hall_angle_rad) };
        let mut k_phase = self.phase_emf_constants(s);
        if MECH && self.mech_effects.saturation_inv_current_sq_per_a2 != 0.0 {
            // while the phases are resolved `current_a` is the loop's lagged reference, not what
            // flows: their `½Σ|i_j|` is `output_current_a`
            let flowing_a = if s.phase_resolved { s.output_current_a } else { s.current_a };
            self.saturate(&mut k_phase, flowing_a);
        }
        let k_eq = if MECH {
            self.pair_k(&k_phase, sector, s)
        } else {
            let (p, q) = PAIRS[sector];
            k_phase[p] + k_phase[q]
        };
        let dt_over_l = self.pair_dt_over_l[sector];
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
        if MECH && self.mech_effects.dead_time_pair_v != 0.0 {
            back += self.mech_effects.dead_time_pair_v * sign(i);
        }
        let hold = match &self.sensor_loop {
            Some(sensors) if MECH => Some(self.sensor_hold(sensors, s, &k_phase, sector, i_ref, back)),
            _ => None,
        };
        let i_ref = hold.map_or(i_ref, |h| h.target_a);
        let mut torque_motor = if resolved {
            if !s.phase_resolved {
                let (p, q) = PAIRS[sector];
                s.phase_current_a = [0.0; 3];
                s.phase_current_a[p] = i;
                s.phase_current_a[q] = -i;
                s.phase_resolved = true;
            }
            // The loop's lag (the pair model's first-order response) on the reference, kept in
            // `current_a` while the phases are resolved.
            s.current_a = i_ref + (i - i_ref) * self.lag_factor;
            self.phase_resolved_step::<MECH>(s, &k_phase, s.current_a, w)
        } else {
            // Commutation terms only while motoring (before or after this step's current change).
            let motoring = i * w > 0.0 || i_ref * w > 0.0;
            let commutation = if motoring { Some(self.commutation::<MECH>(&k_phase, sector, w)) } else { None };
            let wanted = i_ref + (i - i_ref) * self.lag_factor - i;
            let mut up = dt_over_l * (self.supply_voltage_v - back);
            let mut down = dt_over_l * (-self.supply_voltage_v - back);
            if let Some(limit) = commutation.and_then(|c| self.commutation_rise_limit(&c, i, w, sector)) {
                if i > 0.0 {
                    up = up.min(limit);
                } else {
                    down = down.max(-limit);
                }
            }
            s.current_a = i + clamp(wanted, down, up);
            let (dip_a, torque_loss_a) = match commutation {
                Some(c) => self.commutation_losses::<MECH>(&c, s.current_a, w, sector),
                None => (0.0, 0.0),
            };
            s.output_current_a = s.current_a - dip_a;
            // the torque of the step's mean current: the change ramps in over the step
            k_eq * (s.output_current_a - 0.5 * (s.current_a - i) - torque_loss_a)
        };

        if MECH {
            if let Some(hold) = &hold {
                torque_motor += self.freewheel_torque(s, hold, &k_phase, sector);
            }
        }
        s.motor_torque_n_m = torque_motor;
        // Mechanical: torque balance at the motor shaft with Borello dry friction.
        let torque_load = -self.hinge_at_motor_n_m_per_rad * s.surface_angle_rad;
        let mut torque_active = torque_motor - self.viscous_n_m_s * w;
        if MECH && self.mech_effects.cogging_torque_n_m != 0.0 {
            torque_active += self.cogging_n_m(s.motor_angle_wrapped_rad, w);
        }
        let w_new = self.friction_step_with::<MECH>(w, torque_active, torque_load);
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
        // The position transducer's lag over the step (θ_u taken linear in between).
        let lag_ramp_rad = self.position_lag_ramp * (s.surface_angle_rad - surface_start_rad);
        s.measured_position_rad = s.surface_angle_rad - lag_ramp_rad
            + self.position_lag_factor * (s.measured_position_rad - surface_start_rad + lag_ramp_rad);
    }

    /// What the current loop on measured currents holds in this step (`sensor_offset` on,
    /// [`SensorLoop::hold`]), the idle phase's EMF taken at the step's midpoint. Out of line: the
    /// step of every other effect term stays as small as before the term existed.
    #[inline(never)]
    fn sensor_hold(
        &self,
        sensors: &SensorLoop,
        s: &ModelState,
        k_phase: &[f32; 3],
        sector: usize,
        i_ref: f32,
        back_v: f32,
    ) -> Hold {
        let (p, q) = PAIRS[sector];
        let r = 3 - p - q;
        let w = s.motor_speed_rad_s;
        let mid_hall = s.hall_angle_rad + 0.5 * self.pole_pairs * w * self.dt_s;
        let idle_emf_v = k_phase[r] * ideal_shapes(sector, mid_hall)[r] * w;
        sensors.hold(sector, i_ref, back_v, idle_emf_v)
    }

    /// Stores the freewheel's idle-phase current in [`ModelState::freewheel_shift_a`] (`+i_r` on
    /// the idle phase, `−i_r` on the pair phase that does not regulate) and returns the torque it
    /// adds, `(k_r f_r − k_u f_u)·i_r`. The idle phase conducts only outside a commutation (its
    /// current is then zero).
    #[inline(never)]
    fn freewheel_torque(&self, s: &mut ModelState, hold: &Hold, k_phase: &[f32; 3], sector: usize) -> f32 {
        let (p, q) = PAIRS[sector];
        let r = 3 - p - q;
        s.freewheel_shift_a = [0.0; 3];
        if hold.idle_a == 0.0 || (s.phase_resolved && s.phase_current_a[r] != 0.0) {
            return 0.0;
        }
        let f = ideal_shapes(sector, s.hall_angle_rad);
        let returning = if hold.regulated_p { q } else { p };
        s.freewheel_shift_a[r] = hold.idle_a;
        s.freewheel_shift_a[returning] = -hold.idle_a;
        (k_phase[r] * f[r] - k_phase[returning] * f[returning]) * hold.idle_a
    }

    /// The electrical step of the fast regime (`|ω| >` [`PHASE_RESOLVED_ONSET_FRACTION`] of the dip
    /// onset, motoring or braking): the three phase currents in [`PHASE_SUBSTEPS`] explicit
    /// substeps `h`, with the trapezoidal back-EMFs at the substep's rotor angle and the
    /// inverter's six-step switching,
    /// so that each commutation happens at its Hall edge inside the step and the outgoing phase
    /// decays through its diode while the incoming one rises. `g = sign(I_ref)`:
    ///
    /// ```text
    /// pair (p, q) of the substep's Hall sector, its targets t_p = I_ref*, t_q = −I_ref*
    /// third phase r still conducting (i_r ≠ 0): the commutation, see `commutation_substep`
    /// r open: i_p = −i_q = I,  I += h·(g·V_dc − e_p + e_q − (R_p + R_q)·I)/(L_p + L_q),
    ///     |I| held at |I_ref*| (the hysteresis loop)
    /// e_j = k_j(θ_m)·f(θ_e − j·2π/3)·ω      (f: the trapezoid of ramp π/6, or `emf_harmonics`')
    /// ```
    ///
    /// `I_ref*` is the reference through the loop's lag `τ_c`, as in the pair model. A substep
    /// that contains a Hall edge is split there. Each (part of a) substep takes its EMFs at its
    /// midpoint angle and its torque with the mean of its start and end currents: until session
    /// 15 both were taken at the ends, half a substep (1.8° electrical at 840 rad/s) off, and while
    /// an outgoing phase decays on its falling ramp the model's commutation torque dip came out
    /// a third smaller than the actuator's, 1–2 % too much torque at 500–700 rad/s (the model's
    /// motor ran 4 rad/s ahead at the end of the fast reversal; `loop_side_by_side` example).
    ///
    /// The state's `output_current_a` is the measured quantity `½Σ|i_j|` at the step's end (signed
    /// like the pair current); the returned motor torque is the step mean of `Σ e_j i_j / ω =
    /// Σ k_j f_j i_j`. This replaces, above its speed, the sector-mean commutation dip, the
    /// commutation-limited rise and the ramp torque loss of the pair model (module doc).
    fn phase_resolved_step<const MECH: bool>(&self, s: &mut ModelState, k: &[f32; 3], target_a: f32, w: f32) -> f32 {
        let h = self.dt_s * (1.0 / PHASE_SUBSTEPS as f32);
        let d_hall = self.pole_pairs * w * h;
        let offset = match &self.emf_shape {
            Some(shape) if MECH => shape.hall_offset_rad,
            _ => 0.0,
        };
        let g = if target_a != 0.0 { sign(target_a) } else { sign(s.current_a) };
        let mut i = s.phase_current_a;
        let mut hall = s.hall_angle_rad;
        let travel = libm::fabsf(d_hall);
        let inv_travel = 1.0 / travel; // |ω| > 0 in the fast regime
        let mut torque_sum = 0.0;
        let mut sector = 0;
        for _ in 0..PHASE_SUBSTEPS {
            // The Hall edge inside the substep, if any, splits it: the commutation starts at its
            // instant (a model continuous in the speed and the faults, not snapped to the substeps).
            let x = if MECH { wrap(hall + offset) } else { hall };
            sector = Self::sector_of(x);
            let within = x - sector as f32 * FRAC_PI_3;
            let (to_edge, next) =
                if d_hall > 0.0 { (FRAC_PI_3 - within, (sector + 1) % 6) } else { (within, (sector + 5) % 6) };
            let first = if to_edge < travel { to_edge * inv_travel } else { 1.0 };
            if first > 0.0 {
                let mid = hall + 0.5 * first * d_hall;
                torque_sum += first * self.phase_substep::<MECH>(&mut i, sector, mid, k, w, target_a, g, first * h);
            }
            if first < 1.0 {
                sector = next;
                let mid = hall + 0.5 * (1.0 + first) * d_hall;
                torque_sum += (1.0 - first)
                    * self.phase_substep::<MECH>(&mut i, sector, mid, k, w, target_a, g, (1.0 - first) * h);
            }
            hall = wrap(hall + d_hall);
        }
        s.phase_current_a = i;
        let measured = 0.5 * (libm::fabsf(i[0]) + libm::fabsf(i[1]) + libm::fabsf(i[2]));
        let (a, b) = PAIRS[sector];
        let pair_sign = if i[a] != i[b] { sign(i[a] - i[b]) } else { g };
        s.output_current_a = pair_sign * measured;
        torque_sum * (1.0 / PHASE_SUBSTEPS as f32)
    }

    /// A (part of a) substep of [`MonitorModel::phase_resolved_step`] of length `h` in `sector`,
    /// the EMFs at its midpoint Hall angle `hall_rad`; returns its mean torque
    /// `Σ k_j f_j (i_j + i_j⁺)/2` (the midpoint rule in the angle, the trapezoid rule in the
    /// currents). `g` is the polarity the pair is driven with.
    #[allow(clippy::too_many_arguments)]
    fn phase_substep<const MECH: bool>(
        &self,
        i: &mut [f32; 3],
        sector: usize,
        hall_rad: f32,
        k: &[f32; 3],
        w: f32,
        target_a: f32,
        g: f32,
        h: f32,
    ) -> f32 {
        let (a, b) = PAIRS[sector];
        let r = 3 - a - b;
        let f = match &self.emf_shape {
            Some(shape) if MECH => {
                let (theta_e, inv_ramp) = (hall_rad + FRAC_PI_6, shape.inv_ramp_per_rad);
                [
                    trapezoid_within_a_turn(theta_e, inv_ramp),
                    trapezoid_within_a_turn(theta_e - 2.0 * FRAC_PI_3, inv_ramp),
                    trapezoid_within_a_turn(theta_e - 4.0 * FRAC_PI_3, inv_ramp),
                ]
            }
            _ => ideal_shapes(sector, hall_rad),
        };
        let e_v = [k[0] * f[0] * w, k[1] * f[1] * w, k[2] * f[2] * w];
        let i_before = *i;
        if i[r] != 0.0 {
            self.commutation_substep::<MECH>(i, (a, b, r), target_a, &e_v, h);
        } else {
            let pair = i[a];
            let mut u = g * self.supply_voltage_v - (e_v[a] - e_v[b]) - (self.phase_r[a] + self.phase_r[b]) * pair;
            if MECH {
                u -= self.mech_effects.dead_time_pair_v * sign(pair);
            }
            let mut next = pair + u * self.pair_dt_over_l[sector] * self.inv_dt * h;
            let limit = libm::fabsf(target_a);
            if next * g > limit {
                next = g * limit;
            }
            i[a] = next;
            i[b] = -next;
            i[r] = 0.0;
        }
        let mean = [0.5 * (i_before[0] + i[0]), 0.5 * (i_before[1] + i[1]), 0.5 * (i_before[2] + i[2])];
        k[0] * f[0] * mean[0] + k[1] * f[1] * mean[1] + k[2] * f[2] * mean[2]
    }

    /// One substep of [`MonitorModel::phase_resolved_step`] while the third phase `r` still
    /// conducts through its diode: the commutation. Each commanded phase `j` of the pair `(a, b)`
    /// has its own hysteresis loop around its target `t_a = I_ref`, `t_b = −I_ref`, averaged: its
    /// terminal is at the rail that drives it toward the target, and a phase that sits at its
    /// target while that rail would push it past is **held** there (its switch chops, `di_j = 0`)
    /// and drops out of the neutral point, which the other phases then set alone, unless even the
    /// opposite rail would push it past (braking: the back-EMF drives the common phase beyond its
    /// target): then it runs free at the opposite rail:
    ///
    /// ```text
    /// v_j = sign(t_j − i_j)·V_dc/2 (sign(t_j) at the target),  v_r = −sign(i_r)·V_dc/2
    /// u_j = v_j − e_j − R_j i_j,  v_N = Σ_free Y_j u_j / Σ_free Y_j,  i_j += h·Y_j·(u_j − v_N)
    /// ```
    ///
    /// A free commanded phase that crosses its target is held there and `r` crossing zero is
    /// blocked at zero (its diode), each excess shared by the other free phases in proportion to
    /// `Y_j`. With a shorted common phase (small `L`, large `Y`) holding matters: that phase would
    /// otherwise pin `v_N` and slow the outgoing phase's decay.
    fn commutation_substep<const MECH: bool>(
        &self,
        i: &mut [f32; 3],
        (a, b, r): (usize, usize, usize),
        target_a: f32,
        e_v: &[f32; 3],
        h: f32,
    ) {
        let half_v = 0.5 * self.supply_voltage_v;
        let y = self.phase_inv_l;
        let mut t = [0.0f32; 3];
        t[a] = target_a;
        t[b] = -target_a;
        let mut u = [0.0f32; 3];
        for j in [a, b] {
            let rail = if i[j] < t[j] {
                1.0
            } else if i[j] > t[j] {
                -1.0
            } else {
                sign(t[j])
            };
            u[j] = rail * half_v - e_v[j] - self.phase_r[j] * i[j];
            if MECH {
                u[j] -= 0.5 * self.mech_effects.dead_time_pair_v * sign(i[j]);
            }
        }
        u[r] = -sign(i[r]) * half_v - e_v[r] - self.phase_r[r] * i[r];
        if MECH {
            u[r] -= 0.5 * self.mech_effects.dead_time_pair_v * sign(i[r]);
        }
        let mut v_all = (y[0] * u[0] + y[1] * u[1] + y[2] * u[2]) * self.inv_y_sum;
        let mut free = [true; 3];
        for j in [a, b] {
            free[j] = !(i[j] == t[j] && t[j] != 0.0 && sign(t[j]) * (u[j] - v_all) > 0.0);
            if !free[j] {
                // its switch chops only if the opposite rail turns it back; braking, the back-EMF
                // can drive it past its target even there: it then runs free at that rail
                let u_opposite = u[j] - sign(t[j]) * self.supply_voltage_v;
                let v_opposite = v_all + y[j] * (u_opposite - u[j]) * self.inv_y_sum;
                if sign(t[j]) * (u_opposite - v_opposite) > 0.0 {
                    u[j] = u_opposite;
                    v_all = v_opposite;
                    free[j] = true;
                }
            }
        }
        let v_n = if free[a] && free[b] {
            v_all
        } else {
            let (mut num, mut den) = (0.0f32, 0.0f32);
            for j in 0..3 {
                if free[j] {
                    num += y[j] * u[j];
                    den += y[j];
                }
            }
            num / den // r is always free: den ≥ Y_r > 0
        };
        let before = *i;
        for j in 0..3 {
            if free[j] {
                i[j] += h * y[j] * (u[j] - v_n);
            }
        }
        for j in [a, b] {
            if free[j] && before[j] != t[j] && (before[j] - t[j]) * (i[j] - t[j]) <= 0.0 {
                let excess = i[j] - t[j];
                i[j] = t[j];
                free[j] = false;
                Self::share(i, excess, &free, &y);
            }
        }
        if i[r] * before[r] <= 0.0 {
            // The diode blocks: i_r → 0, its excess shared by the pair.
            let excess = i[r];
            i[r] = 0.0;
            let mut pair = [false; 3];
            pair[a] = free[a];
            pair[b] = free[b];
            if !pair[a] && !pair[b] {
                pair[a] = true;
                pair[b] = true;
            }
            Self::share(i, excess, &pair, &y);
        }
    }

    /// Adds `excess` back to the phases marked in `to`, in proportion to `Y_j` (keeps `Σi = 0`
    /// after a phase was set to a bound); nothing when none is marked.
    fn share(i: &mut [f32; 3], excess: f32, to: &[bool; 3], y: &[f32; 3]) {
        let den: f32 = (0..3).filter(|&j| to[j]).map(|j| y[j]).sum();
        if den > 0.0 {
            for j in 0..3 {
                if to[j] {
                    i[j] += excess * y[j] / den;
                }
            }
        }
    }

    /// The commutation into `sector` at speed `w` (module doc, "Commutation"): the phase the two
    /// pairs share (common `c`, its current `I`), the one leaving (`o`, decaying through its diode)
    /// and the one entering (`n`). With the isolated star's neutral
    /// `v_N = Σ Y_j(v_j − e_j)/ΣY_j`, `Y_j = 1/L_j`, flat-top EMFs `E_j = k_j(θ_m)|ω|`:
    ///
    /// ```text
    /// d|i_o|/dt = −(Y_o/Y)·[Y_c(E_c + E_o) + Y_n(V_dc + E_o − E_n)]      (t_c = |I| / that)
    /// d|i_c|/dt =  (Y_c/Y)·[Y_n(V_dc − E_c − E_n) − Y_o(E_c + E_o)]      (ΔI = −that·t_c when < 0)
    /// ```
    ///
    /// Equal phases give Carlson's `t_c = 3L|I|/(V_dc + 2E)`, `ΔI = |I|(4E − V_dc)/(V_dc + 2E)`;
    /// a shorted or eccentric phase changes both, commutation by commutation. `R` is neglected
    /// during `t_c`, as there.
    fn commutation<const MECH: bool>(&self, k: &[f32; 3], sector: usize, w: f32) -> Commutation {
        let k_flat = k;
        let shaped;
        let k = match &self.emf_shape {
            Some(shape) if MECH => {
                shaped = shape.commutation_k(k, sector, w > 0.0);
                &shaped
            }
            _ => k,
        };
        let (c, o, n) = commutation_roles(sector, w > 0.0);
        let speed = libm::fabsf(w);
        let (v, dv) = (self.supply_voltage_v, if MECH { self.mech_effects.dead_time_pair_v } else { 0.0 });
        let (e_c, e_o, e_n) = (k[c] * speed, k[o] * speed, k[n] * speed);
        let (y_c, y_o, y_n) = (self.phase_inv_l[c], self.phase_inv_l[o], self.phase_inv_l[n]);
        let inv_y = self.inv_y_sum;
        let decay = y_o * inv_y * (y_c * (e_c + e_o + dv) + y_n * (v + e_o - e_n));
        let common = y_c * inv_y * (y_n * (v - dv - e_c - e_n) - y_o * (e_c + e_o + dv));
        let sector_time_s = self.sector_angle_rad / speed;
        let (time_s_per_a, drop_fraction) = if decay > 0.0 {
            (1.0 / decay, if common < 0.0 { -common / decay } else { 0.0 })
        } else {
            (sector_time_s, 0.0) // never reached with physical values: the whole sector commutates
        };
        let (p, q) = PAIRS[sector];
        let pair_k = match &self.emf_shape {
            Some(shape) if MECH => shape.mean_pair_k(k_flat, sector),
            _ => k[p] + k[q],
        };
        let sectors_per_s = speed * self.sectors_per_rad;
        Commutation { time_s_per_a, drop_fraction, sector_time_s, sectors_per_s, pair_emf_v: pair_k * speed }
    }

    /// The recovery slope `(V_dc − 2ΔV − K_eq|ω| − R_eq|I|)/L_eq` of the new pair after `t_c`.
    fn recovery_a_per_s(&self, sector: usize, k_eq_speed_v: f32, i_abs: f32) -> f32 {
        (self.supply_voltage_v - self.mech_effects.dead_time_pair_v - k_eq_speed_v - self.pair_r[sector] * i_abs)
            * self.pair_dt_over_l[sector]
            * self.inv_dt
    }

    /// Largest change of `|I|` over one step while motoring above the dip onset: per sector the
    /// current loses `ΔI` during `t_c` and regains the recovery slope only during `T_s − t_c`, so
    /// the sector-start current rises by at most `T·[slope·(T_s − t_c) − ΔI]/T_s` (negative: it
    /// decays to the commutation-limited current). `None` when braking, at rest or below the onset.
    fn commutation_rise_limit(&self, c: &Commutation, i: f32, w: f32, sector: usize) -> Option<f32> {
        if i * w <= 0.0 || c.drop_fraction <= 0.0 {
            return None;
        }
        let i_abs = libm::fabsf(i);
        let (t_c, drop) = (c.time_s_per_a * i_abs, c.drop_fraction * i_abs);
        let slope = self.recovery_a_per_s(sector, c.pair_emf_v, i_abs);
        let rise_time = if c.sector_time_s > t_c { c.sector_time_s - t_c } else { 0.0 };
        Some(self.dt_s * (slope * rise_time - drop) * c.sectors_per_s)
    }

    /// Sector means of the commutation dip of `I_out` and of the extra torque loss (both as
    /// equivalent currents, signed like `i`; module doc). Zero when braking or at rest.
    fn commutation_losses<const MECH: bool>(&self, c: &Commutation, i: f32, w: f32, sector: usize) -> (f32, f32) {
        if i * w <= 0.0 {
            return (0.0, 0.0);
        }
        let i_abs = libm::fabsf(i);
        let (t_c, drop) = (c.time_s_per_a * i_abs, c.drop_fraction * i_abs);
        let angle = self.pole_pairs * libm::fabsf(w) * t_c;
        // The paper's model (`MECH = false`) has no Hall offset and keeps its own expression: one
        // form for both (the advance 0, the lower clamp unused) ran 0.54 % more instructions on
        // the built-in trace (8.904e9 against 8.856e9, session 20).
        let torque_loss = if MECH {
            // `a = δ_H·sign ω`: how far (electrical rad) the commutation runs ahead of the EMFs
            let advance_rad = self.emf_shape.as_ref().map_or(0.0, |shape| shape.hall_offset_rad) * sign(w);
            let ramp_loss = 1.5 * angle * (angle - 3.0 * advance_rad) * i_abs * (1.0 / (PI * PI));
            clamp(ramp_loss, -0.5 * i_abs, 0.5 * i_abs)
        } else {
            let ramp_loss = 1.5 * angle * angle * i_abs * (1.0 / (PI * PI));
            if ramp_loss < 0.5 * i_abs {
                ramp_loss
            } else {
                0.5 * i_abs
            }
        };
        let dip = if drop > 0.0 {
            let slope = self.recovery_a_per_s(sector, c.pair_emf_v, i_abs);
            let t_r = if slope > 0.0 { drop / slope } else { c.sector_time_s };
            let dip_time = if t_c + t_r < c.sector_time_s { t_c + t_r } else { c.sector_time_s };
            0.5 * drop * dip_time * c.sectors_per_s
        } else {
            0.0
        };
        if i > 0.0 {
            (dip, torque_loss)
        } else {
            (-dip, -torque_loss)
        }
    }

    /// Saturation effect: `k_j ×1/(1 + (I/I_sat)²)` with the current `I` flowing at the step's
    /// start (the reference model's `I = ½Σ|i_j|`: the pair current, or while the phases are
    /// resolved their `½Σ|i_j|`; until session 18 the loop's lagged reference there, which stays
    /// at the 15 A limit while the fast reversal's current collapses under the back-EMF).
    fn saturate(&self, k: &mut [f32; 3], i: f32) {
        let factor = 1.0 / (1.0 + i * i * self.mech_effects.saturation_inv_current_sq_per_a2);
        for kj in k.iter_mut() {
            *kj *= factor;
        }
    }

    /// Cogging effect: the mean of `A·sin(24·θ_m)` over the step from `θ_m` at speed `ω`,
    /// `A·sin(24θ_m + x/2)·sin(x/2)/(x/2)` with `x = 24·ω·T` (the control step spans up to a third
    /// of a cogging period at full speed, where the reference model, at its 0.25 µs step, sees
    /// its mean).
    fn cogging_n_m(&self, motor_angle_wrapped_rad: f32, w: f32) -> f32 {
        let fx = &self.mech_effects;
        let half = 0.5 * fx.cogging_phase_per_speed_s * w;
        let phase = maxima::COGGING_CYCLES_PER_REV * motor_angle_wrapped_rad + half;
        let (sin_phase, _) = crate::trig::sin_cos(phase);
        let mean = if libm::fabsf(half) > 1e-3 { crate::trig::sin_cos(half).0 / half } else { 1.0 };
        fx.cogging_torque_n_m * sin_phase * mean
    }

    /// Sliding friction without the load term: `FDJ`, plus the Stribeck excess `S·exp(−ω²/ω_s²)`
    /// when that effect is on (negligible, < 1e-7·S, and skipped beyond `4ω_s`).
    fn sliding_friction_n_m<const MECH: bool>(&self, w: f32) -> f32 {
        let fx = &self.mech_effects;
        if !MECH || fx.stribeck_excess_n_m == 0.0 {
            return self.dynamic_friction_n_m;
        }
        let r2 = w * w * fx.stribeck_inv_speed_sq_s2;
        if r2 < 16.0 {
            self.dynamic_friction_n_m + fx.stribeck_excess_n_m * libm::expf(-r2)
        } else {
            self.dynamic_friction_n_m
        }
    }

    /// Borello dry friction (physics.md §3.7): the four cases stuck/breakaway/slip/stop.
    /// `torque_active` = motor torque minus viscous; `torque_load` = load reflected to the motor.
    /// The motor is stuck only when `ω` is exactly 0. A slip step that would reverse `ω` reaches 0
    /// at the fraction `f = ω/(ω − ω⁺)` of the step; there the breakaway decides as from rest, over
    /// the step's remaining `1 − f`: the motor stays stopped when `|T_net|` does not pass it, and
    /// otherwise leaves the other way, `ω⁺ = (1 − f)·T/J·(T_net − d·(F_D + load))`. (Stopping for
    /// the rest of the step instead would lose up to a whole control period at every driven
    /// reversal, a loss that jumps by a period as any parameter moves the zero crossing across a
    /// step boundary: the fast reversal's rotor angle, and the commutation ripple after it, would
    /// then jump with it.)
    pub fn friction_step(&self, w: f32, torque_active: f32, torque_load: f32) -> f32 {
        if self.mech_effects.on {
            self.friction_step_with::<true>(w, torque_active, torque_load)
        } else {
            self.friction_step_with::<false>(w, torque_active, torque_load)
        }
    }

    /// [`MonitorModel::friction_step`] with (`MECH`) or without the Stribeck term.
    #[inline(always)]
    fn friction_step_with<const MECH: bool>(&self, w: f32, torque_active: f32, torque_load: f32) -> f32 {
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
            let friction = self.sliding_friction_n_m::<MECH>(w) + load_term(d);
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
            let friction = self.sliding_friction_n_m::<MECH>(0.0) + load_term(d);
            from_rest * dt_over_j * (net - d * friction)
        }
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

/// The ideal trapezoidal back-EMF shapes `f_j` (120° flat tops) at the Hall angle `hall_rad` in
/// its Hall `sector`: the sector's pair on its flat tops (+1, −1), the third phase on its 60° ramp,
/// falling in even sectors, rising in odd ones (`sector_effects::trapezoid` without its folds).
fn ideal_shapes(sector: usize, hall_rad: f32) -> [f32; 3] {
    let (a, b) = PAIRS[sector % 6];
    // The angle into the sector; at the 5 → 0 edge `hall_rad` may round to either side of 2π.
    let mut within = wrap(hall_rad) - sector as f32 * FRAC_PI_3;
    if within > PI {
        within -= TWO_PI;
    } else if within < -PI {
        within += TWO_PI;
    }
    let within = clamp(within, 0.0, FRAC_PI_3);
    let ramp = 1.0 - within * (6.0 / PI);
    let mut f = [0.0f32; 3];
    f[a] = 1.0;
    f[b] = -1.0;
    f[3 - a - b] = if sector.is_multiple_of(2) { ramp } else { -ramp };
    f
}

/// `sector_effects::trapezoid` of an angle less than one turn outside `[0, 2π)` (the substep's `θ_e − j·2π/3`,
/// `θ_e ∈ [π/6, 2π + π/6)`): folded by one turn instead of a `floor`. Same value as `trapezoid`
/// up to the rounding of the fold.
#[cfg_attr(not(target_os = "none"), inline)]
fn trapezoid_within_a_turn(theta_e_rad: f32, inv_ramp_per_rad: f32) -> f32 {
    let x = if theta_e_rad < 0.0 {
        theta_e_rad + TWO_PI
    } else if theta_e_rad >= TWO_PI {
        theta_e_rad - TWO_PI
    } else {
        theta_e_rad
    };
    trapezoid_in_a_turn(x, inv_ramp_per_rad)
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

/// Wraps an angle that moved by less than 2π per step back into `[0, 2π)`.
fn wrap(a: f32) -> f32 {
    if a >= TWO_PI {
        a - TWO_PI
    } else if a < 0.0 {
        a + TWO_PI
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::Profile;

    fn model(k: [f32; 8]) -> MonitorModel {
        MonitorModel::new(&EmaParams::NOMINAL, &FaultVector(k))
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
        // (the f32 wrapped angle it replaces drifts as much: ~4e-7 of rounding per step)
        assert!(worst < 1e-4, "phasor drifted by {worst}");
        let modulus = phasor.0 * phasor.0 + phasor.1 * phasor.1;
        assert!((modulus - 1.0).abs() < 1e-6, "modulus² {modulus}");
    }

    #[test]
    fn eccentricity_ripple_averages_to_zero_over_an_electrical_turn() {
        // physics.md §3.6: k_p + k_q = k_0[2 − ζ cos(θ_m − φ − ψ_r)]; the per-phase form averages out.
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

    /// The model of `p` with its rotor locked by an enormous breakaway friction, `effects` on.
    fn locked_rotor(p: &EmaParams, effects: &ModelEffects) -> MonitorModel {
        let mut f = FaultVector::HEALTHY.physical(p);
        f.static_friction_n_m = 1e9;
        f.dynamic_friction_n_m = 1e9;
        MonitorModel::from_physics_with_effects(p, &f, effects)
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
    fn healthy_step_response_is_well_damped() {
        // physics.md §7.2 [S]: 0.05 rad step, overshoot ≈ 3.5 %, t90 ≈ 70 ms.
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
    fn commutation_dip_starts_at_a_quarter_of_the_bus_voltage() {
        let m = model(FaultVector::HEALTHY.0);
        let k = [0.13f32; 3];
        let at = |i: f32, w: f32| m.commutation_losses::<true>(&m.commutation::<true>(&k, 0, w), i, w, 0);
        let limit = |i: f32, w: f32| m.commutation_rise_limit(&m.commutation::<true>(&k, 0, w), i, w, 0);
        let onset = 270.0 / (4.0 * 0.13); // 4E = V_dc, E = k_0 ω
        assert_eq!(at(15.0, 0.98 * onset).0, 0.0);
        assert!(at(15.0, 1.05 * onset).0 > 0.0);
        // Worked example (the reference model reads 13.6 A, i.e. a 1.4 A dip, at 686 rad/s):
        // E = 89.18 V, t_c = 0.2007 ms, ΔI = 2.901 A, t_r = 2.901·4 mH/(270 − 178.4 − 15) V = 0.1514 ms,
        // T_s = 0.3816 ms → ½·2.901·0.3521/0.3816 = 1.338 A.
        let (d, torque) = at(15.0, 686.0);
        assert!((d - 1.338).abs() < 0.002, "{d}");
        // ramp loss: p·ω·t_c = 4·686·0.2007 ms = 0.5507 rad → 1.5·0.5507²·15/π² = 0.691 A
        assert!((torque - 0.691).abs() < 0.002, "{torque}");
        // Rise limit at the same point: rate = (270 − 178.36 − 15)/4 mH = 19 160 A/s over
        // T_s − t_c = 0.1809 ms regains 3.466 A against the 2.901 A lost: +0.565 A per sector,
        // i.e. 0.565·T/T_s = 0.148 A per step; at 800 rad/s the sector loses more than it regains.
        let l = limit(15.0, 686.0).unwrap();
        assert!((l - 0.148).abs() < 1e-3, "{l}");
        assert!(limit(15.0, 800.0).unwrap() < 0.0);
        assert_eq!(limit(15.0, 0.98 * onset), None);
        assert_eq!(limit(15.0, -686.0), None, "braking");
        let (dn, tn) = at(-15.0, -686.0);
        assert!((dn + d).abs() < 1e-6 && (tn + torque).abs() < 1e-6, "odd in the current");
        assert_eq!(at(15.0, -686.0), (0.0, 0.0), "nothing when braking");
    }

    fn with_effect(k: [f32; 8], effect: EffectId, severity: f32) -> MonitorModel {
        let fx = ModelEffects::NONE.with(effect, severity).unwrap();
        MonitorModel::with_effects(&EmaParams::NOMINAL, &FaultVector(k), &fx)
    }

    #[test]
    fn effect_terms_are_off_by_default() {
        let m = model(FaultVector::HEALTHY.0);
        assert_eq!(m.mech_effects.cogging_torque_n_m, 0.0);
        assert_eq!(m.mech_effects.stribeck_excess_n_m, 0.0);
        assert_eq!(m.mech_effects.saturation_inv_current_sq_per_a2, 0.0);
        assert_eq!(m.mech_effects.dead_time_pair_v, 0.0);
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
        // and it moves the commutation dip onset from 4E = V_dc down to 4E = V_dc − 4ΔV (the common
        // phase's drive and the outgoing phase's decay each carry ΔV twice)
        let at_onset = |dead_time_v: f32| (270.0 - 4.0 * dead_time_v) / (4.0 * 0.13);
        let k = [0.13f32; 3];
        let dead = with_effect(FaultVector::HEALTHY.0, EffectId::DeadTime, 1.0);
        assert_eq!(dead.commutation::<true>(&k, 0, 0.99 * at_onset(8.0)).drop_fraction, 0.0);
        assert!(dead.commutation::<true>(&k, 0, 1.01 * at_onset(8.0)).drop_fraction > 0.0);
        let healthy = model(FaultVector::HEALTHY.0);
        let w = 0.98 * at_onset(0.0);
        assert_eq!(healthy.commutation::<true>(&k, 0, w).drop_fraction, 0.0);
        assert!(dead.commutation::<true>(&k, 0, w).drop_fraction > 0.0);
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

    #[test]
    fn commutation_torque_loss_with_a_hall_offset_integrates_the_ramps() {
        // Against the new pair's K_eq at full current, a commutation over α = p·ω·t_c loses
        // k·i_out·(f_in − f_out): the outgoing phase decays from I while its EMF leaves its flat top
        // at φ = a (the Hall advance), the incoming one carries I − i_out while its EMF reaches its
        // flat top at φ = a. Integrated numerically over the trapezoids' 30° ramps here; the
        // model's sector mean in equivalent current (÷ π/3, ÷ 2k) must match.
        let p = EmaParams::NOMINAL;
        let k = FaultVector::HEALTHY;
        let hall =
            MonitorModel::with_effects(&p, &k, &ModelEffects::NONE.with(EffectId::HallMisalignment, 1.0).unwrap());
        let plain = MonitorModel::new(&p, &k);
        let (kp, i) = ([0.13f32; 3], 15.0f32);
        let ramp = |x: f64| (x * 6.0 / core::f64::consts::PI).clamp(0.0, 1.0);
        let integral = |alpha: f64, a: f64| {
            let n = 20_000;
            let h = alpha / n as f64;
            let sum: f64 = (0..n)
                .map(|j| {
                    let phi = (j as f64 + 0.5) * h;
                    let (f_in, f_out) = (1.0 - ramp(a - phi), 1.0 - ramp(phi - a));
                    f64::from(i) * (1.0 - phi / alpha) * (f_in - f_out)
                })
                .sum();
            sum * h / (core::f64::consts::PI / 3.0) / 2.0
        };
        for (m, w, a) in
            [(&plain, 300.0f32, 0.0f64), (&hall, 300.0, 10f64.to_radians()), (&hall, -300.0, -10f64.to_radians())]
        {
            let c = m.commutation::<true>(&kp, 1, w);
            let alpha = f64::from(4.0 * libm::fabsf(w) * c.time_s_per_a * i);
            let loss = m.commutation_losses::<true>(&c, i * w.signum(), w, 1).1 * w.signum();
            let expected = integral(alpha, a);
            assert!((f64::from(loss) - expected).abs() < 2e-3 * f64::from(i), "a {a}: {loss} vs {expected}");
        }
        // forward, the advance turns the loss into a gain: the outgoing phase decays on its flat top
        let c = hall.commutation::<true>(&kp, 1, 300.0);
        assert!(hall.commutation_losses::<true>(&c, i, 300.0, 1).1 < 0.0);
    }

    #[test]
    fn sensor_offset_moves_the_regulated_current() {
        // Locked rotor, sector 0 (a+, b−): the legs' measured-current targets are
        // T_a = (I_ref − 0.2)/1.02 and T_b = (I_ref − 0.1)/0.98. The 0 V drift is only R_eq·I,
        // 0.02 A per control period against the controller's jitter of 0.29 A, so the loop holds
        // the current halfway between them (sector_effects::SensorLoop), not on the lower one.
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

    #[test]
    fn ideal_shapes_are_the_reference_trapezoid() {
        for n in 0..600 {
            let hall = (n as f32 + 0.5) * (TWO_PI / 600.0);
            let sector = MonitorModel::sector_of(hall);
            let f = ideal_shapes(sector, hall);
            for (j, fj) in f.iter().enumerate() {
                let theta = hall + FRAC_PI_6 - j as f32 * (2.0 * FRAC_PI_3);
                let reference = crate::sector_effects::trapezoid(theta, 6.0 / PI);
                assert!((fj - reference).abs() < 1e-4, "hall {hall}, phase {j}: {fj} vs {reference}");
                let folded = trapezoid_within_a_turn(theta, 6.0 / PI);
                assert!((folded - reference).abs() < 1e-5, "hall {hall}, phase {j}: {folded} vs {reference}");
            }
        }
    }

    #[test]
    fn commutation_roles_follow_the_six_step_table() {
        // forward 0 → 1: (a+, b−) → (a+, c−): a stays, b leaves, c enters
        assert_eq!(commutation_roles(1, true), (0, 1, 2));
        // backward 1 → 0: (a+, c−) → (a+, b−): a stays, c leaves, b enters
        assert_eq!(commutation_roles(0, false), (0, 2, 1));
        for sector in 0..6 {
            for forward in [true, false] {
                let (c, o, n) = commutation_roles(sector, forward);
                assert!(c != o && o != n && c != n);
                let (p, q) = PAIRS[sector];
                assert!((c == p || c == q) && (n == p || n == q), "the new pair is (common, incoming)");
            }
        }
    }

    #[test]
    fn a_shorted_outgoing_phase_commutates_faster() {
        // A short lowers L_j (∝ (1−s)²) more than k_j (∝ 1−s): its current decays faster, so
        // commutations where it leaves are shorter than the healthy ones; the equal-phase case is
        // the symmetric formula exactly.
        let m = model([0.0, 0.0, 0.6, 0.0, 0.0, 0.0, 0.5, 0.5]); // s_a = 0.3
        let k = [0.13 * 0.7, 0.13, 0.13];
        let w = 700.0;
        let a_leaves = m.commutation::<true>(&k, 2, w); // forward 1 → 2: a leaves
        let a_stays = m.commutation::<true>(&k, 1, w); // forward 0 → 1: b leaves
        assert!(a_leaves.time_s_per_a < a_stays.time_s_per_a);
        let healthy = model(FaultVector::HEALTHY.0).commutation::<true>(&[0.13; 3], 1, w);
        let e = 0.13 * w;
        assert!((healthy.time_s_per_a - 3.0 * 2e-3 / (270.0 + 2.0 * e)).abs() < 1e-9);
        assert!((healthy.drop_fraction - (4.0 * e - 270.0) / (270.0 + 2.0 * e)).abs() < 1e-5);
    }
}
