//! How a run is scored beyond the paper's Err%: the ±2σ coverage of the true values, the
//! detectability floor (the part of the error that is a limit of the recording) and how the
//! report's "not detectable below" bounds read against the truth.

use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::{group_pays, group_present, group_size, without_group, IdentifyConfig};
use ema_monitor::faults::FaultGroup;
use ema_monitor::fitness::{EquivalentCurrentFit, PooledTrace};
use ema_monitor::health::{HealthReport, Uncertainty};
use ema_monitor::{EmaParams, FaultVector, Profile};

/// The faulted modes of a run that its report gives as not found (a "not detectable below"
/// bound, [`Uncertainty::detectable_below`]), counted against the truth's severities.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BoundsVsTruth {
    /// Faulted modes reported not found whose bound lies above the truth's severity: the
    /// recording could not tell them, and the report says so.
    pub covered: u32,
    /// Faulted modes reported not found whose bound lies at or below the truth's severity (or
    /// is NaN): faults the recording could tell, missed.
    pub missed: u32,
}

impl BoundsVsTruth {
    /// `true` when every faulted mode lies at or above the recording's smallest detectable
    /// severity: none is covered by its bound. The run's Err% then measures the monitor, not
    /// the manoeuvre.
    pub fn detectable(&self) -> bool {
        self.covered == 0
    }
}

/// [`BoundsVsTruth`] of a report's `uncertainty` against `truth` (severities per mode as
/// [`HealthReport::new`] reads them from the vector, against the actuator `params`). A report
/// without uncertainty (an abstention) gives no bound: nothing is counted.
pub fn bounds_vs_truth(truth: &FaultVector, params: &EmaParams, uncertainty: Option<&Uncertainty>) -> BoundsVsTruth {
    let mut counts = BoundsVsTruth::default();
    let Some(u) = uncertainty else { return counts };
    let modes = HealthReport::new(*truth, params, 0.0, 0, 0, None).modes;
    for (mode, bound) in modes.iter().zip(u.detectable_below) {
        let Some(bound) = bound else { continue };
        if mode.severity <= 0.0 {
            continue;
        }
        if bound > mode.severity {
            counts.covered += 1;
        } else {
            counts.missed += 1;
        }
    }
    counts
}

/// `(counted, covered)`: the parameters of the fault groups present in the truth or in the
/// estimate, and those of them whose true value lies within ±2σ of the estimate. A group healthy
/// in both is left out (its exact healthy value would be covered by any σ); the eccentricity
/// phase counts only when both have an eccentricity, by its distance on the circle.
pub fn coverage(truth: &FaultVector, estimate: &FaultVector, sigma: &[f32; 8]) -> (u32, u32) {
    let (mut counted, mut covered) = (0u32, 0u32);
    for group in FaultGroup::ALL {
        let (first, last) = group.params();
        let (in_truth, in_estimate) = (group_present(&truth.0, group), group_present(&estimate.0, group));
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
    trace: &ConditionedWindow<W>,
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
    trace: &'a ConditionedWindow<W>,
    more: &'a [PooledTrace<'a, W>],
    params: &EmaParams,
    profile: &Profile,
    config: &IdentifyConfig,
    truth: &FaultVector,
) -> FaultVector {
    let Some(fit) = EquivalentCurrentFit::new(trace, *params, profile)
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
    for group in FaultGroup::ALL {
        if group_present(&truth.0, group) {
            let error_without = fit.error(&FaultVector(without_group(&truth.0, group)));
            if !group_pays(error_with, error_without, group_size(group), n) {
                floor = without_group(&floor, group);
            }
        }
    }
    FaultVector(floor)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Friction 0.03 and a short circuit 0.2 on phase B in the truth; the report finds neither,
    /// friction "not detectable below" 0.05 (it hides below) and the short below 0.1 (missed);
    /// backlash, absent from the truth, has a bound too and is not counted.
    #[test]
    fn bounds_count_the_faulted_modes_reported_not_found() {
        let truth = FaultVector([0.03, 0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5]);
        let params = EmaParams::NOMINAL;
        let u = Uncertainty { sigma: [0.01; 8], detectable_below: [Some(0.05), Some(0.01), Some(0.1), None, None] };
        let b = bounds_vs_truth(&truth, &params, Some(&u));
        assert_eq!(b, BoundsVsTruth { covered: 1, missed: 1 });
        assert!(!b.detectable());
        // a mode found has no bound; a report without uncertainty counts nothing
        let found = Uncertainty { detectable_below: [None, Some(0.01), None, None, None], ..u };
        assert_eq!(bounds_vs_truth(&truth, &params, Some(&found)), BoundsVsTruth::default());
        assert!(bounds_vs_truth(&truth, &params, None).detectable());
        // a bound exactly at the truth's severity: the recording could tell it
        let at = Uncertainty { detectable_below: [Some(0.03), None, None, None, None], ..u };
        assert_eq!(bounds_vs_truth(&truth, &params, Some(&at)), BoundsVsTruth { covered: 0, missed: 1 });
    }
}
