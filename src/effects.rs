//! Optional effect terms of the monitor model (physics.md §10), all off by default.
//!
//! The reference model can play ten "library" effects the paper's monitor model does not know
//! (`host-tests/reference`, same IDs). Each has a severity `s ∈ [0, 1]` mapped to a physical
//! magnitude by the **same** table as there ([`maxima`]), so an effect named by the discrepancy
//! workflow (`ema discover`) can be switched on here with the severity it estimated, on the host
//! and on board alike. Storage is one fixed array of severities: no allocation, `Copy`.
//!
//! A model built with [`ModelEffects::NONE`] runs exactly (bit for bit) the code it ran before the
//! effects existed: every term is guarded by its severity being non-zero.

/// Number of library effects the monitor model can add.
pub const EFFECT_COUNT: usize = 10;

/// One library effect, by the ID the reference model and the command line use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EffectId {
    /// Cogging torque `A·sin(24·θ_m)`, `A = s·0.04 N·m`.
    Cogging,
    /// Velocity-weakening friction: breakaway `FSJ·(1+s)`, sliding
    /// `FDJ + s·(2·FSJ − FDJ)·exp(−(ω/ω_s)²)`, `ω_s = 5 rad/s` (motor side).
    Stribeck,
    /// Extra viscous friction at the motor, `ΔC = s·5e-4 N·m·s/rad`.
    Viscous,
    /// Winding temperature rise `ΔT = s·100 K`: `R×(1 + 3.93e-3·ΔT)`, `k_e×(1 − 1.1e-3·ΔT)`.
    WindingTemperature,
    /// Back-EMF flat top narrowed from 120° to `120° − s·40°` electrical.
    EmfHarmonics,
    /// Inverter dead time and device drops, `−sign(i_j)·ΔV` per conducting phase, `ΔV = s·8 V`.
    DeadTime,
    /// Current-sensor error `i_meas = (1 + g_j)·i_j + o_j`, `o = s·(0.2, −0.1, 0.15) A`,
    /// `g = s·(0.02, −0.02, 0.01)`.
    SensorOffset,
    /// Hinge stiffness above nominal, `K_h×(1 + s)`.
    HingeStiffness,
    /// Magnetic saturation `k_j/(1 + (I/I_sat)²)`, `I_sat = 30 A / s`.
    Saturation,
    /// Hall-sensor misalignment `δ_H = s·10°` electrical.
    HallMisalignment,
}

/// What severity 1 means, per effect (the reference model's documented maxima).
pub mod maxima {
    /// Cogging torque amplitude (N·m).
    pub const COGGING_TORQUE_N_M: f32 = 0.04;
    /// Cogging cycles per mechanical revolution (12 slots, 8 poles).
    pub const COGGING_CYCLES_PER_REV: f32 = 24.0;
    /// Breakaway gain of the Stribeck effect: `FSJ×(1 + s·gain)`.
    pub const STRIBECK_STICTION_GAIN: f32 = 1.0;
    /// Stribeck speed at the motor (rad/s).
    pub const STRIBECK_SPEED_RAD_PER_S: f32 = 5.0;
    /// Extra viscous friction (N·m·s/rad).
    pub const VISCOUS_N_M_S_PER_RAD: f32 = 5e-4;
    /// Winding temperature rise (K).
    pub const WINDING_TEMPERATURE_RISE_K: f32 = 100.0;
    /// Copper resistance coefficient (1/K).
    pub const COPPER_ALPHA_PER_K: f32 = 3.93e-3;
    /// NdFeB flux coefficient (1/K).
    pub const MAGNET_BETA_PER_K: f32 = -1.1e-3;
    /// Narrowing of the back-EMF flat top (degrees electrical).
    pub const EMF_FLAT_TOP_NARROWING_DEG: f32 = 40.0;
    /// Dead-time voltage per conducting phase (V).
    pub const DEAD_TIME_V: f32 = 8.0;
    /// Current-sensor offsets per phase (A).
    pub const SENSOR_OFFSET_A: [f32; 3] = [0.2, -0.1, 0.15];
    /// Current-sensor gain errors per phase.
    pub const SENSOR_GAIN: [f32; 3] = [0.02, -0.02, 0.01];
    /// Relative hinge stiffness increase.
    pub const HINGE_STIFFNESS_GAIN: f32 = 1.0;
    /// Saturation current at `s = 1` (A).
    pub const SATURATION_CURRENT_A: f32 = 30.0;
    /// Hall offset (degrees electrical).
    pub const HALL_OFFSET_DEG: f32 = 10.0;
}

