//! Nominal parameters of the actuator: a ~1 kW flight-control EMA on a 270 V bus.
//!
//! One table shared by the monitor model (`ema-monitor`, `f32`) and the reference model
//! (`host-tests/reference`, which converts to `f64`). The values are a physically consistent
//! proposal (no published table exists; `docs/model.md`), except the nominal backlash, chosen so
//! that the paper's "1 to 100 times nominal" range ends at 5 mrad.
//!
//! Derived values: electrical time constant L/R = 4 ms; torque constant of the conducting pair
//! `Kt = 2·k_0 = 0.26 N·m/A`; no-load motor speed `V_dc/(2 k_0) ≈ 1038 rad/s`; closed position
//! loop `ω_n = sqrt(Kp·Kt·N / J_s) ≈ 49 rad/s`, `ζ ≈ 0.87` with `J_s = J_eq·N²`.
//!
//! Another actuator is described by a parameter file: [`FIELDS`] lists every field with its
//! meaning, unit and allowed range (the `ema params` template and the TOML reader of
//! `ema-params-file`, which the command line and the firmware's `EMA_PARAMS` build step share,
//! read this one table), and [`EmaParams::check`] refuses
//! a set outside those ranges or one the monitor model cannot integrate at its control period.

use core::fmt;

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
    /// (`ema_monitor::conditioning::MeasuredEnvelope`); the reference model uses it to add the noise.
    pub current_noise_a: f32,
    /// RMS white noise of the surface position transducer.
    pub position_noise_rad: f32,
    /// First-order lag `τ_θ` of the surface position transducer: the controller sees the surface
    /// angle through it (the reference model uses the same value).
    pub position_lag_s: f32,
    /// Resolution (one code) of the surface position transducer: 16 bits over ±0.6 rad.
    pub position_resolution_rad: f32,
    /// Temperature coefficient `α` of the winding resistance (copper: 3.93e-3 /K):
    /// `R(T) = R_0·(1 + α·(T − 20 °C))` ([`EmaParams::at_temperature`]).
    pub copper_alpha_per_k: f32,
    /// Temperature coefficient `β` of the magnets' flux, hence of the EMF constant (NdFeB:
    /// about −1.1e-3 /K): `k(T) = k_0·(1 + β·(T − 20 °C))`.
    pub magnet_beta_per_k: f32,
    /// Rise `γ` of the three friction terms per kelvin below 20 °C (the grease stiffens):
    /// `F(T) = F_0·(1 + γ·max(0, 20 °C − T))`; above 20 °C friction stays at `F_0`.
    pub friction_cold_per_k: f32,
    /// Lowest operating temperature the unit is declared for.
    pub temperature_min_c: f32,
    /// Highest operating temperature the unit is declared for.
    pub temperature_max_c: f32,
}

