//! Warm start: an identification from the previous flight's diagnosis, without the global search.
//!
//! A monitor that runs every flight sees faults that change slowly. From a prior fault vector
//! (the last diagnosis) the warm identification ([`super::Identification::warm`]) runs, in order:
//! 1. **start**: the prior with its absent groups exactly healthy, its cost and the effective
//!    sample count `n` of the information criterion (two evaluations);
//! 2. **drift polish** ([`DRIFT_POLISH`]): a coarse compass search over the prior's present
//!    groups, each parameter within [`MAX_DRIFT`] of the prior, so that the cost the probes and
//!    model selection compare with is that of the prior's groups followed by their drift;
//! 3. **new-fault probes** (`probes.rs`): for each group absent from the prior, one evaluation
//!    with the group at [`super::PROBE_SEVERITY`]; a probe **fires** when the same Bayesian
//!    information criterion as model selection says the group pays for its parameters at the
//!    probe point. The probes run before the present groups move freely: a new fault that a
//!    present group can imitate (a new short on phase B by a known short on C grown threefold)
//!    is then still seen as the probe's gain;
//! 4. **targeted refit** when one fires (`probes.rs`): the fired probes are scouted, and a
//!    compass search ([`super::TARGETED_REFIT`]) from the best scouted point moves that group and
//!    the present ones; then the probes of the groups still absent run again (at most
//!    [`super::MAX_NEW_FAULTS`] refits per flight);
//! 5. **model selection and the polish**, as after a cold global search (only the present groups
//!    move): a group the new flight no longer supports is dropped, the others are polished.
//!
//! A probe of severity `s` lowers the cost when the fault is larger than about `s/2` (`E` is
//! nearly quadratic in a fault's severity), so the probe severity sets the smallest new fault
//! one flight detects; smaller ones are left to the evidence pooled over flights. The choice and
//! its evidence: `docs/decisions/0018-warm-start.md`.
//!
//! A warm result that fails its goodness-of-fit test goes on cold in the same call
//! ([`super::WarmReport::cold_fallback`]). When a cold identification is required from the start is
//! [`plan_start`]'s answer: no prior (the
//! first flight, or after maintenance reset the record), every [`IdentifyConfig::cold_every_flights`]
//! flights, and after a warm flight whose result fails its fit check ([`super::WarmReport::needs_cold`]).

use super::config::{fault_bounds, IdentifyConfig, PHASE_INDEX};
use super::groups::{group_present, present_free, without_group};
use super::stage::Next;
use super::state::{Account, IdentificationState, WarmPhase};
use super::MonitorError;
use crate::faults::{FaultGroup, FaultVector, FAULT_COUNT};
use crate::optimizer::pattern::{PatternConfig, PatternSearch};
use crate::optimizer::{Bounds, Optimizer, SearchStatus, TerminationReason};

/// The drift polish of a warm start, before the probes and model selection: a compass search over the prior's
/// present groups, steps from 0.02 (a flight's drift is a few hundredths) down to 2e-3, at most
/// 120 evaluations. Model selection judges a group by `E` with it against `E` of the refit
/// without it; at the unmoved prior, `E` with it is stale by the drift, and a refit of the other
/// groups that absorbs the drift can beat it, so a group the flight still has is dropped (and
/// its probe then fires). After the drift polish, `E` with the group is near its best, as after
/// a cold global search.
///
/// The drift polish stays within [`MAX_DRIFT`] of the prior: a larger move is not a drift but a
/// new fault another group imitates (a new short on phase B fitted by a known short on phase C
/// grown threefold), which the probes must see against the prior's groups, not after them.
pub const DRIFT_POLISH: PatternConfig = PatternConfig { initial_step: 0.02, min_step: 2.0e-3, max_evaluations: 120 };

/// The largest change of a fault parameter between two flights the drift polish follows
/// (normalized): 0.05, above the few hundredths a fault grows by in one flight.
pub const MAX_DRIFT: f32 = 0.05;

/// Default of [`IdentifyConfig::cold_every_flights`]: a cold identification every 20 flights
/// bounds how long a wrong prior (a basin the probes cannot leave) can persist.
pub const COLD_EVERY_FLIGHTS: u32 = 20;

/// Why an identification starts cold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ColdReason {
    /// No prior: the first flight, or the record was reset by maintenance (or found corrupt).
    NoPrior,
    /// The prior is not a fault vector (a non-finite element, or one outside `[0, 1]`).
    InvalidPrior,
    /// [`IdentifyConfig::cold_every_flights`] flights since the last cold identification.
    Periodic,
    /// The last warm identification's result failed its fit check ([`super::WarmReport::needs_cold`]).
    FailedWarm,
}

/// How the next identification starts ([`plan_start`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Start {
    /// The global search, then model selection and the polish ([`super::Identification::new`]).
    Cold(ColdReason),
    /// From the prior ([`super::Identification::warm`]).
    Warm,
}

