//! Tests of the health report: conditions, statuses, the fit test and its text.
use super::*;

#[test]
fn healthy_vector_reads_healthy() {
    let r = HealthReport::new(FaultVector::HEALTHY, &EmaParams::NOMINAL, 0.0, 1, 1, None);
    assert_eq!(r.overall(), Condition::Healthy);
    assert!((r.modes[0].value - 1.0).abs() < 1e-6);
    assert!((r.modes[1].value - 0.05).abs() < 1e-6);
    assert!((r.modes[4].value - 100.0).abs() < 1e-4);
}

#[test]
fn faults_read_in_physical_terms() {
    let k = FaultVector([0.25, 0.0, 0.0, 0.8, 0.1, 0.0, 0.5, 0.2]);
    let r = HealthReport::new(k, &EmaParams::NOMINAL, 0.0, 1, 1, None);
    assert!((r.modes[0].value - 1.5).abs() < 1e-6);
    assert_eq!(r.modes[0].condition, Condition::Degraded);
    assert_eq!(r.modes[2].phase, 1);
    assert!((r.modes[2].value - 40.0).abs() < 1e-4);
    assert_eq!(r.modes[2].condition, Condition::Failing);
    assert!((r.modes[4].severity - 0.6).abs() < 1e-6);
    assert!((r.modes[4].value - 70.0).abs() < 1e-4);
    assert_eq!(r.overall(), Condition::Failing);
    let text = std::format!("{r}");
    assert!(text.contains("short circuit") && text.contains("phase B") && text.contains("FAILING"), "{text}");
    assert!(!text.contains("not tested"), "{text}");
    let cut = HealthReport { untested_groups: 2, ..r };
    let text = std::format!("{cut}");
    assert!(
        text.ends_with("model selection: 2 fault group(s) not tested (selection and polish budget spent)"),
        "{text}"
    );
}

