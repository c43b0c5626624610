//! The actuator's temperature during a recording: the parameters the monitor model takes.
//!
//! The parameters of `--params` (or the nominal set) are the actuator's at 20 °C. A recording with
//! a temperature column ([`crate::recording::read`]) was made at its temperature, so the monitor
//! model is built from the parameters at the mean temperature of the manoeuvre's rows
//! ([`EmaParams::at_temperature`]: winding resistance, EMF constant and friction); without a column,
//! from the parameters as given. Every command that identifies recordings read from files takes its
//! model parameters here, once per recording (or once per pooled set), right after reading:
//! [`model_params`], or [`pooled_model_params`] for recordings fitted by one fault vector, which
//! share one parameter set and must therefore share a temperature.

use std::path::Path;

use ema_monitor::EmaParams;

use crate::error::CliError;
use crate::recording::Recording;

/// Widest spread of the mean temperatures of recordings identified together (K): the pooled fit
/// uses one parameter set, and 5 K moves the winding resistance by 2 %.
pub const POOLED_TEMPERATURE_SPREAD_K: f64 = 5.0;

/// The parameters the monitor model takes for a recording, and the temperature they are at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelParams {
    /// The actuator's parameters at [`ModelParams::temperature_c`] (as given without one).
    pub params: EmaParams,
    /// The recording's mean temperature (°C); `None` without a temperature column.
    pub temperature_c: Option<f64>,
}

/// `params` at `temperature_c`, checked ([`EmaParams::check`]); `path` names the recording in the
/// error.
fn at(params: &EmaParams, temperature_c: f64, path: &Path) -> Result<ModelParams, CliError> {
    let at = params.at_temperature(temperature_c as f32);
    at.check().map_err(|e| {
        CliError::input(
            path,
            format!("at the recording's mean temperature, {temperature_c:.1} °C, the actuator's parameters are refused: {e}"),
        )
    })?;
    Ok(ModelParams { params: at, temperature_c: Some(temperature_c) })
}

/// The parameters the monitor model takes for `recording` (read from `path`, named in errors) of
/// the actuator `params` (at 20 °C): `params` at the recording's mean temperature, or `params`
/// without a temperature column. Refused when the parameters at that temperature fail
/// [`EmaParams::check`].
pub fn model_params(recording: &Recording, path: &Path, params: &EmaParams) -> Result<ModelParams, CliError> {
    match recording.mean_temperature_c() {
        Some(t) => at(params, t, path),
        None => Ok(ModelParams { params: *params, temperature_c: None }),
    }
}

/// The one parameter set of recordings identified together (each read from its path): `params`
/// at their mean temperature, every row weighing the same. Refused, naming both files, when one
/// recording has a temperature column and another has none, or when two mean temperatures differ
/// by more than [`POOLED_TEMPERATURE_SPREAD_K`].
pub fn pooled_model_params(recordings: &[(&Path, &Recording)], params: &EmaParams) -> Result<ModelParams, CliError> {
    let with: Vec<(&Path, f64, usize)> =
        recordings.iter().filter_map(|&(p, r)| r.mean_temperature_c().map(|t| (p, t, r.len()))).collect();
    let Some(&(first, ..)) = with.first() else {
        return Ok(ModelParams { params: *params, temperature_c: None });
    };
    if let Some(&(without, _)) = recordings.iter().find(|(_, r)| r.mean_temperature_c().is_none()) {
        return Err(CliError::input(
            without,
            format!(
                "no temperature column, but '{}' has one: recordings identified together share one parameter set \
                 at one temperature; give every recording a temperature column or none",
                first.display()
            ),
        ));
    }
    let by_temperature = |a: &&(&Path, f64, usize), b: &&(&Path, f64, usize)| a.1.total_cmp(&b.1);
    if let (Some(cold), Some(hot)) = (with.iter().min_by(by_temperature), with.iter().max_by(by_temperature)) {
        if hot.1 - cold.1 > POOLED_TEMPERATURE_SPREAD_K {
            return Err(CliError::input(
                hot.0,
                format!(
                    "mean temperature {:.1} °C, {:.1} K above the {:.1} °C of '{}': recordings identified together \
                     share one parameter set, so their temperatures must lie within {POOLED_TEMPERATURE_SPREAD_K} K; \
                     identify them apart",
                    hot.1,
                    hot.1 - cold.1,
                    cold.1,
                    cold.0.display()
                ),
            ));
        }
    }
    let rows: usize = with.iter().map(|w| w.2).sum();
    let mean = with.iter().map(|&(_, t, n)| t * n as f64).sum::<f64>() / rows.max(1) as f64;
    at(params, mean, first)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at_temperature(t: Option<f64>, rows: usize) -> Recording {
        Recording {
            time_s: (0..rows).map(|k| k as f64 * 1e-4).collect(),
            temperature_c: t.map(|t| vec![t; rows]),
            ..Recording::default()
        }
    }

    #[test]
    fn the_model_takes_the_recordings_temperature() {
        let unit = EmaParams { phase_resistance_ohm: 0.52, static_friction_n_m: 0.11, ..EmaParams::NOMINAL };
        let path = Path::new("a.csv");
        let plain = model_params(&at_temperature(None, 4), path, &unit).expect("no column");
        assert_eq!(plain, ModelParams { params: unit, temperature_c: None });
        let cold = model_params(&at_temperature(Some(-40.0), 4), path, &unit).expect("-40 °C");
        assert_eq!(cold, ModelParams { params: unit.at_temperature(-40.0), temperature_c: Some(-40.0) });
        assert!(cold.params.phase_resistance_ohm < 0.45 && cold.params.static_friction_n_m > 0.13, "{cold:?}");
        // at -100 °C the mechanical time constant of the nominal actuator falls below ten periods
        let e = model_params(&at_temperature(Some(-100.0), 4), path, &EmaParams::NOMINAL).expect_err("refused");
        assert!(e.to_string().starts_with("'a.csv': at the recording's mean temperature, -100.0 °C"), "{e}");
    }

    #[test]
    fn pooled_recordings_share_one_temperature() {
        let unit = EmaParams { phase_emf_constant_v_s_per_rad: 0.128, ..EmaParams::NOMINAL };
        let (a, b, c) = (Path::new("a.csv"), Path::new("b.csv"), Path::new("c.csv"));
        let (r1, r2, r3) = (at_temperature(Some(-40.0), 1), at_temperature(Some(-36.0), 3), at_temperature(None, 2));
        let pooled = pooled_model_params(&[(a, &r1), (b, &r2)], &unit).expect("within 5 K");
        assert_eq!(pooled, ModelParams { params: unit.at_temperature(-37.0), temperature_c: Some(-37.0) });
        let none = pooled_model_params(&[(c, &r3), (c, &r3)], &unit).expect("no column");
        assert_eq!(none.params, unit);
        let e = pooled_model_params(&[(a, &r1), (c, &r3)], &unit).expect_err("a mix").to_string();
        assert!(e.starts_with("'c.csv': no temperature column, but 'a.csv' has one"), "{e}");
        let r4 = at_temperature(Some(-34.5), 1);
        let e = pooled_model_params(&[(a, &r1), (b, &r2), (c, &r4)], &unit).expect_err("5.5 K").to_string();
        assert!(e.starts_with("'c.csv': mean temperature -34.5 °C, 5.5 K above the -40.0 °C of 'a.csv'"), "{e}");
    }
}
