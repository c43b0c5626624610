//! Warm start: an identification from the previous flight's diagnosis, without the global search.
//!
//! A monitor that runs every flight sees faults that change slowly. From a prior fault vector
//! (the last diagnosis) the warm identification ([`Identification::warm`]) runs, in order:
//! 1. **start**: the prior with its absent groups exactly healthy, its cost and the effective
//!    sample count `n` of the information criterion (two evaluations);
//! 2. **drift polish** ([`DRIFT_POLISH`]): a coarse compass search over the prior's present
//!    groups, each parameter within [`MAX_DRIFT`] of the prior, so that the cost the probes and
//!    model selection compare with is that of the prior's groups followed by their drift;
//! 3. **new-fault probes**: for each group absent from the prior, one evaluation with the group
//!    at [`PROBE_SEVERITY`] (the eccentricity at [`ECCENTRICITY_PROBES`] phases, the gain drift
//!    on both sides of nominal). A probe **fires** when
//!    the same Bayesian information criterion as model selection says the group pays for its
//!    parameters at the probe point: [`group_pays`]`(E_probe, E_best, m, n)`. The probe's model
//!    run is abandoned as soon as its cost exceeds the criterion's threshold, so a quiet probe
//!    costs a fraction of an evaluation. The probes run before the present groups move freely:
//!    a new fault that a present group can imitate (a new short on phase B by a known short on C
//!    grown threefold) is then still seen as the probe's gain;
//! 4. **targeted refit** when one fires: each fired probe is scouted by a short compass search
//!    over its group alone ([`PROBE_SCOUT`]), and a compass search ([`TARGETED_REFIT`]) from the
//!    best scouted point moves that group and the present ones; then the probes of the groups
//!    still absent run again (at most [`MAX_NEW_FAULTS`] refits per flight);
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
use super::groups::{group_present, FAULT_GROUPS};
use super::identification::Identification;
use super::selection::group_pays;
use super::stage::{Selection, Stage, WarmStage};
use crate::faults::{FaultVector, FAULT_COUNT};
use crate::fitness::EquivalentCurrentFit;
use crate::optimizer::pattern::{PatternConfig, PatternSearch};
use crate::optimizer::{Bounds, Objective, Optimizer, SearchStatus, TerminationReason};

/// Severity of a new-fault probe (normalized, the scale of the fault vector): 0.1. A probe
/// fires for a new fault above about half of it (0.05, the campaign's smallest "low" fault);
/// smaller probes sit closer to the noise, larger ones miss the faults between.
pub const PROBE_SEVERITY: f32 = 0.1;

/// The targeted refit after a probe fires: steps from 0.05 (a new fault may lie far from the
/// probe) down to the polish's 2e-4, at most 250 evaluations.
pub const TARGETED_REFIT: PatternConfig = PatternConfig { initial_step: 0.05, min_step: 2.0e-4, max_evaluations: 250 };

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

/// Targeted refits one warm identification runs at most (new faults found in one flight).
pub const MAX_NEW_FAULTS: u8 = 2;

/// Default of [`IdentifyConfig::cold_every_flights`]: a cold identification every 20 flights
/// bounds how long a wrong prior (a basin the probes cannot leave) can persist.
pub const COLD_EVERY_FLIGHTS: u32 = 20;

/// Phases of the eccentricity probes: eight, at `(2j + 1)/16` of a turn. The gain of an
/// eccentricity is narrow in phase (at a severity near the probe's, a probe a quarter of a turn
/// from the fault's phase barely lowers the cost), so a probe grid of a quarter of a turn leaves
/// faults between its points unseen (an eccentricity of 0.18 halfway between two of them);
/// an eighth of a turn halves the largest phase gap.
const ECCENTRICITY_PROBES: usize = 8;

/// Probe points: friction, backlash, the three shorts (one each), eccentricity at
/// [`ECCENTRICITY_PROBES`] phases, gain drift up and down.
const PROBES: usize = 7 + ECCENTRICITY_PROBES;