/// The temperature at which [`EmaParams`] gives `R_0`, `k_0` and the friction terms.
pub const REFERENCE_TEMPERATURE_C: f32 = 20.0;

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
        copper_alpha_per_k: 3.93e-3,
        magnet_beta_per_k: -1.1e-3,
        friction_cold_per_k: 4.0e-3,
        temperature_min_c: -40.0,
        temperature_max_c: 70.0,
    };

    /// Inertia referred to the motor shaft, `J_eq = J_m + J_u/N²`.
    pub fn equivalent_inertia_kg_m2(&self) -> f32 {
        self.motor_inertia_kg_m2 + self.surface_inertia_kg_m2 / (self.gear_ratio * self.gear_ratio)
    }

    /// A 32-bit identity of the parameter set: FNV-1a over the IEEE-754 bits of every field, in
    /// [`FIELDS`] order. Two sets with one field differing by one bit get different identities
    /// with probability `1 − 2⁻³²`; the health record keeps it to tell a record made under other
    /// parameters (`ema_monitor::persist::RecordIdentity`). An identity, not an integrity check (the
    /// store's CRC is that), so the eight-line hash is written here rather than a dependency added.
    pub fn identity(&self) -> u32 {
        const OFFSET_BASIS: u32 = 0x811c_9dc5;
        const PRIME: u32 = 0x0100_0193;
        FIELDS
            .iter()
            .flat_map(|f| f.get(self).to_bits().to_le_bytes())
            .fold(OFFSET_BASIS, |h, byte| (h ^ u32::from(byte)).wrapping_mul(PRIME))
    }

    /// The same unit at `temperature_c`: resistance, EMF constant and the three friction terms
    /// follow their coefficients from [`REFERENCE_TEMPERATURE_C`]:
    ///
    /// ```text
    /// R(T) = R_0·(1 + α·ΔT),   k(T) = k_0·(1 + β·ΔT),   F(T) = F_0·(1 + γ·max(0, −ΔT)),   ΔT = T − 20 °C
    /// ```
    ///
    /// The reference model and the monitor model both take their temperature through this one
    /// function. A temperature outside `[temperature_min_c, temperature_max_c]` is still applied
    /// (the caller decides whether to trust it); a non-finite one leaves the parameters at 20 °C.
    pub fn at_temperature(&self, temperature_c: f32) -> Self {
        if !temperature_c.is_finite() {
            return *self;
        }
        let dt = temperature_c - REFERENCE_TEMPERATURE_C;
        let friction = 1.0 + self.friction_cold_per_k * (-dt).max(0.0);
        Self {
            phase_resistance_ohm: self.phase_resistance_ohm * (1.0 + self.copper_alpha_per_k * dt),
            phase_emf_constant_v_s_per_rad: self.phase_emf_constant_v_s_per_rad * (1.0 + self.magnet_beta_per_k * dt),
            viscous_friction_n_m_s_per_rad: self.viscous_friction_n_m_s_per_rad * friction,
            static_friction_n_m: self.static_friction_n_m * friction,
            dynamic_friction_n_m: self.dynamic_friction_n_m * friction,
            ..*self
        }
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

/// One field of [`EmaParams`]: its name (the struct's, which carries the unit), meaning, unit and
/// the closed range `[min, max]` [`EmaParams::check`] accepts.
#[derive(Clone, Copy, Debug)]
pub struct ParamField {
    /// Field name, as in the struct and as the key of a parameter file.
    pub name: &'static str,
    /// One-line meaning.
    pub doc: &'static str,
    /// Unit (`1` for a dimensionless number).
    pub unit: &'static str,
    /// Smallest accepted value.
    pub min: f32,
    /// Largest accepted value.
    pub max: f32,
    /// `true` when only whole numbers are accepted.
    pub integer: bool,
    get: fn(&EmaParams) -> f32,
    set: fn(&mut EmaParams, f32),
}

impl ParamField {
    /// The field's value in `p`.
    pub fn get(&self, p: &EmaParams) -> f32 {
        (self.get)(p)
    }

    /// Sets the field's value in `p` (unchecked: [`EmaParams::check`] checks the whole set).
    pub fn set(&self, p: &mut EmaParams, value: f32) {
        (self.set)(p, value)
    }

    /// Looks a field up by name.
    pub fn find(name: &str) -> Option<&'static ParamField> {
        FIELDS.iter().find(|f| f.name == name)
    }

    /// The field's own check: finite, within `[min, max]`, whole when [`ParamField::integer`].
    pub fn check(&self, value: f32) -> Result<(), ParamsError> {
        if !value.is_finite() {
            return Err(ParamsError::NotFinite { field: self.name });
        }
        if value < self.min || value > self.max {
            return Err(ParamsError::OutOfRange { field: self.name, value, min: self.min, max: self.max });
        }
        if self.integer && libm::truncf(value) != value {
            return Err(ParamsError::NotInteger { field: self.name, value });
        }
        Ok(())
    }
}

