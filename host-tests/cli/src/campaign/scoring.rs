//! How a run is scored beyond the paper's Err%: the ±2σ coverage of the true values and the
//! detectability floor (the part of the error that is a limit of the recording).

use ema_monitor::conditioning::MeasuredTrace;
use ema_monitor::fitness::{CurrentFit, PooledTrace};
use ema_monitor::monitor::{group_pays, group_present, without_group, IdentifyConfig, FAULT_GROUPS};
use ema_monitor::{EmaParams, FaultVector, Profile};

/// `(counted, covered)`: the parameters of the fault groups present in the truth or in the
/// estimate, and those of them whose true value lies within ±2σ of the estimate. A group healthy
/// in both is left out (its exact healthy value would be covered by any σ); the eccentricity
/// phase counts only when both have an eccentricity, by its distance on the circle.
pub fn coverage(truth: &FaultVector, estimate: &FaultVector, sigma: &[f32; 8]) -> (u32, u32) {
    let (mut counted, mut covered) = (0u32, 0u32);
    for &(first, last) in &FAULT_GROUPS {
        let (in_truth, in_estimate) =
            (group_present(&truth.0, (first, last)), group_present(&estimate.0, (first, last)));
        if !in_truth && !in_estimate {
            continue;
        }
        for (i, &s) in sigma.iter().enumerate().take(last + 1).skip(first) {
            let mut d = (truth.0[i] - estimate.0[i]).abs();
            if i == 6 {
                if !(in_truth && in_estimate) {
                    continue;
                }
                d = d.min(1.0 - d);
            }
            counted += 1;
            if d <= 2.0 * s {
                covered += 1;
            }
        }
    }
    (counted, covered)
}

/// The truth with every fault group removed that model selection's criterion would refuse even
/// at the truth: a group of `truth` stays when `group_pays(E(k), E(k without it), parameters,
/// n_eff(k))` at `k = truth`, with the identification's fitness (its fast-regime weight and
/// effect terms). No estimator that applies the criterion can be expected to report a fault
/// whose evidence is below it at the true vector, so the Err% of this vector is the part of a
/// run's error that is a limit of the recording (its noise and manoeuvre), not of the search.
/// Not a strict bound: the truth is not the monitor model's best fit (its mismatch floor), and a
/// nearby vector can fit better.
pub fn detectability_floor<const W: usize>(
    trace: &MeasuredTrace<W>,
    params: &EmaParams,
    profile: &Profile,
    config: &IdentifyConfig,
    truth: &FaultVector,
) -> FaultVector {
    detectability_floor_pooled(trace, &[], params, profile, config, truth)
}

/// [`detectability_floor`] of the pooled fitness over `trace` and the recordings `more` (every
/// one under `profile`): the criterion weighs the evidence of every flight at once.
pub fn detectability_floor_pooled<'a, const W: usize>(
    trace: &'a MeasuredTrace<W>,
    more: &'a [PooledTrace<'a, W>],
    params: &EmaParams,
    profile: &Profile,
    config: &IdentifyConfig,
    truth: &FaultVector,
) -> FaultVector {
    let Some(fit) = CurrentFit::new(trace, *params, *profile)
        .ok()
        .map(|fit| fit.with_effects(config.effects))
        .and_then(|fit| fit.with_fast_regime_weight(config.fast_regime_weight))
        .and_then(|fit| if more.is_empty() { Some(fit) } else { fit.pooled_with(more).ok() })
    else {
        return *truth;
    };
    let error_with = fit.error(truth);
    let n = fit.effective_samples(truth);
    let mut floor = truth.0;
    for &group in &FAULT_GROUPS {
        if group_present(&truth.0, group) {
            let error_without = fit.error(&FaultVector(without_group(&truth.0, group)));
            if !group_pays(error_with, error_without, group.1 - group.0 + 1, n) {
                floor = without_group(&floor, group);
            }
        }
    }
    FaultVector(floor)
}
