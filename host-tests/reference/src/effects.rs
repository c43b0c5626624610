//! Effects the monitor model lacks (docs/model.md), each OFF by default with a severity `s ∈ [0, 1]`.
//!
//! A severity maps to a physical magnitude; `s = 1` is the documented maximum of the table in the
//! crate documentation (and `host-tests/reference/README.md`). The mapping is linear in `s` unless
//! the table says otherwise.

use core::fmt;
use core::str::FromStr;

/// Number of effects in the catalogue.
pub const EFFECT_COUNT: usize = 12;

/// One unmodelled effect, by its command-line ID.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Effect {
    /// Cogging torque `A·sin(24·θ_m)`, `A = s·0.04 N·m` (12 slots / 8 poles: 24 cycles per revolution).
    Cogging,
    /// Velocity-weakening (Stribeck) dry friction: breakaway `FSJ·(1+s)`, sliding
    /// `FDJ + s·(2·FSJ − FDJ)·exp(−(ω/ω_s)²)`, `ω_s = 5 rad/s` (motor side).
    Stribeck,
    /// Extra viscous friction (cold grease) at the motor shaft, `ΔC = s·5e-4 N·m·s/rad` (6× nominal at `s = 1`).
    Viscous,
    /// Winding temperature rise `ΔT = s·100 K`: `R×(1 + 3.93e-3·ΔT)`, `k_e×(1 − 1.1e-3·ΔT)` (copper, NdFeB).
    WindingTemperature,
    /// Non-ideal trapezoid: back-EMF flat top narrowed from 120° to `120° − s·40°` electrical.
    EmfHarmonics,
    /// Inverter dead time and device drops: `−sign(i_j)·ΔV` on each conducting phase, `ΔV = s·8 V`.
    DeadTime,
    /// Current-sensor error `i_meas = (1 + g_j)·i_j + o_j`, `o = s·(0.2, −0.1, 0.15) A`,
    /// `g = s·(0.02, −0.02, 0.01)`; the hysteresis controller regulates the measured current.
    SensorOffset,
    /// Aerodynamic hinge stiffness above nominal, `K_h×(1 + s)` (2× at `s = 1`).
    HingeStiffness,
    /// Magnetic saturation `k_j×1/(1 + (I/I_sat)²)`, `I = ½Σ|i_j|`, `I_sat = 30 A / s` (−20 % torque at 15 A, `s = 1`).
    Saturation,
    /// Hall-sensor misalignment: `δ_H = s·10°` electrical added to `θ_e` in the Hall logic only.
    HallMisalignment,
    /// Finite transmission stiffness between gear output and surface: mode at `f_r = 50 Hz / s`
    /// (`K_tr = J_u·(2π f_r)²`, damping ratio 0.2); `s < 0.0025` (mode above 20 kHz) is rigid.
    Compliance,
    /// DC-link sag under load: `V_dc,eff = V_dc − R_bus·Ī_dc`, `R_bus = s·3 Ω`, `Ī_dc` the DC-link
    /// current low-passed at 1 ms (DC-link capacitor).
    BusSag,
}

impl Effect {
    /// Every effect, in catalogue order.
    pub const ALL: [Effect; EFFECT_COUNT] = [
        Effect::Cogging,
        Effect::Stribeck,
        Effect::Viscous,
        Effect::WindingTemperature,
        Effect::EmfHarmonics,
        Effect::DeadTime,
        Effect::SensorOffset,
        Effect::HingeStiffness,
        Effect::Saturation,
        Effect::HallMisalignment,
        Effect::Compliance,
        Effect::BusSag,
    ];