/// Decides how the next identification starts from what the persisted record holds: the prior
/// (`None` after maintenance or on the first flight), the flights since the last cold
/// identification (0 right after one), and whether the last warm flight asked for a cold one.
pub fn plan_start(
    prior: Option<&[f32; FAULT_COUNT]>,
    flights_since_cold: u32,
    last_warm_needs_cold: bool,
    config: &IdentifyConfig,
) -> Start {
    match prior {
        None => Start::Cold(ColdReason::NoPrior),
        Some(k) if !FaultVector(*k).is_valid() => Start::Cold(ColdReason::InvalidPrior),
        Some(_) if last_warm_needs_cold => Start::Cold(ColdReason::FailedWarm),
        Some(_) if flights_since_cold >= config.cold_every_flights => Start::Cold(ColdReason::Periodic),
        Some(_) => Start::Warm,
    }
}

/// The box of the drift polish around `prior`: each parameter within [`MAX_DRIFT`] of the
/// prior's value (and within the fault bounds), the eccentricity phase free on its circle.
fn drift_bounds(prior: &[f32; FAULT_COUNT]) -> Bounds<FAULT_COUNT> {
    let mut bounds = fault_bounds();
    for (i, &x) in prior.iter().enumerate() {
        if i != PHASE_INDEX {
            bounds.lower[i] = (x - MAX_DRIFT).max(bounds.lower[i]);
            bounds.upper[i] = (x + MAX_DRIFT).min(bounds.upper[i]);
        }
    }
    bounds
}

/// The start point of a warm start from `prior`: the prior in the search box, its absent groups
/// exactly healthy; refused when it is not a fault vector.
pub(super) fn warm_start_point(prior: &[f32; FAULT_COUNT]) -> Result<[f32; FAULT_COUNT], MonitorError> {
    if !FaultVector(*prior).is_valid() {
        return Err(MonitorError::Prior);
    }
    let mut start = *prior;
    fault_bounds().enforce_point(&mut start);
    for group in FaultGroup::ALL {
        if !group_present(&start, group) {
            start = without_group(&start, group);
        }
    }
    Ok(start)
}

/// Where the warm stages before the probes are.
#[derive(Clone, Debug)]
pub(super) enum WarmStart {
    /// Evaluates the prior's cost (one evaluation).
    Start,
    /// Evaluates `n` of the information criterion at the prior (one evaluation), then hands over
    /// to the drift polish (or, with model selection off, to the polish).
    Samples,
    /// Follows the drift of the prior's groups before the probes ([`DRIFT_POLISH`]; one
    /// evaluation per step).
    Drift(PatternSearch<FAULT_COUNT>),
}

impl WarmStart {
    /// One step of the warm stages before the probes (see [`WarmStart`] for what each spends);
    /// every evaluation is the warm stages'. Not inlined: the cold path's step stays as compact
    /// as without them.
    #[inline(never)]
    pub(super) fn step<const W: usize>(&mut self, state: &mut IdentificationState<'_, W>) -> Next {
        match self {
            WarmStart::Start => {
                state.rescore(Account::Warm);
                *self = WarmStart::Samples;
                Next::Stay
            }
            WarmStart::Samples => {
                let best = *state.best();
                let effective_samples = state.evaluate(Account::Warm, |fit| fit.effective_samples(&FaultVector(best)));
                state.set_prior_samples(effective_samples);
                if !state.config().model_selection {
                    return Next::Polish(TerminationReason::FunctionTolerance);
                }
                let free = present_free(&best);
                let bounds = drift_bounds(&best);
                match PatternSearch::new(bounds, DRIFT_POLISH, best, Some(state.best_cost()), free) {
                    Ok(search) if free.iter().any(|&f| f) => {
                        *self = WarmStart::Drift(search);
                        Next::Stay
                    }
                    _ => Next::Probes,
                }
            }
            WarmStart::Drift(search) => {
                let status = state.step_search(search, Account::Warm);
                let SearchStatus::Done(_) = status else { return Next::Stay };
                let (x, c) = search.best();
                if c <= state.best_cost() {
                    state.set_best(*x, c);
                }
                Next::Probes
            }
        }
    }
}

/// Where an identification goes once the polish is over ([`Next::Finish`]): a warm one to the
/// probes when they have not run yet (model selection off) and the vector's cost is known, or
/// to the end of its warm stages; a cold one, or a warm one gone on cold, to the end.
pub(super) fn finish<const W: usize>(state: &IdentificationState<'_, W>, reason: TerminationReason) -> Next {
    match state.warm_phase() {
        WarmPhase::Cold | WarmPhase::FellBack => Next::Done(reason),
        WarmPhase::BeforeProbes if !state.best_cost().is_nan() => Next::Probes,
        WarmPhase::BeforeProbes | WarmPhase::Probing => Next::EndWarm(reason),
    }
}

