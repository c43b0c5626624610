//! Physical parameters of the simulated actuator in `f64`: the shared nominal table, the fault
//! mapping of the shared contract, and the effects on top.

use core::f64::consts::PI;

use ema_monitor::{EmaParams, FaultVector};

use crate::effects::{maxima, Effect, Effects};

/// How the free play between the gear output and the surface is modelled when the transmission is rigid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BacklashModel {
    /// Kinematic play operator `θ_u ← clamp(θ_u, θ_m/N − BL/2, θ_m/N + BL/2)` (docs/model.md), the
    /// monitor model's choice: one mechanical degree of freedom, `J_eq = J_m + J_u/N²`, the hinge load
    /// always reflected to the motor.
    #[default]
    Play,
    /// Two degrees of freedom: the surface has its own inertia and moves freely inside the gap under the
    /// hinge load; contact is a stiff, heavily damped spring (1 kHz contact mode, damping ratio 0.5,
    /// restitution ≈ 0.16), i.e. nearly rigid and nearly inelastic.
    FreeSurface,
}

/// Widens an `f32` parameter to the `f64` of its shortest decimal form (`0.13f32` → `0.13`, not
/// `0.12999999523…`): the nominal table is decimal, the `f32` only its on-board representation.
pub fn widen(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(f64::from(x))
}

/// Contact mode of [`BacklashModel::FreeSurface`], Hz.
pub const FREE_SURFACE_CONTACT_MODE_HZ: f64 = 1000.0;
/// Contact damping ratio of [`BacklashModel::FreeSurface`].
pub const FREE_SURFACE_CONTACT_DAMPING_RATIO: f64 = 0.5;

/// Stiffness and damping of a compliant transmission, referred to the surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transmission {
    /// `K_tr` at the surface.
    pub stiffness_n_m_per_rad: f64,
    /// `C_tr` at the surface (acts only in contact).
    pub damping_n_m_s_per_rad: f64,
}

impl Transmission {
    /// A transmission whose surface-side mode `sqrt(K_tr/J_u)` is at `mode_hz` with damping ratio `zeta`.
    pub fn from_mode(surface_inertia_kg_m2: f64, mode_hz: f64, zeta: f64) -> Self {
        let w = 2.0 * PI * mode_hz;
        let k = surface_inertia_kg_m2 * w * w;
        Self { stiffness_n_m_per_rad: k, damping_n_m_s_per_rad: 2.0 * zeta * (k * surface_inertia_kg_m2).sqrt() }
    }
}

