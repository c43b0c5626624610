//! The new-fault probes of a warm start and their targeted refit (`warm.rs` runs the stages
//! around them).
//!
//! For each group absent from the best vector, one evaluation with the group at
//! [`PROBE_SEVERITY`] (the eccentricity at [`ECCENTRICITY_PROBES`] phases, the gain drift on both
//! sides of nominal). A probe **fires** when the same Bayesian information criterion as model
//! selection says the group pays for its parameters at the probe point:
//! [`group_pays`]`(E_probe, E_best, m, n)`. The probe's model run is abandoned as soon as its
//! cost exceeds the criterion's threshold, so a quiet probe costs a fraction of an evaluation.
//! Each fired probe is then scouted by a short compass search over its group alone
//! ([`PROBE_SCOUT`]), and a compass search ([`TARGETED_REFIT`]) from the best scouted point moves
//! that group and the present ones; then the probes of the groups still absent run again (at
//! most [`MAX_NEW_FAULTS`] refits per flight). The choice and its evidence:
//! `docs/decisions/0018-warm-start.md`.

use super::config::{fault_bounds, PHASE_INDEX};
use super::groups::{group_present, group_size, present_free};
use super::selection::group_pays;
use super::stage::Next;
use super::state::{Account, IdentificationState};
use crate::faults::{FaultGroup, FaultParam, FAULT_COUNT};
use crate::optimizer::pattern::{PatternConfig, PatternSearch};
use crate::optimizer::{Objective, Optimizer, SearchStatus, TerminationReason};

/// Severity of a new-fault probe (normalized, the scale of the fault vector): 0.1. A probe
/// fires for a new fault above about half of it (0.05, the campaign's smallest "low" fault);
/// smaller probes sit closer to the noise, larger ones miss the faults between.
pub const PROBE_SEVERITY: f32 = 0.1;

/// The targeted refit after a probe fires: steps from 0.05 (a new fault may lie far from the
/// probe) down to the polish's 2e-4, at most 250 evaluations.
pub const TARGETED_REFIT: PatternConfig = PatternConfig { initial_step: 0.05, min_step: 2.0e-4, max_evaluations: 250 };

/// Targeted refits one warm identification runs at most (new faults found in one flight).
pub const MAX_NEW_FAULTS: u8 = 2;

/// Phases of the eccentricity probes: eight, at `(2j + 1)/16` of a turn. The gain of an
/// eccentricity is narrow in phase (at a severity near the probe's, a probe a quarter of a turn
/// from the fault's phase barely lowers the cost), so a probe grid of a quarter of a turn leaves
/// faults between its points unseen (an eccentricity of 0.18 halfway between two of them);
/// an eighth of a turn halves the largest phase gap.
const ECCENTRICITY_PROBES: usize = 8;

/// Probe points: friction, backlash, the three shorts (one each), eccentricity at
/// [`ECCENTRICITY_PROBES`] phases, gain drift up and down.
const PROBES: usize = 7 + ECCENTRICITY_PROBES;

/// The probe `index` (`0..PROBES`): its group and the parameters it sets, applied to `k`.
fn probe_point(k: &[f32; FAULT_COUNT], index: usize) -> Option<(FaultGroup, [f32; FAULT_COUNT])> {
    let mut x = *k;
    let group = match index {
        0..=4 => {
            *x.get_mut(index)? = PROBE_SEVERITY;
            FaultParam::ALL.get(index)?.group()
        }
        5..=12 => {
            x[5] = PROBE_SEVERITY;
            x[PHASE_INDEX] = (2 * (index - 5) + 1) as f32 / (2 * ECCENTRICITY_PROBES) as f32;
            FaultGroup::Eccentricity
        }
        13 => {
            x[7] = 0.5 + 0.5 * PROBE_SEVERITY;
            FaultGroup::GainDrift
        }
        14 => {
            x[7] = 0.5 - 0.5 * PROBE_SEVERITY;
            FaultGroup::GainDrift
        }
        _ => return None,
    };
    Some((group, x))
}

/// The scout of a fired probe: a short compass search over the probe's group alone, from the
/// probe point (steps 0.05 → 0.0125, at most 16 evaluations). Groups whose effects look alike
/// in the slow regime (the three shorts differ mainly in the fast reversal) can all fire; the
/// probe at a fixed severity does not rank them, their best single-group fits do.
pub const PROBE_SCOUT: PatternConfig = PatternConfig { initial_step: 0.05, min_step: 0.0125, max_evaluations: 16 };

/// Where the probes are.
#[derive(Clone, Debug)]
pub(super) enum Probing {
    /// Runs probe `next` on (one evaluation each); bit `i` of `fired` marks probe `i` fired.
    Probe {
        /// Next probe index.
        next: u8,
        /// Fired probes, bit `i` for probe `i`.
        fired: u16,
    },
    /// Scouts the fired probes in turn (`PROBE_SCOUT`; one evaluation per step).
    Scout {
        /// Fired probes not scouted yet, bit `i` for probe `i`.
        left: u16,
        /// The scout under way.
        search: PatternSearch<FAULT_COUNT>,
        /// The best scouted point and its cost so far.
        best: Option<([f32; FAULT_COUNT], f32)>,
    },
    /// The targeted refit (one evaluation per step).
    Refit(PatternSearch<FAULT_COUNT>),
}