#[test]
fn abstentions_withhold_the_diagnosis_and_outrank_it() {
    let k = FaultVector([0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let r = HealthReport::new(k, &EmaParams::NOMINAL, 0.0, 1, 1, None);
    assert_eq!(r.status, Status::Degraded);
    assert!(r.status.is_diagnosis());
    let poor = r.abstaining(Status::Inconclusive(Abstain::PoorFit));
    assert_eq!(poor.status.label(), "INCONCLUSIVE");
    assert_eq!(poor.status.reason(), Some(Abstain::PoorFit));
    let text = std::format!("{poor}");
    assert!(text.starts_with("EMA health: INCONCLUSIVE (poor fit)"), "{text}");
    assert!(!text.contains("friction") && text.contains("k (not a diagnosis)"), "{text}");
    // a sensor fault outranks an abstention, a diagnosis never replaces one
    let fault = poor.abstaining(Status::SensorFault);
    assert_eq!(fault.status.label(), "SENSOR_FAULT");
    assert_eq!(fault.abstaining(Status::Inconclusive(Abstain::RateMismatch)).status, Status::SensorFault);
    assert_eq!(poor.abstaining(Status::Healthy).status, poor.status);
    let summary = AcquisitionSummary { frames: 8500, refused: 200, longest_refused_run: 200, ..Default::default() };
    let r2 = r.with_acquisition(&summary);
    assert_eq!((r2.status, r2.refused_frames), (Status::SensorFault, 200));
    let one = AcquisitionSummary { frames: 8500, refused: 1, longest_refused_run: 1, ..Default::default() };
    assert_eq!(r.with_acquisition(&one).status, Status::Degraded);
}

#[test]
fn a_mode_is_healthy_only_when_a_degraded_fault_of_it_would_have_been_seen() {
    let k = FaultVector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.52]);
    let r = HealthReport::new(k, &EmaParams::NOMINAL, 0.01, 1, 1, None);
    assert_eq!(r.status, Status::Healthy);
    // eccentricity hides below 0.15, friction exactly at the threshold; gain drift was found
    let bounds = [Some(DEGRADED_AT), Some(0.002), Some(0.01), Some(0.15), None];
    let u = Uncertainty { sigma: [0.01; 8], detectable_below: bounds };
    let r = r.with_uncertainty(u);
    let conditions: std::vec::Vec<_> = r.modes.iter().map(|m| m.condition).collect();
    assert_eq!(
        conditions,
        [Condition::NotAssessed, Condition::Healthy, Condition::Healthy, Condition::NotAssessed, Condition::Healthy]
    );
    assert_eq!((r.status, r.overall()), (Status::Healthy, Condition::Healthy));
    let text = std::format!("{r}");
    assert!(text.starts_with("EMA health: HEALTHY (not assessed: friction, eccentricity)\n"), "{text}");
    assert!(text.contains("eccentricity   NOT_ASSESSED not detectable below 0.150\n"), "{text}");
    assert!(text.contains("backlash       HEALTHY      severity 0.000 (not detectable below 0.002)"), "{text}");
    // no mode assessed (a NaN bound counts as not assessed): no diagnosis, the bounds shown
    let blind = Uncertainty {
        sigma: [0.5; 8],
        detectable_below: [Some(22.0), Some(f32::NAN), Some(7.0), Some(119.0), Some(5.3)],
    };
    let r = HealthReport::new(k, &EmaParams::NOMINAL, 22.0, 1, 1, None).with_uncertainty(blind);
    assert_eq!(r.status, Status::Inconclusive(Abstain::NothingAssessable));
    assert!(r.modes.iter().all(|m| m.condition == Condition::NotAssessed));
    let text = std::format!("{r}");
    assert!(text.starts_with("EMA health: INCONCLUSIVE (nothing assessable)\n  no mode assessable"), "{text}");
    assert!(text.contains("friction       NOT_ASSESSED not detectable below 22.000"), "{text}");
    // a fault found stays a diagnosis whatever the other modes' bounds
    let faulty = FaultVector([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let u = Uncertainty { detectable_below: [None, Some(3.0), Some(7.0), Some(119.0), Some(5.3)], ..blind };
    let r = HealthReport::new(faulty, &EmaParams::NOMINAL, 0.01, 1, 1, None).with_uncertainty(u);
    assert_eq!(
        (r.status, r.modes[0].condition, r.modes[1].condition),
        (Status::Degraded, Condition::Degraded, Condition::NotAssessed)
    );
    // a sensor fault names no mode in its headline
    let fault = HealthReport::new(k, &EmaParams::NOMINAL, 0.01, 1, 1, None)
        .with_uncertainty(Uncertainty { detectable_below: bounds, sigma: [0.01; 8] })
        .abstaining(Status::SensorFault);
    assert!(std::format!("{fault}").starts_with("EMA health: SENSOR_FAULT\n"), "{fault}");
    // an abstention stays: the modes are marked, the status is not replaced
    let poor = HealthReport::new(k, &EmaParams::NOMINAL, 0.01, 1, 1, None)
        .abstaining(Status::Inconclusive(Abstain::PoorFit))
        .with_uncertainty(blind);
    assert_eq!(poor.status, Status::Inconclusive(Abstain::PoorFit));
}

#[test]
fn the_fit_test_is_a_chi_square_normal_score() {
    // E equal to the expected variance: T = n, z = 0
    let c = FitCheck::new(0.02, 2000.0, 0.02);
    assert!(c.z.abs() < 1e-4 && c.passes());
    // 20 % above with 2000 effective samples: z = 400/√4000 = 6.3, rejected
    let c = FitCheck::new(0.024, 2000.0, 0.02);
    assert!((c.z - 6.325).abs() < 0.01 && !c.passes(), "{c:?}");
    // the same excess with 200 effective samples is within the noise: z = 2.0
    assert!(FitCheck::new(0.024, 200.0, 0.02).passes());
    assert!(!FitCheck::new(f32::INFINITY, 2000.0, 0.02).passes());
    assert!(!FitCheck::new(f32::NAN, 2000.0, 0.02).passes());
}

#[test]
fn the_window_test_is_sidak_corrected_wilson_hilferty() {
    // one window is the whole-recording level; 22 windows (the standard manoeuvre) ask more
    assert!((normal_upper_quantile(FIT_TEST_P) - FIT_TEST_Z).abs() < 1e-3);
    assert!((sidak_limit(1) - FIT_TEST_Z).abs() < 1e-3);
    assert!((sidak_limit(22) - 5.34).abs() < 0.01, "{}", sidak_limit(22));
    assert!(sidak_limit(96) > sidak_limit(22));
    // textbook quantiles: p = 0.05 → 1.645, p = 0.001 → 3.090
    assert!((normal_upper_quantile(0.05) - 1.645).abs() < 1e-3);
    assert!((normal_upper_quantile(0.001) - 3.090).abs() < 1e-3);
    assert_eq!(normal_upper_quantile(0.0), f32::INFINITY);
    assert_eq!(normal_upper_quantile(0.7), 0.0);
    // 100 white samples at the expected variance score about 0; at twice it, 5.56
    let at = |ratio: f32, lag: f32| window_score(100, ratio * 100.0, 100.0, lag * 100.0, 1.0);
    assert!(at(1.0, 0.0).abs() < 0.1, "{}", at(1.0, 0.0));
    assert!((at(2.0, 0.0) - 5.56).abs() < 0.01, "{}", at(2.0, 0.0));
    // the same excess in a correlated window (ρ = 0.5: 33 effective samples) weighs less
    assert!(at(2.0, 1.0) < 4.0 && at(2.0, 1.0) > 3.0, "{}", at(2.0, 1.0));
    assert_eq!(window_score(0, 1.0, 1.0, 0.0, 1.0), f32::NEG_INFINITY);
    assert_eq!(window_score(10, 1.0, 0.0, 0.0, 1.0), f32::NEG_INFINITY);
    assert!(window_score(10, f32::INFINITY, 1.0, 0.0, 1.0).is_nan());
    // a failing window fails the check; a NaN score too; no window test passes by it
    let c = FitCheck::new(0.02, 2000.0, 0.02);
    assert!(c.passes() && c.with_windows(5.0, 3, 22).passes());
    assert!(!c.with_windows(5.4, 3, 22).passes());
    assert!(!c.with_windows(f32::NAN, 3, 22).passes());
    let text = std::format!(
        "{}",
        HealthReport {
            fit_check: Some(c.with_windows(5.4, 3, 22)),
            ..HealthReport::new(FaultVector::HEALTHY, &EmaParams::NOMINAL, 0.02, 1, 1, None)
        }
    );
    assert!(text.contains("worst window 3 z 5.4 (limit 5.34)"), "{text}");
}