/// One [`ParamField`] entry, its accessors generated from the field name.
macro_rules! field {
    ($name:ident, $unit:expr, $min:expr, $max:expr, $integer:expr, $doc:expr) => {
        ParamField {
            name: stringify!($name),
            doc: $doc,
            unit: $unit,
            min: $min,
            max: $max,
            integer: $integer,
            get: |p| p.$name,
            set: |p, v| p.$name = v,
        }
    };
}

/// Every field of [`EmaParams`] in declaration order, with its unit and range.
///
/// The ranges bound a flight-control EMA from a small trim-tab actuator to a primary-surface one
/// (a few hundred W to a few tens of kW); they exist to catch a mistyped unit or digit (a
/// resistance in mΩ, an inductance in mH), not to judge a design. Some zero values are allowed
/// where the physics allows them (no friction, no hinge load, no sensor noise).
///
/// A `static`, not a `const`: one table in flash however many crates read it (a `const` would be
/// copied into each, with its own copies of the accessors).
pub static FIELDS: [ParamField; 33] = [
    field!(supply_voltage_v, "V", 10.0, 1000.0, false, "DC-link voltage V_dc"),
    field!(pole_pairs, "1", 1.0, 32.0, true, "Motor pole pairs p: electrical angle = p * mechanical angle"),
    field!(phase_resistance_ohm, "ohm", 1.0e-3, 100.0, false, "Per-phase winding resistance R_0 at 20 degC"),
    field!(phase_inductance_h, "H", 1.0e-6, 1.0, false, "Per-phase inductance L_0 = L - M (self minus mutual)"),
    field!(
        phase_emf_constant_v_s_per_rad,
        "V s/rad",
        1.0e-3,
        10.0,
        false,
        "Per-phase back-EMF constant k_0 (flat-top value; torque constant of a conducting pair = 2 k_0)"
    ),
    field!(current_limit_a, "A", 0.1, 1000.0, false, "Controller current saturation I_max"),
    field!(
        hysteresis_half_band_a,
        "A",
        0.0,
        100.0,
        false,
        "Hysteresis current-control half band h (below current_limit_a)"
    ),
    field!(motor_inertia_kg_m2, "kg m^2", 1.0e-7, 1.0, false, "Rotor plus first gear stage inertia J_m"),
    field!(gear_ratio, "1", 1.0, 10000.0, false, "Overall reduction N (motor rad per surface rad)"),
    field!(surface_inertia_kg_m2, "kg m^2", 0.0, 1000.0, false, "Control surface inertia J_u"),
    field!(viscous_friction_n_m_s_per_rad, "N m s/rad", 0.0, 1.0, false, "Motor-side viscous friction C_m"),
    field!(static_friction_n_m, "N m", 0.0, 100.0, false, "Motor-side static (breakaway) dry friction FSJ_0"),
    field!(
        dynamic_friction_n_m,
        "N m",
        0.0,
        100.0,
        false,
        "Motor-side dynamic (sliding) dry friction FDJ_0 (at most static_friction_n_m)"
    ),
    field!(
        efficiency_opposing,
        "1",
        0.05,
        1.0,
        false,
        "Transmission efficiency with the load opposing the motion eta_O"
    ),
    field!(
        efficiency_aiding,
        "1",
        -1.0,
        1.0,
        false,
        "Transmission efficiency with the load aiding the motion eta_A (<= 0: irreversible)"
    ),
    field!(
        nominal_backlash_rad,
        "rad",
        0.0,
        1.0e-3,
        false,
        "Healthy total free play at the surface BL_0 (the backlash fault reaches 100 times it)"
    ),
    field!(end_stop_rad, "rad", 0.01, 1.6, false, "End-stop position +-theta_max of the surface"),
    field!(
        hinge_stiffness_n_m_per_rad,
        "N m/rad",
        0.0,
        1.0e6,
        false,
        "Aerodynamic hinge-moment stiffness K_h at the surface"
    ),
    field!(
        kp_a_per_rad,
        "A/rad",
        1.0,
        1.0e5,
        false,
        "Proportional gain of the position loop Kp_0 (current per surface angle error)"
    ),
    field!(ki_a_per_rad_s, "A/(rad s)", 0.0, 1.0e6, false, "Integral gain Ki"),
    field!(kd_a_s_per_rad, "A s/rad", 0.0, 1.0e4, false, "Derivative gain Kd (derivative on measurement)"),
    field!(
        control_period_s,
        "s",
        1.0e-5,
        1.0e-3,
        false,
        "Control (ACE) sample period T: also the ADC period and the monitor model's step"
    ),
    field!(
        derivative_filter_s,
        "s",
        1.0e-5,
        1.0,
        false,
        "First-order derivative filter time constant tau_D (longer than control_period_s)"
    ),
    field!(
        current_loop_lag_s,
        "s",
        1.0e-7,
        1.0e-2,
        false,
        "Equivalent closed current-loop lag tau_c of the monitor model (current sensor bandwidth: 1/(2 pi f))"
    ),
    field!(current_noise_a, "A", 0.0, 10.0, false, "RMS white noise of each phase-current sensor"),
    field!(position_noise_rad, "rad", 0.0, 1.0e-2, false, "RMS white noise of the surface position transducer"),
    field!(position_lag_s, "s", 1.0e-6, 0.1, false, "First-order lag tau_theta of the surface position transducer"),
    field!(
        position_resolution_rad,
        "rad",
        1.0e-9,
        1.0e-2,
        false,
        "Resolution (one code) of the surface position transducer"
    ),
    field!(
        copper_alpha_per_k,
        "1/K",
        0.0,
        1.0e-2,
        false,
        "Temperature coefficient of the winding resistance: R(T) = R_0 (1 + alpha (T - 20 degC))"
    ),
    field!(
        magnet_beta_per_k,
        "1/K",
        -1.0e-2,
        0.0,
        false,
        "Temperature coefficient of the EMF constant: k(T) = k_0 (1 + beta (T - 20 degC))"
    ),
    field!(
        friction_cold_per_k,
        "1/K",
        0.0,
        5.0e-2,
        false,
        "Rise of the friction terms per kelvin below 20 degC: F(T) = F_0 (1 + gamma max(0, 20 degC - T))"
    ),
    field!(temperature_min_c, "degC", -100.0, 200.0, false, "Lowest declared operating temperature"),
    field!(
        temperature_max_c,
        "degC",
        -100.0,
        200.0,
        false,
        "Highest declared operating temperature (at least temperature_min_c)"
    ),
];

