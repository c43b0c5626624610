use super::*;
use crate::conditioning::MIN_SAMPLES;
use crate::profile::Profile;

/// A "measurement" made by the monitor model itself (noise-free), through the conditioner.
fn self_trace(k: &FaultVector) -> ConditionedWindow<2200> {
    let (p, profile) = (EmaParams::NOMINAL, Profile::STANDARD);
    let mut c = ConditionedWindow::new();
    let n = (profile.duration_s() / p.control_period_s) as usize / DECIMATION;
    simulate_window(&p, &profile, k, n, |_, i, _| {
        // feed DECIMATION identical frames whose I_3eq is the block value
        for _ in 0..DECIMATION {
            c.push(i, -i, 0.0).unwrap();
        }
        true
    });
    c.finish().unwrap();
    c
}

#[test]
fn an_unfinished_trace_is_refused_not_indexed() {
    let mut trace = ConditionedWindow::<2200>::new();
    assert_eq!(
        EquivalentCurrentFit::new(&trace, EmaParams::NOMINAL, &Profile::STANDARD).err(),
        Some(ConditioningError::Finished)
    );
    for k in 0..(MIN_SAMPLES + 5) * DECIMATION {
        let i = if k % 50 < 25 { 1.0 } else { 2.0 };
        trace.push(i, -i, 0.0).unwrap();
    }
    // samples in, weights not yet computed: still refused
    assert!(!trace.is_empty());
    assert_eq!(
        EquivalentCurrentFit::new(&trace, EmaParams::NOMINAL, &Profile::STANDARD).err(),
        Some(ConditioningError::Finished)
    );
    trace.finish().unwrap();
    let fit = EquivalentCurrentFit::new(&trace, EmaParams::NOMINAL, &Profile::STANDARD).unwrap();
    assert!(fit.error(&FaultVector::HEALTHY).is_finite());
}

#[test]
fn the_true_vector_has_only_the_windows_rounding_as_error_and_others_do_not() {
    let truth = FaultVector([0.3, 0.1, 0.0, 0.2, 0.0, 0.0, 0.5, 0.4]);
    let trace = self_trace(&truth);
    let fit = EquivalentCurrentFit::new(&trace, EmaParams::NOMINAL, &Profile::STANDARD).unwrap();
    // each stored sample is within half a step of the model's; the weights are at most 1
    let rounding_a = 0.5 * trace.step_a();
    assert!(fit.error(&truth) <= rounding_a * rounding_a, "{} at step {}", fit.error(&truth), trace.step_a());
    for i in [0usize, 1, 3, 7] {
        let mut k = truth;
        k.0[i] += 0.05;
        assert!(fit.error(&k) > 1e-6, "parameter {i} is invisible: {}", fit.error(&k));
    }
}

#[test]
fn effective_samples_fall_with_a_correlated_residual() {
    let truth = FaultVector::HEALTHY;
    let trace = self_trace(&truth);
    let fit = EquivalentCurrentFit::new(&trace, EmaParams::NOMINAL, &Profile::STANDARD).unwrap();
    let n = trace.len() as f32;
    // A wrong gain leaves a smooth (strongly correlated) residual: far fewer than n samples.
    let wrong = FaultVector([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.3]);
    let n_eff = fit.effective_samples(&wrong);
    assert!(n_eff > 0.0 && n_eff < 0.2 * n, "{n_eff} of {n}");
    // The exact vector leaves the window's rounding alone, uncorrelated: nearly every sample counts.
    let n_true = fit.effective_samples(&truth);
    assert!(n_true > 0.8 * n && n_true <= n, "{n_true} of {n}");
}

#[test]
fn fast_regime_is_the_step_and_the_reversal_and_weighs_only_there() {
    let truth = FaultVector([0.2, 0.0, 0.0, 0.1, 0.0, 0.0, 0.5, 0.5]);
    let trace = self_trace(&FaultVector::HEALTHY);
    let paper = EquivalentCurrentFit::new(&trace, EmaParams::NOMINAL, &Profile::STANDARD).unwrap();
    let ours = paper.clone().with_fast_regime_weight(0.1).unwrap();
    let (intervals, weight) = ours.fast_regime();
    assert_eq!(weight, 0.1);
    // the first step (+0.05 rad at 0.01 s) and the reversal (at 0.15 s): 0.4 ms per sample
    assert_eq!(intervals.len(), 2, "{intervals:?}");
    let t = |i: u32| i as f32 * 4e-4;
    assert!(t(intervals[0].0) > 0.01 && t(intervals[0].1) < 0.15, "{intervals:?}");
    assert!(t(intervals[1].0) > 0.15 && t(intervals[1].1) < 0.30, "{intervals:?}");
    // E with ρ, recomputed by hand from the paper's per-sample terms
    let y: std::vec::Vec<f32> = trace.current_a().collect();
    let w: std::vec::Vec<f32> = trace.weights().collect();
    let mut by_hand = 0.0f32;
    simulate_window(&EmaParams::NOMINAL, &Profile::STANDARD, &truth, y.len(), |i, m, _| {
        let fast = intervals.iter().any(|&(a, b)| (a..b).contains(&(i as u32)));
        by_hand += if fast { 0.1 } else { 1.0 } * w[i] * (y[i] - m) * (y[i] - m);
        true
    });
    let by_hand = by_hand / y.len() as f32;
    assert!((ours.error(&truth) - by_hand).abs() <= 1e-6 * by_hand, "{} vs {by_hand}", ours.error(&truth));
    assert!(ours.error(&truth) < paper.error(&truth));
    // weight 1 is the paper's fitness exactly; a weight outside (0, 1] is refused
    let one = paper.clone().with_fast_regime_weight(1.0).unwrap();
    assert_eq!(one.error(&truth), paper.error(&truth));
    for bad in [0.0, -0.5, 1.5, f32::NAN, f32::INFINITY] {
        assert!(paper.clone().with_fast_regime_weight(bad).is_none(), "{bad}");
    }
}