    /// The command-line ID (`cogging`, `stribeck`, …).
    pub const fn id(self) -> &'static str {
        match self {
            Effect::Cogging => "cogging",
            Effect::Stribeck => "stribeck",
            Effect::Viscous => "viscous",
            Effect::WindingTemperature => "winding_temperature",
            Effect::EmfHarmonics => "emf_harmonics",
            Effect::DeadTime => "dead_time",
            Effect::SensorOffset => "sensor_offset",
            Effect::HingeStiffness => "hinge_stiffness",
            Effect::Saturation => "saturation",
            Effect::HallMisalignment => "hall_misalignment",
            Effect::Compliance => "compliance",
            Effect::BusSag => "bus_sag",
        }
    }

    /// What severity 1 means physically (one line, for help texts and reports).
    pub const fn maximum(self) -> &'static str {
        match self {
            Effect::Cogging => "cogging torque 0.04 N·m, 24 cycles/rev",
            Effect::Stribeck => "stiction 2×FSJ, Stribeck decay over 5 rad/s",
            Effect::Viscous => "+5e-4 N·m·s/rad viscous friction (6× nominal)",
            Effect::WindingTemperature => "+100 K: R +39 %, k_e −11 %",
            Effect::EmfHarmonics => "back-EMF flat top 80° instead of 120°",
            Effect::DeadTime => "8 V per phase against the current",
            Effect::SensorOffset => "offsets (0.2, −0.1, 0.15) A, gains (+2, −2, +1) %",
            Effect::HingeStiffness => "hinge stiffness 2× nominal",
            Effect::Saturation => "I_sat = 30 A (−20 % torque at 15 A)",
            Effect::HallMisalignment => "Hall offset 10° electrical",
            Effect::Compliance => "transmission mode at 50 Hz (damping ratio 0.2)",
            Effect::BusSag => "3 Ω DC-link source resistance",
        }
    }

    /// Position in [`Effect::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The valid IDs, comma separated (for error messages).
    pub fn valid_ids() -> String {
        Effect::ALL.iter().map(|e| e.id()).collect::<Vec<_>>().join(", ")
    }
}

impl fmt::Display for Effect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.id())
    }
}

/// An effect ID that is not in the catalogue.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownEffect(pub String);

impl fmt::Display for UnknownEffect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown effect '{}'; valid effects: {}", self.0, Effect::valid_ids())
    }
}

impl std::error::Error for UnknownEffect {}

impl FromStr for Effect {
    type Err = UnknownEffect;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Effect::ALL.iter().copied().find(|e| e.id() == s).ok_or_else(|| UnknownEffect(s.to_owned()))
    }
}

/// Why a severity was refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeverityOutOfRange {
    /// The effect.
    pub effect: Effect,
    /// The refused value.
    pub severity: f64,
}

impl fmt::Display for SeverityOutOfRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "severity {} of effect '{}' is outside [0, 1]", self.severity, self.effect)
    }
}

impl std::error::Error for SeverityOutOfRange {}

/// Severities of all effects (0 = off, the default).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Effects([f64; EFFECT_COUNT]);

impl Effects {
    /// Every effect off.
    pub const NONE: Self = Self([0.0; EFFECT_COUNT]);

    /// Sets one severity; refuses NaN and values outside `[0, 1]`.
    pub fn set(&mut self, effect: Effect, severity: f64) -> Result<(), SeverityOutOfRange> {
        if !(0.0..=1.0).contains(&severity) {
            return Err(SeverityOutOfRange { effect, severity });
        }
        self.0[effect.index()] = severity;
        Ok(())
    }

    /// Builder form of [`Effects::set`].
    pub fn with(mut self, effect: Effect, severity: f64) -> Result<Self, SeverityOutOfRange> {
        self.set(effect, severity)?;
        Ok(self)
    }

    /// Severity of `effect` (0 when off).
    pub fn get(&self, effect: Effect) -> f64 {
        self.0[effect.index()]
    }

    /// The effects that are on, with their severities, in catalogue order.
    pub fn active(&self) -> impl Iterator<Item = (Effect, f64)> + '_ {
        Effect::ALL.iter().map(|&e| (e, self.get(e))).filter(|&(_, s)| s > 0.0)
    }

    /// `true` when every severity is finite and inside `[0, 1]`.
    pub fn is_valid(&self) -> bool {
        self.0.iter().all(|s| (0.0..=1.0).contains(s))
    }
}

/// Maxima of the effects (`s = 1`). The ten library effects' numbers come from the monitor's own
/// table (`ema_monitor::effects::maxima`, widened from `f32`), so the severity the discrepancy
/// workflow estimates means the same physical magnitude on both sides; compliance and bus sag
/// (outside the library) are the reference model's alone.
pub mod maxima {
    use ema_monitor::effects::maxima as lib;