/// The probe `index` (`0..PROBES`): its group (index into [`FAULT_GROUPS`]) and the parameters it
/// sets, applied to `k`.
fn probe_point(k: &[f32; FAULT_COUNT], index: usize) -> Option<(usize, [f32; FAULT_COUNT])> {
    let mut x = *k;
    let group = match index {
        0..=4 => {
            *x.get_mut(index)? = PROBE_SEVERITY;
            index
        }
        5..=12 => {
            x[5] = PROBE_SEVERITY;
            x[PHASE_INDEX] = (2 * (index - 5) + 1) as f32 / (2 * ECCENTRICITY_PROBES) as f32;
            5
        }
        13 => {
            x[7] = 0.5 + 0.5 * PROBE_SEVERITY;
            6
        }
        14 => {
            x[7] = 0.5 - 0.5 * PROBE_SEVERITY;
            6
        }
        _ => return None,
    };
    Some((group, x))
}

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
    /// The global search, then model selection and the polish ([`Identification::new`]).
    Cold(ColdReason),
    /// From the prior ([`Identification::warm`]).
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

/// The scout of a fired probe: a short compass search over the probe's group alone, from the
/// probe point (steps 0.05 → 0.0125, at most 16 evaluations). Groups whose effects look alike
/// in the slow regime (the three shorts differ mainly in the fast reversal) can all fire; the
/// probe at a fixed severity does not rank them, their best single-group fits do.
pub const PROBE_SCOUT: PatternConfig = PatternConfig { initial_step: 0.05, min_step: 0.0125, max_evaluations: 16 };

