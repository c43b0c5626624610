//! What varies from one unit to the next: the tolerance table.
//!
//! [`crate::EmaParams`] describes the drawing's actuator. A built unit differs from it by its
//! production tolerances: winding resistance and inductance, EMF constant, inertias, the three
//! friction terms, the transmission efficiencies, the hinge load. [`Tolerances`] gives each of
//! these [`UNIT_PARAMS`] a relative 1σ, and a unit is the drawing's parameters moved by `z_i`
//! standard deviations each ([`Tolerances::apply`]):
//!
//! ```text
//! p_i = p_i,nominal·(1 + σ_i·z_i)
//! ```
//!
//! The reference model draws units from this table (`ema simulate --unit`); commissioning
//! ([`crate::commissioning`]) estimates a unit's own `z` from recordings of it, with the table as
//! its prior.

use crate::params::{EmaParams, ParamField, FIELDS};

/// Number of parameters that vary from unit to unit.
pub const UNIT_PARAM_COUNT: usize = 11;

/// The parameters that vary from unit to unit, as indices into [`FIELDS`] (the names are the
/// parameter file's keys).
pub const UNIT_PARAMS: [usize; UNIT_PARAM_COUNT] = [
    2,  // phase_resistance_ohm
    3,  // phase_inductance_h
    4,  // phase_emf_constant_v_s_per_rad
    7,  // motor_inertia_kg_m2
    9,  // surface_inertia_kg_m2
    10, // viscous_friction_n_m_s_per_rad
    11, // static_friction_n_m
    12, // dynamic_friction_n_m
    13, // efficiency_opposing
    14, // efficiency_aiding
    17, // hinge_stiffness_n_m_per_rad
];

/// The [`ParamField`] of unit parameter `i` (`i < UNIT_PARAM_COUNT`; `None` beyond).
pub fn unit_field(i: usize) -> Option<&'static ParamField> {
    UNIT_PARAMS.get(i).and_then(|&f| FIELDS.get(f))
}

/// The name (parameter-file key) of unit parameter `i`, `"?"` beyond [`UNIT_PARAM_COUNT`].
pub fn unit_name(i: usize) -> &'static str {
    unit_field(i).map_or("?", |f| f.name)
}

/// Largest relative 1σ a tolerance table accepts: beyond it a "unit" is another actuator, which
/// takes a parameter file of its own.
pub const MAX_RELATIVE_SIGMA: f32 = 0.3;

/// The relative 1σ of each unit parameter, in [`UNIT_PARAMS`] order.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Tolerances {
    /// Relative 1σ of each parameter (0.03: 3 %), in `[0, MAX_RELATIVE_SIGMA]`.
    pub relative_sigma: [f32; UNIT_PARAM_COUNT],
}

/// Why a tolerance table is refused ([`Tolerances::check`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ToleranceError {
    /// The parameter whose 1σ is refused.
    pub field: &'static str,
    /// The value given.
    pub value: f32,
}

impl core::fmt::Display for ToleranceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{} = {}: a relative 1σ must lie in [0, {}]", self.field, self.value, MAX_RELATIVE_SIGMA)
    }
}

impl Tolerances {
    /// Ordinary production tolerances of a flight-control EMA: resistance 3 %, inductance 5 %,
    /// EMF constant 2 %, motor and surface inertia 5 %, the three friction terms 10 %,
    /// efficiencies 2 %, hinge stiffness 5 %.
    pub const TYPICAL: Self =
        Self { relative_sigma: [0.03, 0.05, 0.02, 0.05, 0.05, 0.10, 0.10, 0.10, 0.02, 0.02, 0.05] };

    /// Each 1σ finite and in `[0, MAX_RELATIVE_SIGMA]`.
    pub fn check(&self) -> Result<(), ToleranceError> {
        for (i, &s) in self.relative_sigma.iter().enumerate() {
            if !(0.0..=MAX_RELATIVE_SIGMA).contains(&s) {
                return Err(ToleranceError { field: unit_name(i), value: s });
            }
        }
        Ok(())
    }

    /// The unit `z` standard deviations from `base`: `p_i = p_i,base·(1 + σ_i·z_i)`. Unchecked:
    /// [`EmaParams::check`] tells whether the result is a unit the models take.
    pub fn apply(&self, base: &EmaParams, z: &[f32; UNIT_PARAM_COUNT]) -> EmaParams {
        let mut p = *base;
        for (i, (&s, &zi)) in self.relative_sigma.iter().zip(z).enumerate() {
            if let Some(field) = unit_field(i) {
                field.set(&mut p, field.get(base) * (1.0 + s * zi));
            }
        }
        p
    }

    /// The deviations `z` of `unit` from `base` (the inverse of [`Tolerances::apply`]); 0 where
    /// a 1σ or a base value is 0.
    pub fn deviations(&self, base: &EmaParams, unit: &EmaParams) -> [f32; UNIT_PARAM_COUNT] {
        let mut z = [0.0; UNIT_PARAM_COUNT];
        for (i, (zi, &s)) in z.iter_mut().zip(&self.relative_sigma).enumerate() {
            if let Some(field) = unit_field(i) {
                let b = field.get(base);
                if s > 0.0 && b != 0.0 {
                    *zi = (field.get(unit) / b - 1.0) / s;
                }
            }
        }
        z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_unit_parameters_are_the_fields_they_name() {
        let names = [
            "phase_resistance_ohm",
            "phase_inductance_h",
            "phase_emf_constant_v_s_per_rad",
            "motor_inertia_kg_m2",
            "surface_inertia_kg_m2",
            "viscous_friction_n_m_s_per_rad",
            "static_friction_n_m",
            "dynamic_friction_n_m",
            "efficiency_opposing",
            "efficiency_aiding",
            "hinge_stiffness_n_m_per_rad",
        ];
        for (i, name) in names.iter().enumerate() {
            assert_eq!(unit_name(i), *name);
        }
        assert_eq!(unit_name(UNIT_PARAM_COUNT), "?");
    }

    #[test]
    fn apply_and_deviations_are_inverse_and_check_refuses_wild_tables() {
        let t = Tolerances::TYPICAL;
        assert_eq!(t.check(), Ok(()));
        let z = [1.0, -2.0, 0.5, 2.0, -1.0, 1.5, -0.5, 0.0, 1.0, -1.0, 2.0];
        let unit = t.apply(&EmaParams::NOMINAL, &z);
        assert!((unit.phase_resistance_ohm - 0.515).abs() < 1e-6);
        assert!((unit.phase_emf_constant_v_s_per_rad - 0.13 * 1.01).abs() < 1e-6);
        assert_eq!(unit.gear_ratio, EmaParams::NOMINAL.gear_ratio);
        let back = t.deviations(&EmaParams::NOMINAL, &unit);
        for (a, b) in z.iter().zip(&back) {
            assert!((a - b).abs() < 1e-4, "{z:?} {back:?}");
        }
        let mut wild = t;
        wild.relative_sigma[6] = 0.5;
        assert_eq!(wild.check(), Err(ToleranceError { field: "static_friction_n_m", value: 0.5 }));
        wild.relative_sigma[6] = f32::NAN;
        assert!(wild.check().is_err());
    }
}