/// Every physical parameter the reference model uses, after faults and effects (units in the names).
///
/// Phase quantities are per phase `j ∈ {a, b, c}` (index 0, 1, 2):
/// `R_j = R_0·(1 − s_j)·(1 + α·ΔT)`, `L_j = L_0·(1 − s_j)²`, `k_j = k_0·(1 − s_j)·(1 + β·ΔT)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plant {
    /// DC-link voltage `V_dc`.
    pub supply_voltage_v: f64,
    /// Pole pairs `p`.
    pub pole_pairs: f64,
    /// `R_j`.
    pub phase_resistance_ohm: [f64; 3],
    /// `L_j` (self minus mutual).
    pub phase_inductance_h: [f64; 3],
    /// Flat-top back-EMF constant `k_j` before eccentricity and saturation.
    pub phase_emf_constant_v_s_per_rad: [f64; 3],
    /// Normalized static eccentricity `ζ`.
    pub eccentricity: f64,
    /// Angle of the minimum air gap `φ`.
    pub eccentricity_phase_rad: f64,
    /// Width of each back-EMF ramp (π/6 for the ideal 120° flat top), electrical rad.
    pub emf_ramp_width_rad: f64,
    /// Saturation current `I_sat` (`∞` without the effect).
    pub saturation_current_a: f64,
    /// Controller current limit `I_max`.
    pub current_limit_a: f64,
    /// Hysteresis half band `h`.
    pub hysteresis_half_band_a: f64,
    /// Hall offset `δ_H`, electrical rad.
    pub hall_offset_rad: f64,
    /// Dead-time/device voltage error per conducting phase `ΔV`.
    pub dead_time_v: f64,
    /// Current-sensor offsets `o_j`.
    pub current_sensor_offset_a: [f64; 3],
    /// Current-sensor gain errors `g_j`.
    pub current_sensor_gain_error: [f64; 3],
    /// DC-link source resistance `R_bus`.
    pub bus_resistance_ohm: f64,
    /// Motor-side inertia `J_m`.
    pub motor_inertia_kg_m2: f64,
    /// Reduction `N`.
    pub gear_ratio: f64,
    /// Surface inertia `J_u`.
    pub surface_inertia_kg_m2: f64,
    /// Motor-side viscous friction `C_m` (plus the viscous effect).
    pub viscous_friction_n_m_s_per_rad: f64,
    /// Breakaway friction `FSJ` (plus Stribeck stiction).
    pub static_friction_n_m: f64,
    /// Sliding friction `FDJ`.
    pub dynamic_friction_n_m: f64,
    /// Stribeck excess at zero speed, `s·(2·FSJ − FDJ)` (0 without the effect).
    pub stribeck_excess_n_m: f64,
    /// Stribeck velocity `ω_s`.
    pub stribeck_speed_rad_per_s: f64,
    /// `η_O`.
    pub efficiency_opposing: f64,
    /// `η_A`.
    pub efficiency_aiding: f64,
    /// Cogging amplitude.
    pub cogging_torque_n_m: f64,
    /// Total free play `BL` at the surface.
    pub backlash_rad: f64,
    /// End stops `±θ_max`.
    pub end_stop_rad: f64,
    /// Hinge stiffness `K_h`.
    pub hinge_stiffness_n_m_per_rad: f64,
    /// Compliant transmission (2-DOF mechanics) or `None` (rigid, play operator).
    pub transmission: Option<Transmission>,
    /// Proportional gain after drift `Kp`.
    pub kp_a_per_rad: f64,
    /// Integral gain `Ki`.
    pub ki_a_per_rad_s: f64,
    /// Derivative gain `Kd`.
    pub kd_a_s_per_rad: f64,
    /// ACE period `T`.
    pub control_period_s: f64,
    /// Derivative filter `τ_D`.
    pub derivative_filter_s: f64,
}

