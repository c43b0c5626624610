//! One unit of an actuator drawn from its tolerance table (`ema simulate --unit SEED`).
//!
//! A built unit differs from its parameter set by its production tolerances
//! ([`ema_monitor::unit`]): each parameter that varies from unit to unit is moved by `z_i`
//! standard deviations of its relative 1σ, `p_i = p_i,base·(1 + σ_i·z_i)`
//! ([`Tolerances::apply`]). [`draw_unit`] draws the `z_i` independently from `N(0, 1)` with the
//! reference model's generator ([`NoiseRng`]), seeded by the unit's seed, one deviate per unit
//! parameter in [`UNIT_PARAMS`](ema_monitor::unit::UNIT_PARAMS) order. A draw whose parameters
//! [`EmaParams::check`] refuses (dynamic friction above static, a negative value from a wide
//! tolerance) is not a unit the models take: the next draw of the same stream is taken, so a seed
//! always gives the same unit.

use ema_monitor::params::ParamsError;
use ema_monitor::unit::{unit_field, unit_name, Tolerances, UNIT_PARAM_COUNT};
use ema_monitor::EmaParams;
use ema_reference::rng::NoiseRng;

use crate::recording::sidecar::{SidecarUnit, SidecarUnitParameter};

/// Most draws of one seed's stream before the tolerance table is declared to give no unit the
/// models take (with [`Tolerances::TYPICAL`] nearly every first draw passes).
pub const MAX_DRAWS: u32 = 1000;

/// Mixed into the seed of the unit's stream, so that `--unit N --seed N` draws the unit and the
/// sensor noise from different streams of the one generator.
const UNIT_STREAM: u64 = 0x756e_6974_2d64_7261;

/// A unit drawn from a tolerance table.
#[derive(Clone, Debug, PartialEq)]
pub struct DrawnUnit {
    /// The seed of its stream (`--unit SEED`).
    pub seed: u64,
    /// Its deviations, in standard deviations, in unit-parameter order.
    pub z: [f32; UNIT_PARAM_COUNT],
    /// Its parameters (at 20 °C): `tolerances.apply(base, &z)`.
    pub params: EmaParams,
    /// Draws taken: the last one is the unit (1 when the first passed [`EmaParams::check`]).
    pub draws: u32,
}

/// Why no unit was drawn: every one of [`MAX_DRAWS`] draws failed [`EmaParams::check`]; the last
/// failure is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoUnit {
    /// The check's refusal of the last draw.
    pub last: ParamsError,
}

impl std::fmt::Display for NoUnit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "none of {MAX_DRAWS} units drawn passes the parameter check (the last: {}); narrow the tolerances",
            self.last
        )
    }
}

/// Draws the unit of `seed`: `z` from `N(0, 1)` until `tolerances.apply(base, &z)` passes
/// [`EmaParams::check`], as the module describes.
pub fn draw_unit(base: &EmaParams, tolerances: &Tolerances, seed: u64) -> Result<DrawnUnit, NoUnit> {
    let mut rng = NoiseRng::new(seed ^ UNIT_STREAM);
    let mut draws = 0;
    loop {
        draws += 1;
        let mut z = [0.0f32; UNIT_PARAM_COUNT];
        for zi in &mut z {
            *zi = rng.gaussian() as f32;
        }
        let params = tolerances.apply(base, &z);
        match params.check() {
            Ok(()) => return Ok(DrawnUnit { seed, z, params, draws }),
            Err(last) if draws >= MAX_DRAWS => return Err(NoUnit { last }),
            Err(_) => {}
        }
    }
}

impl DrawnUnit {
    /// The unit as the sidecar records it: its seed and draws, the tolerance table (named
    /// `tolerances_file`) and per unit parameter its 1σ, `z`, base value and value.
    pub fn to_sidecar(&self, base: &EmaParams, tolerances: &Tolerances, tolerances_file: String) -> SidecarUnit {
        let parameters = (0..UNIT_PARAM_COUNT)
            .filter_map(|i| {
                let field = unit_field(i)?;
                Some(SidecarUnitParameter {
                    name: unit_name(i).to_owned(),
                    relative_sigma: tolerances.relative_sigma[i],
                    z: self.z[i],
                    base: field.get(base),
                    value: field.get(&self.params),
                })
            })
            .collect();
        SidecarUnit { seed: self.seed, draws: self.draws, tolerances_file, parameters }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_seed_gives_one_unit_and_refused_draws_are_redrawn() {
        let t = Tolerances::TYPICAL;
        let a = draw_unit(&EmaParams::NOMINAL, &t, 11).expect("a unit");
        assert_eq!(draw_unit(&EmaParams::NOMINAL, &t, 11), Ok(a.clone()));
        assert_ne!(draw_unit(&EmaParams::NOMINAL, &t, 12).expect("a unit").z, a.z);
        assert_eq!(a.params, t.apply(&EmaParams::NOMINAL, &a.z));
        assert_eq!(a.params.gear_ratio, EmaParams::NOMINAL.gear_ratio);
        // the widest table: dynamic friction often drawn above static; every unit passes the check
        let wide = Tolerances { relative_sigma: [ema_monitor::unit::MAX_RELATIVE_SIGMA; UNIT_PARAM_COUNT] };
        let units: Vec<DrawnUnit> =
            (0..50).map(|s| draw_unit(&EmaParams::NOMINAL, &wide, s).expect("a unit")).collect();
        assert!(units.iter().all(|u| u.params.check().is_ok()));
        assert!(units.iter().any(|u| u.draws > 1), "some seed needed a second draw");
        // a base no draw can repair: dynamic friction 1.5 times static, which 10 % sigmas never undo
        let base = EmaParams { static_friction_n_m: 0.1, dynamic_friction_n_m: 0.15, ..EmaParams::NOMINAL };
        let narrow = Tolerances { relative_sigma: [0.001; UNIT_PARAM_COUNT] };
        let e = draw_unit(&base, &narrow, 1).expect_err("no unit");
        assert_eq!(e.last.field(), "dynamic_friction_n_m");
        assert!(e.to_string().contains("narrow the tolerances"), "{e}");
    }
}