/// Why a parameter set is refused ([`EmaParams::check`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParamsError {
    /// The field is NaN or infinite.
    NotFinite {
        /// Field name.
        field: &'static str,
    },
    /// The field is outside its range `[min, max]`.
    OutOfRange {
        /// Field name.
        field: &'static str,
        /// The value given.
        value: f32,
        /// Smallest accepted value.
        min: f32,
        /// Largest accepted value.
        max: f32,
    },
    /// The field must be a whole number.
    NotInteger {
        /// Field name.
        field: &'static str,
        /// The value given.
        value: f32,
    },
    /// A relation between fields does not hold; `field` is the one named as the culprit.
    Relation {
        /// Field name.
        field: &'static str,
        /// The relation that must hold.
        rule: &'static str,
    },
}

impl ParamsError {
    /// The field the error is about.
    pub fn field(&self) -> &'static str {
        match *self {
            ParamsError::NotFinite { field }
            | ParamsError::OutOfRange { field, .. }
            | ParamsError::NotInteger { field, .. }
            | ParamsError::Relation { field, .. } => field,
        }
    }
}

/// A value in a message: Rust's shortest round-trip form, in exponent form outside 1e-6 to 1e9
/// (`1e38`, not its 39 digits).
struct Shown(f32);

impl fmt::Display for Shown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        if x == 0.0 || !x.is_finite() || (1e-6..1e9).contains(&x.abs()) {
            write!(f, "{x}")
        } else {
            write!(f, "{x:e}")
        }
    }
}