impl Plant {
    /// The actuator `nominal` with the faults `k` and the `effects` applied.
    ///
    /// Faults go through [`FaultVector::physical`] (the one mapping); `f32` values are widened by [`widen`].
    pub fn new(nominal: &EmaParams, faults: &FaultVector, effects: &Effects, backlash: BacklashModel) -> Self {
        let n = nominal;
        let f = faults.physical(n);
        let w = widen;
        let s = |e: Effect| effects.get(e);

        let d_t = s(Effect::WindingTemperature) * maxima::WINDING_TEMPERATURE_RISE_K;
        let r_scale = 1.0 + maxima::COPPER_ALPHA_PER_K * d_t;
        let k_scale = 1.0 + maxima::MAGNET_BETA_PER_K * d_t;
        let mut r = [0.0; 3];
        let mut l = [0.0; 3];
        let mut k = [0.0; 3];
        for j in 0..3 {
            let healthy = 1.0 - w(f.shorted_fraction[j]);
            r[j] = w(n.phase_resistance_ohm) * healthy * r_scale;
            l[j] = w(n.phase_inductance_h) * healthy * healthy;
            k[j] = w(n.phase_emf_constant_v_s_per_rad) * healthy * k_scale;
        }
        let fsj = w(f.static_friction_n_m);
        let fdj = w(f.dynamic_friction_n_m);
        let s_str = s(Effect::Stribeck);
        let s_sat = s(Effect::Saturation);
        let s_cmp = s(Effect::Compliance);
        let surface_inertia = w(n.surface_inertia_kg_m2);
        let transmission = if s_cmp >= maxima::COMPLIANCE_RIGID_BELOW {
            Some(Transmission::from_mode(
                surface_inertia,
                maxima::COMPLIANCE_MODE_HZ / s_cmp,
                maxima::COMPLIANCE_DAMPING_RATIO,
            ))
        } else {
            match backlash {
                BacklashModel::Play => None,
                BacklashModel::FreeSurface => Some(Transmission::from_mode(
                    surface_inertia,
                    FREE_SURFACE_CONTACT_MODE_HZ,
                    FREE_SURFACE_CONTACT_DAMPING_RATIO,
                )),
            }
        };
        let s_off = s(Effect::SensorOffset);
        Plant {
            supply_voltage_v: w(n.supply_voltage_v),
            pole_pairs: w(n.pole_pairs),
            phase_resistance_ohm: r,
            phase_inductance_h: l,
            phase_emf_constant_v_s_per_rad: k,
            eccentricity: w(f.eccentricity),
            eccentricity_phase_rad: w(f.eccentricity_phase_rad),
            emf_ramp_width_rad: PI / 6.0
                + s(Effect::EmfHarmonics) * maxima::EMF_FLAT_TOP_NARROWING_DEG.to_radians() / 2.0,
            saturation_current_a: if s_sat > 0.0 { maxima::SATURATION_CURRENT_A / s_sat } else { f64::INFINITY },
            current_limit_a: w(n.current_limit_a),
            hysteresis_half_band_a: w(n.hysteresis_half_band_a),
            hall_offset_rad: s(Effect::HallMisalignment) * maxima::HALL_OFFSET_DEG.to_radians(),
            dead_time_v: s(Effect::DeadTime) * maxima::DEAD_TIME_V,
            current_sensor_offset_a: maxima::SENSOR_OFFSET_A.map(|o| s_off * o),
            current_sensor_gain_error: maxima::SENSOR_GAIN.map(|g| s_off * g),
            bus_resistance_ohm: s(Effect::BusSag) * maxima::BUS_RESISTANCE_OHM,
            motor_inertia_kg_m2: w(n.motor_inertia_kg_m2),
            gear_ratio: w(n.gear_ratio),
            surface_inertia_kg_m2: surface_inertia,
            viscous_friction_n_m_s_per_rad: w(n.viscous_friction_n_m_s_per_rad)
                + s(Effect::Viscous) * maxima::VISCOUS_N_M_S_PER_RAD,
            static_friction_n_m: fsj * (1.0 + s_str * maxima::STRIBECK_STICTION_GAIN),
            dynamic_friction_n_m: fdj,
            stribeck_excess_n_m: s_str * ((1.0 + maxima::STRIBECK_STICTION_GAIN) * fsj - fdj),
            stribeck_speed_rad_per_s: maxima::STRIBECK_SPEED_RAD_PER_S,
            efficiency_opposing: w(n.efficiency_opposing),
            efficiency_aiding: w(n.efficiency_aiding),
            cogging_torque_n_m: s(Effect::Cogging) * maxima::COGGING_TORQUE_N_M,
            backlash_rad: w(f.backlash_rad),
            end_stop_rad: w(n.end_stop_rad),
            hinge_stiffness_n_m_per_rad: w(n.hinge_stiffness_n_m_per_rad)
                * (1.0 + s(Effect::HingeStiffness) * maxima::HINGE_STIFFNESS_GAIN),
            transmission,
            kp_a_per_rad: w(f.kp_a_per_rad),
            ki_a_per_rad_s: w(n.ki_a_per_rad_s),
            kd_a_s_per_rad: w(n.kd_a_s_per_rad),
            control_period_s: w(n.control_period_s),
            derivative_filter_s: w(n.derivative_filter_s),
        }
    }

    /// Inertia at the motor shaft of the rigid 1-DOF model, `J_eq = J_m + J_u/N²`.
    pub fn equivalent_inertia_kg_m2(&self) -> f64 {
        self.motor_inertia_kg_m2 + self.surface_inertia_kg_m2 / (self.gear_ratio * self.gear_ratio)
    }
}