    /// Cogging torque amplitude, N·m.
    pub const COGGING_TORQUE_N_M: f64 = lib::COGGING_TORQUE_N_M as f64;
    /// Cogging cycles per mechanical revolution (LCM of 12 slots and 8 poles).
    pub const COGGING_CYCLES_PER_REV: f64 = lib::COGGING_CYCLES_PER_REV as f64;
    /// Stiction increase: breakaway `FSJ·(1 + s·STRIBECK_STICTION_GAIN)`.
    pub const STRIBECK_STICTION_GAIN: f64 = lib::STRIBECK_STICTION_GAIN as f64;
    /// Stribeck velocity at the motor, rad/s.
    pub const STRIBECK_SPEED_RAD_PER_S: f64 = lib::STRIBECK_SPEED_RAD_PER_S as f64;
    /// Extra viscous coefficient at the motor, N·m·s/rad.
    pub const VISCOUS_N_M_S_PER_RAD: f64 = lib::VISCOUS_N_M_S_PER_RAD as f64;
    /// Winding temperature rise, K.
    pub const WINDING_TEMPERATURE_RISE_K: f64 = lib::WINDING_TEMPERATURE_RISE_K as f64;
    /// Copper resistance temperature coefficient, 1/K.
    pub const COPPER_ALPHA_PER_K: f64 = lib::COPPER_ALPHA_PER_K as f64;
    /// NdFeB back-EMF temperature coefficient, 1/K (negative).
    pub const MAGNET_BETA_PER_K: f64 = lib::MAGNET_BETA_PER_K as f64;
    /// Flat-top narrowing of the back-EMF trapezoid, electrical degrees.
    pub const EMF_FLAT_TOP_NARROWING_DEG: f64 = lib::EMF_FLAT_TOP_NARROWING_DEG as f64;
    /// Dead-time and device voltage error per phase, V.
    pub const DEAD_TIME_V: f64 = lib::DEAD_TIME_V as f64;
    /// Current-sensor offsets of phases a, b, c, A.
    pub const SENSOR_OFFSET_A: [f64; 3] =
        [lib::SENSOR_OFFSET_A[0] as f64, lib::SENSOR_OFFSET_A[1] as f64, lib::SENSOR_OFFSET_A[2] as f64];
    /// Current-sensor gain errors of phases a, b, c (relative).
    pub const SENSOR_GAIN: [f64; 3] =
        [lib::SENSOR_GAIN[0] as f64, lib::SENSOR_GAIN[1] as f64, lib::SENSOR_GAIN[2] as f64];
    /// Hinge stiffness increase: `K_h·(1 + s·HINGE_STIFFNESS_GAIN)`.
    pub const HINGE_STIFFNESS_GAIN: f64 = lib::HINGE_STIFFNESS_GAIN as f64;
    /// Saturation current at `s = 1`, A (`I_sat = SATURATION_CURRENT_A / s`).
    pub const SATURATION_CURRENT_A: f64 = lib::SATURATION_CURRENT_A as f64;
    /// Hall offset, electrical degrees.
    pub const HALL_OFFSET_DEG: f64 = lib::HALL_OFFSET_DEG as f64;
    /// Transmission mode frequency at `s = 1`, Hz (`f_r = COMPLIANCE_MODE_HZ / s`).
    pub const COMPLIANCE_MODE_HZ: f64 = 50.0;
    /// Transmission damping ratio.
    pub const COMPLIANCE_DAMPING_RATIO: f64 = 0.2;
    /// Below this severity the transmission is rigid (mode above 20 kHz).
    pub const COMPLIANCE_RIGID_BELOW: f64 = 0.0025;
    /// DC-link source resistance, Ω.
    pub const BUS_RESISTANCE_OHM: f64 = 3.0;
    /// DC-link current averaging (capacitor) time constant, s.
    pub const BUS_FILTER_S: f64 = 1.0e-3;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip_and_unknown_is_refused() {
        for e in Effect::ALL {
            assert_eq!(e.id().parse::<Effect>(), Ok(e));
            assert_eq!(Effect::ALL[e.index()], e);
        }
        let err = "cogs".parse::<Effect>().unwrap_err().to_string();
        assert!(err.contains("'cogs'") && err.contains("bus_sag") && err.contains("cogging"), "{err}");
    }

    #[test]
    fn severities_are_checked() {
        let mut fx = Effects::NONE;
        assert!(fx.set(Effect::Cogging, 1.0).is_ok());
        assert!(fx.set(Effect::Cogging, 1.5).is_err());
        assert!(fx.set(Effect::Cogging, -0.1).is_err());
        assert!(fx.set(Effect::Cogging, f64::NAN).is_err());
        assert_eq!(fx.get(Effect::Cogging), 1.0);
        assert_eq!(fx.active().count(), 1);
    }
}
