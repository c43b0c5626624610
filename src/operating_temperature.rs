//! The operating temperature of a flight without a temperature reading, as a nuisance parameter.
//!
//! Resistance, EMF constant and friction follow the temperature ([`EmaParams::at_temperature`]).
//! When a flight comes with a temperature, the monitor model takes its parameters at it. When it
//! does not, the diagnosis must hold over the range the parameter file declares
//! (`temperature_min_c` to `temperature_max_c`, −40 to +70 °C nominal): a hot day lowers the EMF
//! constant by 5.5 % and raises the resistance by 20 %, far beyond any unit's tolerance, and read
//! at 20 °C it looks like a fault.
//!
//! [`estimate_temperature_c`] takes the temperature as one more parameter of the flight: the one
//! at which the healthy unit fits the recording best, by golden-section search over the declared
//! range. The identification then runs at that temperature. The price is detectability: a fault
//! that moves the current the way temperature does is partly taken for temperature. On the
//! standard manoeuvre the Cramér–Rao bounds grow by at most 4 %, 16 % for a short on a phase
//! already shorted; on pbit such a short's bound grows 1.5–1.8× (`docs/results/temperature-cost.md`).

use crate::faults::FaultVector;
use crate::fitness::EquivalentCurrentFit;
use crate::params::EmaParams;

/// Golden-section steps of [`estimate_temperature_c`]: the bracket shrinks by 0.618 per step,
/// from 110 K to under 0.1 K.
pub const TEMPERATURE_SEARCH_STEPS: usize = 15;

/// The temperature in `[params.temperature_min_c, params.temperature_max_c]` at which the healthy
/// unit `params` (at 20 °C) fits `fit`'s recording best ([`TEMPERATURE_SEARCH_STEPS`] + 2
/// evaluations of the fitness). A fitness that is not unimodal in the temperature gives one of its
/// local minima; an empty range gives its one temperature.
pub fn estimate_temperature_c<const W: usize>(fit: &EquivalentCurrentFit<'_, W>, params: &EmaParams) -> f32 {
    let (mut lo, mut hi) = (params.temperature_min_c, params.temperature_max_c);
    if lo.is_nan() || hi.is_nan() || lo >= hi {
        return lo;
    }
    let error = |t: f32| fit.error_of_unit(&params.at_temperature(t), &FaultVector::HEALTHY, f32::INFINITY);
    const RATIO: f32 = 0.618_034;
    let mut a = hi - RATIO * (hi - lo);
    let mut b = lo + RATIO * (hi - lo);
    let (mut fa, mut fb) = (error(a), error(b));
    for _ in 0..TEMPERATURE_SEARCH_STEPS {
        if fa <= fb {
            hi = b;
            b = a;
            fb = fa;
            a = hi - RATIO * (hi - lo);
            fa = error(a);
        } else {
            lo = a;
            a = b;
            fa = fb;
            b = lo + RATIO * (hi - lo);
            fb = error(b);
        }
    }
    if fa <= fb {
        a
    } else {
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conditioning::{ConditionedWindow, DECIMATION};
    use crate::diagnosis::ONBOARD_WINDOW;
    use crate::fitness::simulate_window;
    use crate::optimizer::rng::Rng;
    use crate::profile::Profile;
    use crate::unit::Tolerances;

    fn trace_at(unit: &EmaParams, temperature_c: f32, seed: u64) -> ConditionedWindow<ONBOARD_WINDOW> {
        let mut t = ConditionedWindow::new();
        let n = (Profile::STANDARD.duration_s() / unit.control_period_s) as usize / DECIMATION;
        let mut rng = Rng::new(seed);
        simulate_window(
            &unit.at_temperature(temperature_c),
            &Profile::STANDARD,
            &FaultVector::HEALTHY,
            n,
            |_, i, _| {
                for _ in 0..DECIMATION {
                    let pair = i + 0.29 * rng.normal();
                    t.push(pair + 0.02 * rng.normal(), -pair + 0.02 * rng.normal(), 0.02 * rng.normal()).unwrap();
                }
                true
            },
        );
        t.finish().unwrap();
        t
    }

    #[test]
    fn the_temperature_of_a_healthy_flight_is_found_within_a_few_kelvin() {
        let unit =
            Tolerances::TYPICAL.apply(&EmaParams::NOMINAL, &[1.0, -1.0, 1.0, 0.5, 0.0, -1.0, 1.0, 1.0, 0.0, 0.0, 0.5]);
        for (seed, t) in [(1, -40.0f32), (2, -5.0), (3, 35.0), (4, 70.0)] {
            let trace = trace_at(&unit, t, seed);
            let fit = EquivalentCurrentFit::new(&trace, unit, &Profile::STANDARD).unwrap();
            let found = estimate_temperature_c(&fit, &unit);
            assert!((found - t).abs() < 5.0, "{t} °C read as {found}");
        }
        let empty = EmaParams { temperature_min_c: 10.0, temperature_max_c: 10.0, ..unit };
        let trace = trace_at(&unit, 20.0, 5);
        let fit = EquivalentCurrentFit::new(&trace, unit, &Profile::STANDARD).unwrap();
        assert_eq!(estimate_temperature_c(&fit, &empty), 10.0);
    }
}
