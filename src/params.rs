//! Nominal parameters of the actuator: a ~1 kW flight-control EMA on a 270 V bus.
//!
//! One table shared by the monitor model (this crate, `f32`) and the reference model
//! (`host-tests/reference`, which converts to `f64`). The values are a physically consistent
//! proposal (no published table exists; `docs/model.md`), except the nominal backlash, chosen so
//! that the paper's "1 to 100 times nominal" range ends at 5 mrad.
//!
//! Derived values: electrical time constant L/R = 4 ms; torque constant of the conducting pair
//! `Kt = 2·k_0 = 0.26 N·m/A`; no-load motor speed `V_dc/(2 k_0) ≈ 1038 rad/s`; closed position
//! loop `ω_n = sqrt(Kp·Kt·N / J_s) ≈ 49 rad/s`, `ζ ≈ 0.87` with `J_s = J_eq·N²`.

/// Physical parameters of a healthy actuator, units in the field names.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EmaParams {
    /// DC-link voltage (HVDC aircraft bus).
    pub supply_voltage_v: f32,
    /// Motor pole pairs `p`; electrical angle `θ_e = p·θ_m`.
    pub pole_pairs: f32,
    /// Per-phase winding resistance `R_0` at 20 °C.
    pub phase_resistance_ohm: f32,
    /// Per-phase inductance `L_0 = L − M`.
    pub phase_inductance_h: f32,
    /// Per-phase back-EMF constant `k_0` (V·s/rad, equal to N·m/A), trapezoid flat-top value.
    pub phase_emf_constant_v_s_per_rad: f32,
    /// Controller current saturation `I_max`.
    pub current_limit_a: f32,
    /// Hysteresis current-control half band `h` (reference model only).
    pub hysteresis_half_band_a: f32,
    /// Rotor plus first gear stage inertia `J_m`.
    pub motor_inertia_kg_m2: f32,
    /// Overall reduction `N` (motor rad per surface rad).
    pub gear_ratio: f32,
    /// Control surface inertia `J_u`.
    pub surface_inertia_kg_m2: f32,
    /// Motor-side viscous friction `C_m`.
    pub viscous_friction_n_m_s_per_rad: f32,
    /// Motor-side static (breakaway) dry friction `FSJ_0`.
    pub static_friction_n_m: f32,
    /// Motor-side dynamic (sliding) dry friction `FDJ_0`.
    pub dynamic_friction_n_m: f32,
    /// Transmission efficiency with the load opposing the motion `η_O`.
    pub efficiency_opposing: f32,
    /// Transmission efficiency with the load aiding the motion `η_A` (≤ 0: irreversible).
    pub efficiency_aiding: f32,
    /// Healthy total free play at the surface `BL_0`.
    pub nominal_backlash_rad: f32,
    /// End-stop position `±θ_max` of the surface.
    pub end_stop_rad: f32,
    /// Aerodynamic hinge-moment stiffness `K_h` at the surface.
    pub hinge_stiffness_n_m_per_rad: f32,
    /// Proportional gain of the position loop `Kp_0` (current per surface angle error).
    pub kp_a_per_rad: f32,
    /// Integral gain `Ki`.
    pub ki_a_per_rad_s: f32,
    /// Derivative gain `Kd` (derivative on measurement).
    pub kd_a_s_per_rad: f32,
    /// Control (ACE) sample period `T_ace`; also the ADC period and the monitor-model step.
    pub control_period_s: f32,
    /// First-order derivative filter time constant `τ_D`.
    pub derivative_filter_s: f32,
    /// Equivalent closed current-loop lag `τ_c` of the monitor model: the hysteresis loop follows
    /// its reference at the voltage's slew rate, seen through the current sensor's 20 kHz
    /// bandwidth, `1/(2π·20 kHz)` = 8 µs. The 0.2 ms lag of the loop is the position
    /// transducer's ([`EmaParams::position_lag_s`]), on the other side of the current loop.
    pub current_loop_lag_s: f32,
    /// RMS white noise `σ` of each phase-current sensor (datasheet or bench calibration). The
    /// monitor uses it to predict the rectification bias of the measured `I_3eq`
    /// ([`crate::conditioning::MeasuredEnvelope`]); the reference model uses it to add the noise.
    pub current_noise_a: f32,
    /// RMS white noise of the surface position transducer.
    pub position_noise_rad: f32,
    /// First-order lag `τ_θ` of the surface position transducer: the controller sees the surface
    /// angle through it (the reference model uses the same value).
    pub position_lag_s: f32,
    /// Resolution (one code) of the surface position transducer: 16 bits over ±0.6 rad.
    pub position_resolution_rad: f32,
}

impl EmaParams {
    /// The proposed nominal actuator.
    pub const NOMINAL: Self = Self {
        supply_voltage_v: 270.0,
        pole_pairs: 4.0,
        phase_resistance_ohm: 0.5,
        phase_inductance_h: 2.0e-3,
        phase_emf_constant_v_s_per_rad: 0.13,
        current_limit_a: 15.0,
        hysteresis_half_band_a: 0.3,
        motor_inertia_kg_m2: 1.5e-4,
        gear_ratio: 500.0,
        surface_inertia_kg_m2: 0.5,
        viscous_friction_n_m_s_per_rad: 1.0e-4,
        static_friction_n_m: 0.10,
        dynamic_friction_n_m: 0.07,
        efficiency_opposing: 0.85,
        efficiency_aiding: 0.75,
        nominal_backlash_rad: 5.0e-5,
        end_stop_rad: 0.6,
        hinge_stiffness_n_m_per_rad: 800.0,
        kp_a_per_rad: 700.0,
        ki_a_per_rad_s: 1500.0,
        kd_a_s_per_rad: 25.0,
        control_period_s: 1.0e-4,
        derivative_filter_s: 1.0e-3,
        current_loop_lag_s: 7.957_747e-6,
        current_noise_a: 0.02,
        position_noise_rad: 1.0e-5,
        position_lag_s: 2.0e-4,
        position_resolution_rad: 1.2 / 65536.0,
    };

    /// Inertia referred to the motor shaft, `J_eq = J_m + J_u/N²`.
    pub fn equivalent_inertia_kg_m2(&self) -> f32 {
        self.motor_inertia_kg_m2 + self.surface_inertia_kg_m2 / (self.gear_ratio * self.gear_ratio)
    }

    /// `σ_J`, the RMS current the controller's derivative on measurement puts on the pair from the
    /// position transducer's noise and resolution `q`:
    ///
    /// ```text
    /// σ_J = Kd·(α/T)·σ_θ·√(2/(2−α)),   α = T/τ_D,   σ_θ² = σ_pos² + q²/12
    /// ```
    ///
    /// (the first-order derivative filter's output variance for white input). The conditioning
    /// counts it in the rectification of the measured `I_3eq`, the monitor model in its current
    /// loop on measured currents.
    pub fn controller_jitter_a(&self) -> f32 {
        let q = self.position_resolution_rad;
        let sigma_theta = libm::sqrtf(self.position_noise_rad * self.position_noise_rad + q * q * (1.0 / 12.0));
        let alpha = self.control_period_s / self.derivative_filter_s;
        self.kd_a_s_per_rad * (alpha / self.control_period_s) * sigma_theta * libm::sqrtf(2.0 / (2.0 - alpha))
    }
}

impl Default for EmaParams {
    fn default() -> Self {
        Self::NOMINAL
    }
}