impl fmt::Display for ParamsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ParamsError::NotFinite { field } => write!(f, "{field} must be a finite number"),
            ParamsError::OutOfRange { field, value, min, max } => {
                write!(f, "{field} = {} is outside its range [{}, {}]", Shown(value), Shown(min), Shown(max))
            }
            ParamsError::NotInteger { field, value } => write!(f, "{field} = {} must be a whole number", Shown(value)),
            ParamsError::Relation { field, rule } => write!(f, "{field}: {rule}"),
        }
    }
}

/// Smallest ratio of the electrical (`L_0/R_0`) and mechanical (`J_eq·R_0/(2·k_0²)`) time
/// constants to the control period: the monitor model integrates both with explicit steps of one
/// period (`ema_monitor::model`), whose error stays a few percent at ten steps per time constant (and
/// which diverge beyond two periods per time constant).
pub const MIN_STEPS_PER_TIME_CONSTANT: f32 = 10.0;

impl EmaParams {
    /// Checks every field against its range in [`FIELDS`], then the relations the models need:
    ///
    /// - `dynamic_friction_n_m ≤ static_friction_n_m` (sliding friction does not exceed breakaway);
    /// - `hysteresis_half_band_a < current_limit_a`;
    /// - `control_period_s < derivative_filter_s` (the filter's discrete gain `T/τ_D` below 1);
    /// - `position_resolution_rad < end_stop_rad`;
    /// - `temperature_min_c ≤ temperature_max_c`;
    /// - `L_0/R_0 ≥ 10·T` and `τ_m = J_eq·R_0/(2·k_0²) ≥ 10·T` ([`MIN_STEPS_PER_TIME_CONSTANT`]):
    ///   the pair's resistance `2R_0`, torque constant `2k_0` and back-EMF `2k_0·ω` give the
    ///   mechanical time constant `J_eq·2R_0/(2k_0)²`.
    ///
    /// Returns the first violation, in [`FIELDS`] order.
    pub fn check(&self) -> Result<(), ParamsError> {
        for field in FIELDS.iter() {
            field.check(field.get(self))?;
        }
        let relation = |ok: bool, field, rule| if ok { Ok(()) } else { Err(ParamsError::Relation { field, rule }) };
        relation(
            self.dynamic_friction_n_m <= self.static_friction_n_m,
            "dynamic_friction_n_m",
            "must not exceed static_friction_n_m",
        )?;
        relation(
            self.hysteresis_half_band_a < self.current_limit_a,
            "hysteresis_half_band_a",
            "must be below current_limit_a",
        )?;
        relation(
            self.control_period_s < self.derivative_filter_s,
            "derivative_filter_s",
            "must be longer than control_period_s",
        )?;
        relation(
            self.position_resolution_rad < self.end_stop_rad,
            "position_resolution_rad",
            "must be below end_stop_rad",
        )?;
        let min_tau = MIN_STEPS_PER_TIME_CONSTANT * self.control_period_s;
        relation(
            self.phase_inductance_h / self.phase_resistance_ohm >= min_tau,
            "phase_inductance_h",
            "the electrical time constant phase_inductance_h / phase_resistance_ohm must be at least 10 control periods",
        )?;
        let k0 = self.phase_emf_constant_v_s_per_rad;
        relation(
            self.equivalent_inertia_kg_m2() * self.phase_resistance_ohm / (2.0 * k0 * k0) >= min_tau,
            "motor_inertia_kg_m2",
            "the mechanical time constant J_eq * phase_resistance_ohm / (2 phase_emf_constant^2) must be at least 10 control periods",
        )?;
        relation(
            self.temperature_min_c <= self.temperature_max_c,
            "temperature_max_c",
            "must not be below temperature_min_c",
        )?;
        Ok(())
    }
}