impl EffectId {
    /// Every library effect, in catalogue order (the index order of [`ModelEffects`]).
    pub const ALL: [EffectId; EFFECT_COUNT] = [
        EffectId::Cogging,
        EffectId::Stribeck,
        EffectId::Viscous,
        EffectId::WindingTemperature,
        EffectId::EmfHarmonics,
        EffectId::DeadTime,
        EffectId::SensorOffset,
        EffectId::HingeStiffness,
        EffectId::Saturation,
        EffectId::HallMisalignment,
    ];

    /// The ID (`cogging`, `stribeck`, …), as on the command line and in the reference model.
    pub const fn id(self) -> &'static str {
        match self {
            EffectId::Cogging => "cogging",
            EffectId::Stribeck => "stribeck",
            EffectId::Viscous => "viscous",
            EffectId::WindingTemperature => "winding_temperature",
            EffectId::EmfHarmonics => "emf_harmonics",
            EffectId::DeadTime => "dead_time",
            EffectId::SensorOffset => "sensor_offset",
            EffectId::HingeStiffness => "hinge_stiffness",
            EffectId::Saturation => "saturation",
            EffectId::HallMisalignment => "hall_misalignment",
        }
    }

    /// The effect of an ID, `None` when it is not a library effect.
    pub fn from_id(id: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|e| e.id() == id)
    }

    /// Position in [`EffectId::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }
}

/// A severity outside `[0, 1]` (or not a number).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SeverityOutOfRange {
    /// The effect.
    pub effect: EffectId,
    /// The refused severity.
    pub severity: f32,
}

impl core::fmt::Display for SeverityOutOfRange {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "effect {}: severity {} is outside [0, 1]", self.effect.id(), self.severity)
    }
}

impl core::error::Error for SeverityOutOfRange {}

/// The effect terms switched on in a monitor model: one severity per library effect (0 = off).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModelEffects {
    severity: [f32; EFFECT_COUNT],
}

impl ModelEffects {
    /// No effect: the paper's monitor model.
    pub const NONE: Self = Self { severity: [0.0; EFFECT_COUNT] };

    /// Sets `effect` to `severity` (0 switches it off).
    pub fn set(&mut self, effect: EffectId, severity: f32) -> Result<(), SeverityOutOfRange> {
        if !(0.0..=1.0).contains(&severity) {
            return Err(SeverityOutOfRange { effect, severity });
        }
        if let Some(slot) = self.severity.get_mut(effect.index()) {
            *slot = severity;
        }
        Ok(())
    }

    /// These effects with `effect` at `severity`.
    pub fn with(mut self, effect: EffectId, severity: f32) -> Result<Self, SeverityOutOfRange> {
        self.set(effect, severity)?;
        Ok(self)
    }

    /// Severity of `effect` (0 when off).
    pub fn get(&self, effect: EffectId) -> f32 {
        self.severity.get(effect.index()).copied().unwrap_or(0.0)
    }

    /// `true` when no effect is on.
    pub fn is_none(&self) -> bool {
        self.severity.iter().all(|&s| s == 0.0)
    }

    /// The effects that are on, with their severities, in catalogue order.
    pub fn active(&self) -> impl Iterator<Item = (EffectId, f32)> + '_ {
        EffectId::ALL.iter().copied().zip(self.severity).filter(|&(_, s)| s != 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip_and_unknown_ids_are_refused() {
        for (k, e) in EffectId::ALL.iter().enumerate() {
            assert_eq!(e.index(), k);
            assert_eq!(EffectId::from_id(e.id()), Some(*e));
        }
        assert_eq!(EffectId::from_id("compliance"), None);
        assert_eq!(EffectId::from_id(""), None);
    }

    #[test]
    fn severities_outside_the_unit_interval_are_refused() {
        let mut e = ModelEffects::NONE;
        assert!(e.is_none());
        assert!(e.set(EffectId::DeadTime, 1.5).is_err());
        assert!(e.set(EffectId::DeadTime, -0.1).is_err());
        assert!(e.set(EffectId::DeadTime, f32::NAN).is_err());
        assert!(e.is_none());
        e.set(EffectId::DeadTime, 0.5).unwrap();
        assert_eq!(e.get(EffectId::DeadTime), 0.5);
        assert_eq!(e.active().collect::<heapless::Vec<_, 10>>().as_slice(), &[(EffectId::DeadTime, 0.5)]);
    }
}