/// The end of the warm stages ([`Next::EndWarm`]): the fit check of the result (one model run);
/// when it fails, the identification starts over cold in the same call (the global search from
/// its own start; model selection and the polish with their whole budget), since a warm start
/// that does not fit left the prior's basin for a wrong one or never found a new fault's.
pub(super) fn end<const W: usize>(state: &mut IdentificationState<'_, W>, reason: TerminationReason) -> Next {
    if state.fails_fit_check(Account::Warm) && state.fall_back_cold() {
        Next::Global
    } else {
        Next::Done(reason)
    }
}

#[cfg(test)]
mod tests {
    use super::super::identification::tests::noisy_self_trace;
    use super::super::identification::Identification;
    use super::super::state::WarmReport;
    use super::*;
    use crate::conditioning::ConditionedWindow;
    use crate::diagnosis::{ONBOARD_POPULATION, ONBOARD_WINDOW};
    use crate::health::HealthReport;
    use crate::params::EmaParams;
    use crate::profile::Profile;

    type Id<'a> = Identification<'a, ONBOARD_WINDOW, ONBOARD_POPULATION>;

    fn cold(trace: &ConditionedWindow<ONBOARD_WINDOW>) -> HealthReport {
        let mut id = Id::new(trace, EmaParams::NOMINAL, &Profile::STANDARD, &IdentifyConfig::onboard()).unwrap();
        id.run(u32::MAX);
        id.report()
    }

    fn warm(trace: &ConditionedWindow<ONBOARD_WINDOW>, prior: &FaultVector) -> (HealthReport, WarmReport) {
        let config = IdentifyConfig::onboard();
        let mut id = Id::warm(trace, EmaParams::NOMINAL, &Profile::STANDARD, &config, &prior.0).unwrap();
        id.run(u32::MAX);
        let r = id.report();
        assert_eq!(r.fitness, id.fitness().error(&r.faults), "the reported fitness is the reported vector's");
        (r, id.warm_report().unwrap())
    }

    #[test]
    fn a_cold_start_is_required_without_a_prior_periodically_and_after_a_failed_warm_flight() {
        let config = IdentifyConfig::onboard();
        let k = FaultVector::HEALTHY.0;
        assert_eq!(plan_start(None, 3, false, &config), Start::Cold(ColdReason::NoPrior));
        assert_eq!(plan_start(Some(&[f32::NAN; 8]), 3, false, &config), Start::Cold(ColdReason::InvalidPrior));
        assert_eq!(plan_start(Some(&k), 3, true, &config), Start::Cold(ColdReason::FailedWarm));
        assert_eq!(plan_start(Some(&k), COLD_EVERY_FLIGHTS, false, &config), Start::Cold(ColdReason::Periodic));
        assert_eq!(plan_start(Some(&k), COLD_EVERY_FLIGHTS - 1, false, &config), Start::Warm);
        let t = noisy_self_trace(&FaultVector::HEALTHY, 1);
        let bad = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 1.5];
        let r = Id::warm(&t, EmaParams::NOMINAL, &Profile::STANDARD, &config, &bad);
        assert!(matches!(r, Err(MonitorError::Prior)));
    }

    #[test]
    fn warm_from_the_cold_diagnosis_finds_it_again_at_a_fraction_of_the_cost() {
        // friction and a short on phase B: the cold diagnosis as the prior, the same recording
        let truth = FaultVector([0.3, 0.0, 0.0, 0.2, 0.0, 0.0, 0.5, 0.5]);
        let t = noisy_self_trace(&truth, 5);
        let c = cold(&t);
        let (w, report) = warm(&t, &c.faults);
        let (ce, we) = (c.faults.paper_error_percent(&truth), w.faults.paper_error_percent(&truth));
        assert!(we <= ce + 0.2, "Err% warm {we} cold {ce}: {:?} {:?}", w.faults.0, c.faults.0);
        assert_eq!(report.fired, 0, "no new fault: {report:?}");
        assert_eq!(w.status, c.status);
        assert!(w.evaluations * 10 < c.evaluations, "warm {} cold {}", w.evaluations, c.evaluations);
    }

    #[test]
    fn a_probe_fires_on_a_new_fault_and_the_refit_finds_it() {
        // the prior knows the friction; the flight adds a short on phase C or an eccentricity
        let prior = FaultVector([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
        for (truth, group) in [
            (FaultVector([0.3, 0.0, 0.0, 0.0, 0.25, 0.0, 0.5, 0.5]), FaultGroup::ShortC),
            (FaultVector([0.3, 0.0, 0.0, 0.0, 0.0, 0.3, 0.7, 0.5]), FaultGroup::Eccentricity),
        ] {
            let t = noisy_self_trace(&truth, 11);
            let (w, report) = warm(&t, &prior);
            assert!(report.fired_group(group) && report.refits >= 1, "{report:?}");
            let (we, ce) = (w.faults.paper_error_percent(&truth), cold(&t).faults.paper_error_percent(&truth));
            assert!(we <= ce + 0.2, "Err% warm {we} cold {ce}: {:?}", w.faults.0);
            assert!(!report.needs_cold(&w), "{:?}", w.fit_check);
        }
    }
}
