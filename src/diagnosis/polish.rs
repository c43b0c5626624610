//! The polish: a compass search over the parameters of the groups the global search found and
//! model selection kept, within what is left of the budget of selection and the polish; without
//! a polish, a vector whose cost is unknown (selection changed it) is evaluated once (the
//! rescore). Either ends in [`Next::Finish`].

use super::config::fault_bounds;
use super::groups::group_present;
use super::stage::Next;
use super::state::{Account, IdentificationState};
use crate::faults::{FaultGroup, FaultVector, FAULT_COUNT};
use crate::optimizer::pattern::{PatternConfig, PatternSearch};
use crate::optimizer::{Optimizer, SearchStatus, TerminationReason};

/// The polish over the present and kept groups' parameters, to run in place of the stage; or,
/// without one, the rescore or the finish with `reason`.
pub(super) fn start<const W: usize>(
    state: &mut IdentificationState<'_, W>,
    reason: TerminationReason,
) -> Result<PatternSearch<FAULT_COUNT>, Next> {
    // Only the groups the global search found and selection kept move: an absent group has no
    // gradient to follow from healthy (the eccentricity phase means nothing without magnitude),
    // so it is set exactly healthy.
    let mut free = [false; FAULT_COUNT];
    for group in FaultGroup::ALL {
        let present = group_present(state.best(), group);
        let (first, last) = group.params();
        // The group's indices by iteration, not by slicing: no range to check, no panic path.
        let in_group = |i: usize| (first..=last).contains(&i);
        let healthy = FaultVector::HEALTHY.0;
        if !present && state.best().iter().zip(healthy).enumerate().any(|(i, (&x, h))| in_group(i) && x != h) {
            state.drop_group(group); // re-evaluated by the polish's first step
        }
        let keep = state.kept(group) && present;
        free.iter_mut().enumerate().filter(|&(i, _)| in_group(i)).for_each(|(_, f)| *f = keep);
    }
    let unscored = state.best_cost().is_nan();
    let Some(polish) = state.config().polish else {
        return Err(unpolished(unscored, reason));
    };
    let start_cost = if unscored { None } else { Some(state.best_cost()) };
    let polish = PatternConfig { max_evaluations: polish.max_evaluations.min(state.budget_left()), ..polish };
    // The configuration was validated in `Identification::new`; with no budget left (or should
    // it fail anyway), keep the result as is.
    PatternSearch::new(fault_bounds(), polish, *state.best(), start_cost, free)
        .map_err(|_| unpolished(unscored, reason))
}

/// Ends without a polish: a rescore first when the cost of the vector is unknown.
fn unpolished(unscored: bool, reason: TerminationReason) -> Next {
    if unscored {
        Next::Rescore(reason)
    } else {
        Next::Finish(reason)
    }
}

/// One step of the polish (one evaluation); its best is the best vector.
pub(super) fn step<const W: usize>(
    search: &mut PatternSearch<FAULT_COUNT>,
    state: &mut IdentificationState<'_, W>,
) -> Next {
    let status = state.step_search(search, Account::Later);
    let (x, c) = search.best();
    state.set_best(*x, c);
    match status {
        SearchStatus::Done(_) => Next::Finish(state.global_reason()),
        SearchStatus::Running => Next::Stay,
    }
}

/// The rescore: one evaluation of the best vector, then the finish with `reason`.
pub(super) fn rescore<const W: usize>(reason: TerminationReason, state: &mut IdentificationState<'_, W>) -> Next {
    state.rescore(Account::Later);
    Next::Finish(reason)
}