/// The probes from the first ([`Next::Probes`]): from here on, the end of the polish ends the
/// warm stages.
pub(super) fn begin<const W: usize>(state: &mut IdentificationState<'_, W>) -> Probing {
    state.begin_probes();
    Probing::Probe { next: 0, fired: 0 }
}

/// The best point and cost of `search` once its step reports it done.
fn done_at(search: &PatternSearch<FAULT_COUNT>, status: SearchStatus) -> Option<([f32; FAULT_COUNT], f32)> {
    match status {
        SearchStatus::Done(_) => {
            let (x, c) = search.best();
            Some((*x, c))
        }
        SearchStatus::Running => None,
    }
}

impl Probing {
    /// One step of the probes (see [`Probing`] for what each state spends); every evaluation is
    /// the warm stages'. Not inlined: the cold path's step stays as compact as without them.
    #[inline(never)]
    pub(super) fn step<const W: usize>(&mut self, state: &mut IdentificationState<'_, W>) -> Next {
        match self {
            Probing::Probe { next, fired } => {
                let n = state.prior_samples();
                let mut index = usize::from(*next);
                while index < PROBES {
                    match probe_point(state.best(), index) {
                        Some((g, x)) if !group_present(state.best(), g) => {
                            let parameters = group_size(g);
                            let best_cost = state.best_cost();
                            // above this cost the group cannot pay: the model run stops there
                            let threshold =
                                best_cost * libm::expf(-(parameters as f32) * libm::logf(n.max(2.0)) / n.max(2.0));
                            let cost = state.evaluate(Account::Warm, |fit| fit.cost(&x, threshold));
                            let pays = group_pays(cost, best_cost, parameters, n);
                            state.record_probe(pays.then_some(g));
                            if pays {
                                *fired |= 1 << index;
                            }
                            *next = (index + 1) as u8;
                            return Next::Stay;
                        }
                        _ => index += 1,
                    }
                }
                let fired = *fired;
                self.next_scout(state, fired, None)
            }
            Probing::Scout { left, search, best } => {
                let status = state.step_search(search, Account::Warm);
                let Some((x, c)) = done_at(search, status) else { return Next::Stay };
                let best = match *best {
                    Some((_, b)) if b <= c => *best,
                    _ => Some((x, c)),
                };
                let left = *left;
                self.next_scout(state, left, best)
            }
            Probing::Refit(search) => {
                let status = state.step_search(search, Account::Warm);
                if let Some((x, c)) = done_at(search, status) {
                    if c <= state.best_cost() {
                        state.set_best(x, c);
                    }
                    state.record_refit();
                    *self = Probing::Probe { next: 0, fired: 0 };
                }
                Next::Stay
            }
        }
    }

    /// Scouts the next fired probe of `left` (no evaluation: the probe's cost is re-evaluated by
    /// the scout's first step), or, when none is left, starts the targeted refit from `best`.
    fn next_scout<const W: usize>(
        &mut self,
        state: &mut IdentificationState<'_, W>,
        mut left: u16,
        best: Option<([f32; FAULT_COUNT], f32)>,
    ) -> Next {
        while left != 0 {
            let index = left.trailing_zeros() as usize;
            left &= left - 1;
            let Some((g, x)) = probe_point(state.best(), index) else { continue };
            if let Ok(search) = PatternSearch::new(fault_bounds(), PROBE_SCOUT, x, None, group_free(g)) {
                *self = Probing::Scout { left, search, best };
                return Next::Stay;
            }
        }
        self.start_refit(state, best)
    }

    /// The targeted refit from the best scouted point, moving its new group and the present
    /// ones; or the end of the probes when no probe fired or [`MAX_NEW_FAULTS`] refits ran.
    fn start_refit<const W: usize>(
        &mut self,
        state: &mut IdentificationState<'_, W>,
        best: Option<([f32; FAULT_COUNT], f32)>,
    ) -> Next {
        let refits = state.refits().unwrap_or(MAX_NEW_FAULTS);
        let Some((x, cost)) = best else {
            return probes_done(state, TerminationReason::FunctionTolerance);
        };
        if refits >= MAX_NEW_FAULTS {
            return probes_done(state, TerminationReason::MaxIterations);
        }
        match PatternSearch::new(fault_bounds(), TARGETED_REFIT, x, Some(cost), present_free(&x)) {
            Ok(search) => {
                *self = Probing::Refit(search);
                Next::Stay
            }
            Err(_) => probes_done(state, TerminationReason::FunctionTolerance),
        }
    }
}

/// Where a warm identification goes once the probes (and their refits) are over: model
/// selection and the polish when they have not run yet (the probes ran after the drift
/// polish), the end of the warm stages otherwise.
fn probes_done<const W: usize>(state: &mut IdentificationState<'_, W>, reason: TerminationReason) -> Next {
    match state.begin_warm_selection() {
        Some(effective_samples) => Next::SelectGroups { effective_samples },
        None => Next::EndWarm(reason),
    }
}

/// The parameters of `group` free, the others fixed.
fn group_free(group: FaultGroup) -> [bool; FAULT_COUNT] {
    let (first, last) = group.params();
    let mut free = [false; FAULT_COUNT];
    free.iter_mut().enumerate().filter(|(i, _)| (first..=last).contains(i)).for_each(|(_, f)| *f = true);
    free
}
