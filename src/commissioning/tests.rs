use super::*;
use crate::conditioning::ConditionedWindow;
use crate::diagnosis::{Identification, IdentifyConfig, ONBOARD_WINDOW};
use crate::health::Status;
use crate::profile::Profile;

/// The monitor model's own trace of the healthy `unit` at `temperature_c`, with the nominal
/// actuator's noise ([`crate::test_traces`]).
fn noisy_trace(unit: &EmaParams, temperature_c: f32, seed: u64) -> ConditionedWindow<ONBOARD_WINDOW> {
    crate::test_traces::noisy_trace(&unit.at_temperature(temperature_c), &FaultVector::HEALTHY, seed)
}

fn fit_of<'a>(trace: &'a ConditionedWindow<ONBOARD_WINDOW>) -> EquivalentCurrentFit<'a, ONBOARD_WINDOW> {
    let config = IdentifyConfig::onboard();
    EquivalentCurrentFit::new(trace, EmaParams::NOMINAL, &Profile::STANDARD)
        .unwrap()
        .with_fast_regime_weight(config.fast_regime_weight)
        .unwrap()
}

/// Commissions `unit` on three recordings at `temperatures` (noise seeds `10·seed + r`).
fn commission_unit(unit: &EmaParams, temperatures: [f32; 3], seed: u64) -> Baseline {
    let traces: [ConditionedWindow<ONBOARD_WINDOW>; 3] =
        core::array::from_fn(|r| noisy_trace(unit, temperatures[r], seed * 10 + r as u64));
    let fits: [EquivalentCurrentFit<'_, ONBOARD_WINDOW>; 3] = core::array::from_fn(|r| fit_of(&traces[r]));
    let flights: [CommissioningFlight<'_, '_, ONBOARD_WINDOW>; 3] =
        core::array::from_fn(|r| CommissioningFlight { fit: &fits[r], temperature_c: temperatures[r] });
    let independent = IdentifyConfig::onboard().independent_frames_per_block;
    let mut objective = BaselineFit::new(&flights, EmaParams::NOMINAL, Tolerances::TYPICAL, independent).unwrap();
    commission::<ONBOARD_WINDOW, 16>(&mut objective, 30, seed, &mut || {}).unwrap()
}

#[test]
fn a_unit_off_nominal_is_commissioned_to_a_baseline_that_diagnoses_it_healthy() {
    let t = Tolerances::TYPICAL;
    // two units 1-2σ off the drawing on several parameters at once, flown at several temperatures
    let units = [
        ([1.5, -1.0, 2.0, 1.0, -1.0, 1.0, -1.5, 2.0, -1.0, 0.5, 1.0], [20.0, -10.0, 45.0]),
        ([-2.0, 1.0, -1.5, -1.5, 0.5, -1.0, 1.0, -1.0, 1.0, -0.5, -1.5], [5.0, 30.0, 60.0]),
    ];
    for (seed, (z_true, temperatures)) in units.iter().enumerate() {
        let unit = t.apply(&EmaParams::NOMINAL, z_true);
        let seed = seed as u64 + 1;
        let baseline = commission_unit(&unit, *temperatures, seed);
        // a fourth flight: the baseline fits it as well as the unit's own parameters do, and
        // better than the drawing
        let fourth = noisy_trace(&unit, 20.0, seed * 10 + 9);
        let fit = fit_of(&fourth);
        let with = fit.error_of_unit(&baseline.params, &FaultVector::HEALTHY, f32::INFINITY);
        let without = fit.error(&FaultVector::HEALTHY);
        let own = fit.error_of_unit(&unit, &FaultVector::HEALTHY, f32::INFINITY);
        assert!(with < without && with <= 1.01 * own, "{with} vs {own} (own) and {without} (drawing)");
        // unresolved parameters stay nominal; the EMF constant shows in every manoeuvre
        for i in 0..D {
            assert!(baseline.resolved[i] || baseline.z[i] == 0.0);
            assert!(baseline.sigma_z[i] > 0.0 && baseline.sigma_z[i] <= 1.0);
        }
        assert!(baseline.resolved[2], "{:?}", baseline.resolved);
        assert_eq!(baseline.out_of_tolerance(), None);
        // diagnosed against its baseline, the fourth flight is healthy
        let config = IdentifyConfig::onboard();
        let mut id: Identification<'_, ONBOARD_WINDOW, 16> =
            Identification::new(&fourth, baseline.params, &Profile::STANDARD, &config).unwrap();
        id.run(u32::MAX);
        let report = id.report();
        assert_eq!(report.status, Status::Healthy, "{:?}", report.faults.0);
    }
}

#[test]
fn friction_far_beyond_its_tolerance_is_not_a_baseline() {
    // a dry-friction fault (static and dynamic friction at 1.6×) on an otherwise nominal unit
    let mut z = [0.0; D];
    z[6] = 6.0;
    z[7] = 6.0;
    let unit = Tolerances::TYPICAL.apply(&EmaParams::NOMINAL, &z);
    let baseline = commission_unit(&unit, [20.0; 3], 7);
    let (i, zi) = baseline.out_of_tolerance().expect("a friction fault is flagged");
    assert!((6..=7).contains(&i) && zi > OUT_OF_TOLERANCE_SIGMAS, "{i} {zi}: {:?}", baseline.z);
}

#[test]
fn bad_inputs_are_refused() {
    let trace = noisy_trace(&EmaParams::NOMINAL, 20.0, 1);
    let fit = fit_of(&trace);
    let flight = CommissioningFlight { fit: &fit, temperature_c: f32::NAN };
    let none: [CommissioningFlight<'_, '_, ONBOARD_WINDOW>; 0] = [];
    assert_eq!(
        BaselineFit::new(&none, EmaParams::NOMINAL, Tolerances::TYPICAL, 4.0).err(),
        Some(CommissioningError::FlightCount)
    );
    let many = [flight; MAX_COMMISSIONING_FLIGHTS + 1];
    assert!(BaselineFit::new(&many, EmaParams::NOMINAL, Tolerances::TYPICAL, 4.0).is_err());
    let mut wild = Tolerances::TYPICAL;
    wild.relative_sigma[0] = 2.0;
    assert!(matches!(
        BaselineFit::new(&many[..1], EmaParams::NOMINAL, wild, 4.0),
        Err(CommissioningError::Tolerances(_))
    ));
    let bad = EmaParams { gear_ratio: 0.0, ..EmaParams::NOMINAL };
    assert!(matches!(BaselineFit::new(&many[..1], bad, Tolerances::TYPICAL, 4.0), Err(CommissioningError::Params(_))));
}

#[test]
fn invert_gives_the_inverse_and_refuses_a_singular_matrix() {
    let m: [[f32; D]; D] =
        core::array::from_fn(|i| core::array::from_fn(|j| if i == j { 2.0 + i as f32 } else { 0.3 }));
    let inv = invert(m).unwrap();
    for i in 0..D {
        for j in 0..D {
            let v: f32 = (0..D).map(|k| m[i][k] * inv[k][j]).sum();
            assert!((v - if i == j { 1.0 } else { 0.0 }).abs() < 1e-4);
        }
    }
    let mut singular = m;
    singular[3] = singular[2];
    assert!(invert(singular).is_none());
}

#[test]
fn every_phase_shorted_is_the_pattern_of_three_phases_at_degraded_size() {
    let k = |a: f32, b: f32, c: f32| FaultVector([0.1, 0.0, a, b, c, 0.0, 0.5, 0.5]);
    assert!(every_phase_shorted(&k(0.8, 0.54, 0.56)));
    assert!(!every_phase_shorted(&k(0.8, 0.54, 0.05)));
    assert!(!every_phase_shorted(&k(0.3, 0.0, 0.0)));
}