/// The parameters of `FAULT_GROUPS[group]` free, the others fixed.
fn group_free(group: usize) -> [bool; FAULT_COUNT] {
    let mut free = [false; FAULT_COUNT];
    if let Some(&(first, last)) = FAULT_GROUPS.get(group) {
        free.iter_mut().enumerate().filter(|(i, _)| (first..=last).contains(i)).for_each(|(_, f)| *f = true);
    }
    free
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

/// The parameters of the groups present in `k` free, the others fixed.
fn present_free(k: &[f32; FAULT_COUNT]) -> [bool; FAULT_COUNT] {
    let mut free = [false; FAULT_COUNT];
    for &(first, last) in FAULT_GROUPS.iter() {
        let present = group_present(k, (first, last));
        free.iter_mut().enumerate().filter(|(i, _)| (first..=last).contains(i)).for_each(|(_, f)| *f = present);
    }
    free
}

/// One step of a warm stage's compass search, its evaluations added to `evaluations`; the
/// search's best point and cost once it is done.
fn step_counted<const W: usize>(
    search: &mut PatternSearch<FAULT_COUNT>,
    fit: &mut EquivalentCurrentFit<'_, W>,
    evaluations: &mut u32,
) -> Option<([f32; FAULT_COUNT], f32)> {
    let before = search.evaluations();
    let status = search.step(fit);
    *evaluations += search.evaluations() - before;
    match status {
        SearchStatus::Done(_) => {
            let (x, c) = search.best();
            Some((*x, c))
        }
        _ => None,
    }
}

impl<const W: usize, const P: usize> Identification<'_, W, P> {
    /// One step of the warm stages (see [`WarmStage`] for what each spends). Not inlined: the
    /// cold path's `step` stays as compact as without the warm stages.
    #[inline(never)]
    pub(super) fn warm_step(&mut self) {
        let Some(warm) = self.warm.as_mut() else { return };
        let Stage::Warm(stage) = &mut self.stage else { return };
        match stage {
            WarmStage::Start => {
                self.best_cost = self.fit.error(&FaultVector(self.best));
                warm.report.evaluations += 1;
                *stage = WarmStage::Samples;
            }
            WarmStage::Samples => {
                let effective_samples = self.fit.effective_samples(&FaultVector(self.best));
                warm.effective_samples = effective_samples;
                warm.report.evaluations += 1;
                if !self.config.model_selection {
                    self.start_polish(TerminationReason::FunctionTolerance);
                    return;
                }
                let free = present_free(&self.best);
                let bounds = drift_bounds(&self.best);
                match PatternSearch::new(bounds, DRIFT_POLISH, self.best, Some(self.best_cost), free) {
                    Ok(search) if free.iter().any(|&f| f) => *stage = WarmStage::Drift(search),
                    _ => {
                        warm.probing = true;
                        *stage = WarmStage::Probe { next: 0, fired: 0 };
                    }
                }
            }
            WarmStage::Drift(search) => {
                if let Some((x, c)) = step_counted(search, &mut self.fit, &mut warm.report.evaluations) {
                    if c <= self.best_cost {
                        (self.best, self.best_cost) = (x, c);
                    }
                    warm.probing = true;
                    *stage = WarmStage::Probe { next: 0, fired: 0 };
                }
            }
            WarmStage::Probe { next, fired } => {
                let n = warm.effective_samples;
                let mut index = usize::from(*next);
                while index < PROBES {
                    match probe_point(&self.best, index) {
                        Some((g, x)) if FAULT_GROUPS.get(g).is_some_and(|&group| !group_present(&self.best, group)) => {
                            let parameters = FAULT_GROUPS.get(g).map_or(1, |&(first, last)| last - first + 1);
                            // above this cost the group cannot pay: the model run stops there
                            let threshold =
                                self.best_cost * libm::expf(-(parameters as f32) * libm::logf(n.max(2.0)) / n.max(2.0));
                            let cost = self.fit.cost(&x, threshold);
                            warm.report.evaluations += 1;
                            warm.report.probes = warm.report.probes.saturating_add(1);
                            if group_pays(cost, self.best_cost, parameters, n) {
                                warm.report.fired |= 1 << g;
                                *fired |= 1 << index;
                            }
                            *next = (index + 1) as u8;
                            return;
                        }
                        _ => index += 1,
                    }
                }
                let fired = *fired;
                self.next_scout(fired, None);
            }
            WarmStage::Scout { left, search, best } => {
                if let Some((x, c)) = step_counted(search, &mut self.fit, &mut warm.report.evaluations) {
                    let best = match *best {
                        Some((_, b)) if b <= c => *best,
                        _ => Some((x, c)),
                    };
                    let left = *left;
                    self.next_scout(left, best);
                }
            }
            WarmStage::Refit(search) => {
                if let Some((x, c)) = step_counted(search, &mut self.fit, &mut warm.report.evaluations) {
                    if c <= self.best_cost {
                        (self.best, self.best_cost) = (x, c);
                    }
                    warm.report.refits += 1;
                    *stage = WarmStage::Probe { next: 0, fired: 0 };
                }
            }
        }
    }

    /// Scouts the next fired probe of `left` (no evaluation: the probe's cost is re-evaluated by
    /// the scout's first step), or, when none is left, starts the targeted refit from `best`.
    fn next_scout(&mut self, mut left: u16, best: Option<([f32; FAULT_COUNT], f32)>) {
        while left != 0 {
            let index = left.trailing_zeros() as usize;
            left &= left - 1;
            let Some((g, x)) = probe_point(&self.best, index) else { continue };
            if let Ok(search) = PatternSearch::new(fault_bounds(), PROBE_SCOUT, x, None, group_free(g)) {
                self.stage = Stage::Warm(WarmStage::Scout { left, search, best });
                return;
            }
        }
        self.start_refit(best);
    }

    /// The targeted refit from the best scouted point, moving its new group and the present
    /// ones; or the end when no probe fired or [`MAX_NEW_FAULTS`] refits ran.
    fn start_refit(&mut self, best: Option<([f32; FAULT_COUNT], f32)>) {
        let refits = self.warm.map_or(MAX_NEW_FAULTS, |w| w.report.refits);
        let Some((x, cost)) = best else {
            self.probes_done(TerminationReason::FunctionTolerance);
            return;
        };
        if refits >= MAX_NEW_FAULTS {
            self.probes_done(TerminationReason::MaxIterations);
            return;
        }
        match PatternSearch::new(fault_bounds(), TARGETED_REFIT, x, Some(cost), present_free(&x)) {
            Ok(search) => self.stage = Stage::Warm(WarmStage::Refit(search)),
            Err(_) => self.probes_done(TerminationReason::FunctionTolerance),
        }
    }

    /// Where a warm identification goes once the probes (and their refits) are over: model
    /// selection and the polish when they have not run yet (the probes ran after the drift
    /// polish), the end otherwise.
    fn probes_done(&mut self, reason: TerminationReason) {
        match self.warm.as_mut() {
            Some(warm) if self.config.model_selection && !warm.selected => {
                warm.selected = true;
                let effective_samples = warm.effective_samples;
                self.stage = Stage::Select(Selection::NextGroup { group: 0, effective_samples });
            }
            _ => self.end_warm(reason),
        }
    }

    /// The end of the warm stages: the fit check of the result (one model run); when it fails,
    /// the identification starts over cold in the same call (the global search from its own
    /// start; model selection and the polish with their whole budget), since a warm start that
    /// does not fit left the prior's basin for a wrong one or never found a new fault's.
    fn end_warm(&mut self, reason: TerminationReason) {
        let fails = self.report().fit_check.is_some_and(|c| !c.passes());
        let Some(warm) = self.warm.as_mut() else {
            self.stage = Stage::Done(reason);
            return;
        };
        warm.report.evaluations += 1;
        if !fails || warm.report.cold_fallback {
            self.stage = Stage::Done(reason);
            return;
        }
        warm.report.cold_fallback = true;
        warm.report.evaluations += self.selection_polish_evaluations;
        self.selection_polish_evaluations = 0;
        self.kept = [true; FAULT_GROUPS.len()];
        self.untested_groups = 0;
        (self.best, self.best_cost) = (FaultVector::HEALTHY.0, f32::INFINITY);
        self.stage = Stage::Global;
    }

    /// Where a warm identification goes once the polish is over: the probes when they have not
    /// run yet (model selection off), or the end.
    pub(super) fn finish(&mut self, reason: TerminationReason) {
        match self.warm.as_mut() {
            Some(warm) if warm.report.cold_fallback => self.stage = Stage::Done(reason),
            Some(warm) if !warm.probing && !self.best_cost.is_nan() => {
                warm.probing = true;
                self.stage = Stage::Warm(WarmStage::Probe { next: 0, fired: 0 });
            }
            Some(_) => self.end_warm(reason),
            None => self.stage = Stage::Done(reason),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::identification::tests::noisy_self_trace;
    use super::super::stage::WarmReport;
    use super::*;
    use crate::conditioning::ConditionedWindow;
    use crate::health::HealthReport;
    use crate::monitor::{MonitorError, ONBOARD_POPULATION, ONBOARD_WINDOW};
    use crate::params::EmaParams;
    use crate::profile::Profile;

    type Id<'a> = Identification<'a, ONBOARD_WINDOW, ONBOARD_POPULATION>;

    fn cold(trace: &ConditionedWindow<ONBOARD_WINDOW>) -> HealthReport {
        let mut id = Id::new(trace, EmaParams::NOMINAL, Profile::STANDARD, &IdentifyConfig::onboard()).unwrap();
        id.run(u32::MAX);
        id.report()
    }

    fn warm(trace: &ConditionedWindow<ONBOARD_WINDOW>, prior: &FaultVector) -> (HealthReport, WarmReport) {
        let config = IdentifyConfig::onboard();
        let mut id = Id::warm(trace, EmaParams::NOMINAL, Profile::STANDARD, &config, &prior.0).unwrap();
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
        let r = Id::warm(&t, EmaParams::NOMINAL, Profile::STANDARD, &config, &bad);
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
            (FaultVector([0.3, 0.0, 0.0, 0.0, 0.25, 0.0, 0.5, 0.5]), 4),
            (FaultVector([0.3, 0.0, 0.0, 0.0, 0.0, 0.3, 0.7, 0.5]), 5),
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