impl Default for EmaParams {
    fn default() -> Self {
        Self::NOMINAL
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nominal_passes_and_the_table_covers_every_field() {
        assert_eq!(EmaParams::NOMINAL.check(), Ok(()));
        // every field is in the table once, in declaration order, and its accessors are its own
        let mut p = EmaParams::NOMINAL;
        for (i, f) in FIELDS.iter().enumerate() {
            assert!(FIELDS[..i].iter().all(|g| g.name != f.name), "{} twice", f.name);
            assert!(f.min <= f.get(&EmaParams::NOMINAL) && f.get(&EmaParams::NOMINAL) <= f.max, "{}", f.name);
            f.set(&mut p, -1.0e9 - i as f32);
        }
        for (i, f) in FIELDS.iter().enumerate() {
            assert_eq!(f.get(&p), -1.0e9 - i as f32, "{}", f.name);
        }
        // a set that moves every field leaves nothing at nominal: every field is reached
        let fields = [
            p.supply_voltage_v,
            p.pole_pairs,
            p.phase_resistance_ohm,
            p.phase_inductance_h,
            p.phase_emf_constant_v_s_per_rad,
            p.current_limit_a,
            p.hysteresis_half_band_a,
            p.motor_inertia_kg_m2,
            p.gear_ratio,
            p.surface_inertia_kg_m2,
            p.viscous_friction_n_m_s_per_rad,
            p.static_friction_n_m,
            p.dynamic_friction_n_m,
            p.efficiency_opposing,
            p.efficiency_aiding,
            p.nominal_backlash_rad,
            p.end_stop_rad,
            p.hinge_stiffness_n_m_per_rad,
            p.kp_a_per_rad,
            p.ki_a_per_rad_s,
            p.kd_a_s_per_rad,
            p.control_period_s,
            p.derivative_filter_s,
            p.current_loop_lag_s,
            p.current_noise_a,
            p.position_noise_rad,
            p.position_lag_s,
            p.position_resolution_rad,
            p.copper_alpha_per_k,
            p.magnet_beta_per_k,
            p.friction_cold_per_k,
            p.temperature_min_c,
            p.temperature_max_c,
        ];
        assert!(fields.iter().all(|v| *v <= -1.0e9), "{fields:?}");
        assert_eq!(ParamField::find("gear_ratio").map(|f| f.unit), Some("1"));
        assert!(ParamField::find("gear").is_none());
    }

    #[test]
    fn ranges_refuse_non_finite_out_of_range_and_fractional_values() {
        let with = |name: &str, v: f32| {
            let mut p = EmaParams::NOMINAL;
            ParamField::find(name).unwrap().set(&mut p, v);
            p.check()
        };
        assert_eq!(
            with("phase_resistance_ohm", f32::NAN),
            Err(ParamsError::NotFinite { field: "phase_resistance_ohm" })
        );
        assert_eq!(with("gear_ratio", f32::INFINITY), Err(ParamsError::NotFinite { field: "gear_ratio" }));
        assert_eq!(with("gear_ratio", 0.0).map_err(|e| e.field()), Err("gear_ratio"));
        assert_eq!(with("pole_pairs", 0.0).map_err(|e| e.field()), Err("pole_pairs"));
        assert_eq!(with("pole_pairs", 4.5), Err(ParamsError::NotInteger { field: "pole_pairs", value: 4.5 }));
        assert_eq!(with("efficiency_opposing", 1.01).map_err(|e| e.field()), Err("efficiency_opposing"));
        assert_eq!(with("efficiency_opposing", 0.0).map_err(|e| e.field()), Err("efficiency_opposing"));
        assert_eq!(with("efficiency_aiding", -0.5), Ok(()));
        assert_eq!(with("control_period_s", 2.0e-3).map_err(|e| e.field()), Err("control_period_s"));
        assert_eq!(with("control_period_s", 5.0e-6).map_err(|e| e.field()), Err("control_period_s"));
        // a resistance typed in milliohm
        let e = with("phase_resistance_ohm", 500.0).unwrap_err();
        assert_eq!(e, ParamsError::OutOfRange { field: "phase_resistance_ohm", value: 500.0, min: 1.0e-3, max: 100.0 });
        let mut text = heapless::String::<128>::new();
        core::fmt::write(&mut text, format_args!("{e}")).unwrap();
        assert_eq!(text.as_str(), "phase_resistance_ohm = 500 is outside its range [0.001, 100]");
        // a value far out of range prints in exponent form, not at full length
        let e = with("phase_resistance_ohm", 1e38).unwrap_err();
        text.clear();
        core::fmt::write(&mut text, format_args!("{e}")).unwrap();
        assert_eq!(text.as_str(), "phase_resistance_ohm = 1e38 is outside its range [0.001, 100]");
    }

    #[test]
    fn temperature_moves_resistance_emf_and_cold_friction_only() {
        let n = EmaParams::NOMINAL;
        assert_eq!(n.at_temperature(REFERENCE_TEMPERATURE_C), n);
        assert_eq!(n.at_temperature(f32::NAN), n);
        let cold = n.at_temperature(-40.0);
        assert!((cold.phase_resistance_ohm - 0.5 * (1.0 - 60.0 * 3.93e-3)).abs() < 1e-6);
        assert!((cold.phase_emf_constant_v_s_per_rad - 0.13 * (1.0 + 60.0 * 1.1e-3)).abs() < 1e-6);
        assert!((cold.static_friction_n_m - 0.10 * 1.24).abs() < 1e-6);
        assert!((cold.dynamic_friction_n_m / cold.static_friction_n_m - 0.7).abs() < 1e-6);
        let hot = n.at_temperature(70.0);
        assert!((hot.phase_resistance_ohm - 0.5 * (1.0 + 50.0 * 3.93e-3)).abs() < 1e-6);
        assert_eq!(hot.static_friction_n_m, n.static_friction_n_m);
        let moved = |p: EmaParams| EmaParams { phase_resistance_ohm: 0.0, phase_emf_constant_v_s_per_rad: 0.0, ..p };
        assert_eq!(moved(hot), moved(n));
        assert_eq!(cold.check(), Ok(()));
        assert_eq!(hot.check(), Ok(()));
    }

    #[test]
    fn relations_between_fields() {
        let relation = |p: EmaParams| match p.check() {
            Err(ParamsError::Relation { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        let n = EmaParams::NOMINAL;
        assert_eq!(relation(EmaParams { dynamic_friction_n_m: 0.2, ..n }), "dynamic_friction_n_m");
        assert_eq!(relation(EmaParams { hysteresis_half_band_a: 20.0, ..n }), "hysteresis_half_band_a");
        assert_eq!(relation(EmaParams { derivative_filter_s: 1.0e-4, ..n }), "derivative_filter_s");
        assert_eq!(relation(EmaParams { temperature_min_c: 80.0, ..n }), "temperature_max_c");
        // L/R = 0.2 ms at a 0.1 ms period: explicit steps of T would be inaccurate
        assert_eq!(relation(EmaParams { phase_inductance_h: 1.0e-4, ..n }), "phase_inductance_h");
        // J_eq·R/(2k²) = 2.25 ms nominal; a 1/100 rotor brings it near 0.03 ms
        assert_eq!(
            relation(EmaParams { motor_inertia_kg_m2: 1.5e-6, surface_inertia_kg_m2: 0.0, ..n }),
            "motor_inertia_kg_m2"
        );
        // a plausible other actuator passes
        let other = EmaParams {
            phase_resistance_ohm: 0.65,
            phase_emf_constant_v_s_per_rad: 0.117,
            motor_inertia_kg_m2: 1.875e-4,
            kp_a_per_rad: 595.0,
            ..n
        };
        assert_eq!(other.check(), Ok(()));
    }
}