#[test]
fn window_errors_split_the_error() {
    let trace = self_trace(&FaultVector::HEALTHY);
    let fit = EquivalentCurrentFit::new(&trace, EmaParams::NOMINAL, &Profile::STANDARD)
        .unwrap()
        .with_fast_regime_weight(0.1)
        .unwrap();
    let k = FaultVector([0.2, 0.0, 0.0, 0.1, 0.0, 0.0, 0.5, 0.45]);
    let w = fit.window_errors(&k);
    assert_eq!((w.window_samples, w.samples), (EVIDENCE_WINDOW_SAMPLES, trace.len()));
    let used = trace.len().div_ceil(EVIDENCE_WINDOW_SAMPLES);
    assert!(w.errors[..used].iter().all(|e| *e > 0.0) && w.errors[used..].iter().all(|e| *e == 0.0));
    let total: f32 = w.errors.iter().sum();
    let e = fit.error(&k);
    assert!((total - e).abs() <= 1e-5 * e, "{total} vs {e}");
}

#[test]
fn pooled_recordings_weigh_by_samples_and_one_recording_is_unchanged() {
    let (a, b) =
        (self_trace(&FaultVector::HEALTHY), self_trace(&FaultVector([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5])));
    let k = FaultVector([0.1, 0.0, 0.0, 0.1, 0.0, 0.0, 0.5, 0.45]);
    let single = EquivalentCurrentFit::new(&a, EmaParams::NOMINAL, &Profile::STANDARD)
        .unwrap()
        .with_fast_regime_weight(0.1)
        .unwrap();
    let none: [PooledTrace<'_, 2200>; 0] = [];
    let same = single.clone().pooled_with(&none).unwrap();
    assert_eq!(same.error(&k).to_bits(), single.error(&k).to_bits());
    assert_eq!(same.window_errors(&k), single.window_errors(&k));
    assert_eq!(same.effective_samples(&k).to_bits(), single.effective_samples(&k).to_bits());
    // two recordings: E is the sample-weighted mean of the two, n_eff their sum
    let fit_b = EquivalentCurrentFit::new(&b, EmaParams::NOMINAL, &Profile::STANDARD)
        .unwrap()
        .with_fast_regime_weight(0.1)
        .unwrap();
    let more = [PooledTrace { trace: &b, command: Command::Profile(&Profile::STANDARD) }];
    let both = single.clone().pooled_with(&more).unwrap();
    assert_eq!(both.recording_count(), 2);
    assert_eq!(both.samples(), a.len() + b.len());
    assert_eq!(both.fast_regime().0.len(), 4, "{:?}", both.fast_regime());
    let mean = (single.error(&k) + fit_b.error(&k)) / 2.0; // equal lengths
    assert!((both.error(&k) - mean).abs() <= 1e-5 * mean, "{} vs {mean}", both.error(&k));
    let n_eff = single.effective_samples(&k) + fit_b.effective_samples(&k);
    assert!((both.effective_samples(&k) - n_eff).abs() <= 1e-3 * n_eff);
    let total: f32 = both.window_errors(&k).errors.iter().sum();
    assert!((total - both.error(&k)).abs() <= 1e-4 * total, "{total}");
    assert!(
        (both.mean_sample_weight() - (single.mean_sample_weight() + fit_b.mean_sample_weight()) / 2.0).abs() < 1e-5
    );
    // abandoning across recordings: above the bound, or the exact value
    let exact = both.error(&k);
    assert!(both.error_abandoning(&k, exact * 0.3) > exact * 0.3);
    assert_eq!(both.error_abandoning(&k, exact * 2.0), exact);
    // an unfinished recording or too many are refused
    let unfinished = ConditionedWindow::<2200>::new();
    let bad = [PooledTrace { trace: &unfinished, command: Command::Profile(&Profile::STANDARD) }];
    assert_eq!(single.clone().pooled_with(&bad).err(), Some(PoolError::Unfinished { index: 0 }));
    let many = [more[0]; MAX_POOLED_RECORDINGS];
    assert_eq!(single.clone().pooled_with(&many).err(), Some(PoolError::TooMany));
}

#[test]
fn abandoning_returns_above_the_bound_or_the_exact_value() {
    let trace = self_trace(&FaultVector::HEALTHY);
    let fit = EquivalentCurrentFit::new(&trace, EmaParams::NOMINAL, &Profile::STANDARD).unwrap();
    let k = FaultVector([0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.8]);
    let exact = fit.error(&k);
    assert!(exact > 0.0);
    let abandoned = fit.error_abandoning(&k, exact * 0.1);
    assert!(abandoned > exact * 0.1 && abandoned <= exact);
    assert_eq!(fit.error_abandoning(&k, exact * 2.0), exact);
}
