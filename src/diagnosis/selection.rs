//! Model selection: after the global search, each fault group present in the best vector is set
//! back to healthy in turn, the other groups are refitted, and the group stays only when it pays
//! for its parameters.
//!
//! A group is tested in three steps, each an explicit [`Selection`] state:
//! 1. **refit**: a compass search ([`SELECTION_REFIT`]) refits the other present groups with the
//!    tested one healthy, so the nested model is compared at its own best;
//! 2. **information criterion**: the group stays when
//!    `ΔBIC = n·ln(E_without/E_with) − m·ln(n) > 0` ([`group_pays`]; `m` its parameters, `n` the
//!    effective samples of the residual; `docs/decisions/0006-model-selection-bic.md`);
//! 3. **window check**: a group that pays must still lower `E` on the trace without the window
//!    where it gains most ([`helps_without_its_best_window`], two evaluations;
//!    `docs/decisions/0002-window-check.md`).
//!
//! Groups refused are set back to healthy. Then each short circuit left is tried on the other
//! phases ([`PHASE_MOVES`], at most 7 evaluations), and a move that lowers `E` is kept, before the
//! polish. Every step spends from the budget of
//! [`IdentifyConfig::selection_polish_max_evaluations`](super::IdentifyConfig); the groups it has
//! no budget left to test stay and are counted in the report.

use super::config::{fault_bounds, PHASE_INDEX};
use super::groups::{group_present, group_size, without_group, PRESENT_ABOVE};
use super::stage::Next;
use super::state::{Account, IdentificationState};
use crate::faults::{FaultGroup, FaultParam, FaultVector, FAULT_COUNT};
use crate::fitness::WindowErrors;
use crate::optimizer::pattern::{PatternConfig, PatternSearch};
use crate::optimizer::{Optimizer, SearchStatus};

/// The refit of the other groups when one group is set back to healthy: steps from 0.01 down to
/// 1e-3, at most 120 evaluations. A nested model is compared at its own best, not at the full
/// model's: otherwise parameters that co-adapted with the group make it look needed.
pub const SELECTION_REFIT: PatternConfig = PatternConfig { initial_step: 0.01, min_step: 1e-3, max_evaluations: 120 };

/// Bayesian information criterion for dropping a group of `parameters`: with Gaussian residuals of
/// `n` effective samples, `ΔBIC = n·ln(E_without/E_with) − parameters·ln(n)`; the group stays only
/// when `ΔBIC > 0`, i.e. when it explains more than its parameters' price (G. Schwarz, "Estimating
/// the dimension of a model", Annals of Statistics 6(2), 1978).
pub fn group_pays(error_with: f32, error_without: f32, parameters: usize, effective_samples: f32) -> bool {
    if !(error_with > 0.0 && error_without.is_finite() && effective_samples > 1.0) {
        return error_without > error_with;
    }
    effective_samples * libm::logf(error_without / error_with) > parameters as f32 * libm::logf(effective_samples)
}

/// Share of its best window's gain a group must also gain on the rest of the trace when the refit
/// without it brings in no group of its own ([`helps_without_its_best_window`]). A fault shows
/// wherever the actuator moves; a group that gains a few percent of its best window elsewhere
/// fits something local to that window (`docs/decisions/0002-window-check.md`).
pub const WINDOW_GAIN_SHARE: f32 = 0.25;

/// `true` when a group still lowers `E` on the trace without the window where it gains most:
/// `with` and `without` are `E` per window of the vectors with and without the group (the
/// refit), and the rest of the trace must gain more than `share` of the best window's gain.
///
/// A group whose net gain comes from one 40 ms stretch of the recording, and which makes the fit
/// worse elsewhere, fits something local there (a cogging ripple read as an eccentricity), not a
/// fault. When the refit replaced the group by another (a low short on phase A refitted as one
/// on C, [`refit_replaces`]), pass `share` = 0: the two differ only where the phase shows, in the
/// fast reversal, and the rest need only not lose. No price is asked on the rest: the
/// information criterion has priced the whole trace already (`docs/decisions/0002-window-check.md`).
pub fn helps_without_its_best_window(with: &WindowErrors, without: &WindowErrors, share: f32) -> bool {
    let mut best = (0usize, f32::NEG_INFINITY);
    for (j, (a, b)) in with.errors.iter().zip(&without.errors).enumerate() {
        if b - a > best.1 {
            best = (j, b - a);
        }
    }
    let mut gain_elsewhere = 0.0f32;
    for (j, (a, b)) in with.errors.iter().zip(&without.errors).enumerate() {
        if j != best.0 {
            gain_elsewhere += b - a;
        }
    }
    gain_elsewhere > share * best.1
}

/// How far the refit without a group must move another group's magnitude to count as taking its
/// place ([`refit_replaces`]): one initial step of [`SELECTION_REFIT`].
pub const REPLACED_ABOVE: f32 = 0.01;

/// `true` when the refit `without` the group `tested` moved another group's magnitude by more than
/// `REPLACED_ABOVE` (0.01) from `with`: another explanation took the group's place (a low short on
/// phase A beside a smaller one on C, refitted as a larger one on C), so
/// [`helps_without_its_best_window`] runs with `share` = 0.
pub fn refit_replaces(with: &[f32; FAULT_COUNT], without: &[f32; FAULT_COUNT], tested: FaultGroup) -> bool {
    let (first, last) = tested.params();
    with.iter()
        .zip(without)
        .enumerate()
        .any(|(i, (a, b))| i != PHASE_INDEX && !(first..=last).contains(&i) && libm::fabsf(a - b) > REPLACED_ABOVE)
}

/// The phase moves of the short circuits, as `(from, to)` indices into the fault vector (`k3`,
/// `k4`, `k5`: shorts on phases A, B, C): each short moved to each other phase, in this order,
/// the two moves of a phase side by side (both start from the same vector, and the better one is
/// kept).
/// The three shorts are separate basins of `E` (`docs/decisions/0010-basin-seeds.md`): a short
/// budget of the global search can end in the wrong one, where the severity is right and the
/// phase is not, and no local step (refit, polish) crosses from one basin to the other. A move
/// tries the other basin at once (`docs/decisions/0026-short-phase-move.md`).
pub const PHASE_MOVES: [(usize, usize); 6] = [(2, 3), (2, 4), (3, 2), (3, 4), (4, 2), (4, 3)];

/// `k` with the short of the move `(from, to)` ([`PHASE_MOVES`]) moved onto the phase `to`: its
/// severity is added to that phase's (a short split over two phases merges into one), capped at 1,
/// and the phase `from` set healthy. `None` when there is no short on `from` to move (or an index
/// is outside the vector).
pub fn phase_moved(k: &[f32; FAULT_COUNT], (from, to): (usize, usize)) -> Option<[f32; FAULT_COUNT]> {
    let (&severity, &there) = (k.get(from)?, k.get(to)?);
    if from == to || severity <= PRESENT_ABOVE {
        return None;
    }
    let mut out = *k;
    *out.get_mut(from)? = 0.0;
    *out.get_mut(to)? = (severity + there).min(1.0);
    Some(out)
}

/// Where model selection is. `group` is an index in [`FaultGroup::ALL`] (a cursor over the
/// groups: the enum's layout stays that of a plain index); `effective_samples` is the `n` of
/// the information criterion, evaluated once on the global search's best vector.
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant, reason = "held once, inline in the identification: no allocator to box into")]
pub(super) enum Selection {
    /// Evaluates the effective sample count of the best vector (one evaluation).
    EffectiveSamples,
    /// Evaluates the best vector with `group` set back to healthy, before any refit (one
    /// evaluation): a group that does not pay even against this unrefitted cost is dropped
    /// without its refit (`Selection::pre_check`).
    PreCheck {
        /// Index in [`FaultGroup::ALL`] of the group under test.
        group: usize,
        /// `n` of the information criterion.
        effective_samples: f32,
    },
    /// Starts the test of the first present group from `group` on (no evaluation).
    NextGroup {
        /// Index in [`FaultGroup::ALL`] of the first group to consider.
        group: usize,
        /// `n` of the information criterion.
        effective_samples: f32,
    },
    /// Refits the other groups with `group` set back to healthy (one evaluation per step).
    Refit {
        /// Index in [`FaultGroup::ALL`] of the group under test.
        group: usize,
        /// `n` of the information criterion.
        effective_samples: f32,
        /// The compass search of the refit.
        search: PatternSearch<FAULT_COUNT>,
    },
    /// Checks window by window a group that paid the information criterion.
    WindowCheck {
        /// Index in [`FaultGroup::ALL`] of the group under test.
        group: usize,
        /// `n` of the information criterion.
        effective_samples: f32,
        /// Which of the check's two evaluations is next.
        check: WindowCheck,
    },
    /// After the groups are judged: scores the vector when selection changed it (one
    /// evaluation), then tries the next possible move of `PHASE_MOVES` from `next` on (one
    /// evaluation each, abandoned above the best cost) and keeps it when it lowers `E`.
    PhaseMove {
        /// First move of `PHASE_MOVES` not tried yet.
        next: usize,
        /// The vector the moves of `next`'s phase start from: the best one before the first of
        /// them, so the second competes with the first instead of moving its result.
        origin: [f32; FAULT_COUNT],
    },
}

/// The window-by-window check of a group that paid the information criterion
/// (`helps_without_its_best_window`): two evaluations, one state each.
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant, reason = "held once, inline in the identification: no allocator to box into")]
pub(super) enum WindowCheck {
    /// Evaluates `E` per window of the best vector, with the group.
    With {
        /// The refit without the group.
        without: [f32; FAULT_COUNT],
    },
    /// Evaluates `E` per window of the refit without the group, then decides.
    Without {
        /// The refit without the group.
        without: [f32; FAULT_COUNT],
        /// `E` per window with the group.
        with: WindowErrors,
    },
}

type State<'s, 'a, const W: usize> = &'s mut IdentificationState<'a, W>;

impl Selection {
    /// One step of model selection (see [`Selection`] for what each state spends); every
    /// evaluation is spent from the budget of selection and the polish.
    pub(super) fn step<const W: usize>(&mut self, state: State<'_, '_, W>) -> Next {
        match self {
            Selection::EffectiveSamples => {
                let best = *state.best();
                let effective_samples = state.evaluate(Account::Later, |fit| fit.effective_samples(&FaultVector(best)));
                *self = Selection::NextGroup { group: 0, effective_samples };
                Next::Stay
            }
            Selection::PreCheck { group, effective_samples } => {
                let (group, effective_samples) = (*group, *effective_samples);
                match FaultGroup::from_index(group) {
                    Some(tested) => self.pre_check(state, tested, effective_samples),
                    None => self.next_test(state, group, effective_samples),
                }
            }
            Selection::NextGroup { group, effective_samples } => {
                let (group, effective_samples) = (*group, *effective_samples);
                self.next_test(state, group, effective_samples)
            }
            Selection::Refit { group, effective_samples, search } => {
                let status = state.step_search(search, Account::Later);
                if let SearchStatus::Done(_) = status {
                    let (group, effective_samples) = (*group, *effective_samples);
                    return match FaultGroup::from_index(group) {
                        Some(tested) => self.refit_done(state, tested, effective_samples),
                        None => self.next_test(state, group + 1, effective_samples),
                    };
                }
                Next::Stay
            }
            Selection::PhaseMove { next, origin } => {
                let (next, origin) = (*next, *origin);
                self.phase_move_step(state, next, origin)
            }
            Selection::WindowCheck { group, effective_samples, check } => match check {
                WindowCheck::With { without } => {
                    let without = *without;
                    let best = *state.best();
                    let with = state.evaluate(Account::Later, |fit| fit.window_errors(&FaultVector(best)));
                    *check = WindowCheck::Without { without, with };
                    Next::Stay
                }
                WindowCheck::Without { without, with } => {
                    let (group, effective_samples) = (*group, *effective_samples);
                    let without_errors =
                        state.evaluate(Account::Later, |fit| fit.window_errors(&FaultVector(*without)));
                    let tested = FaultGroup::from_index(group);
                    let replaced = tested.is_some_and(|tested| refit_replaces(state.best(), without, tested));
                    let share = if replaced { 0.0 } else { WINDOW_GAIN_SHARE };
                    let pays = helps_without_its_best_window(with, &without_errors, share);
                    if let Some(tested) = tested {
                        state.keep(tested, pays);
                    }
                    self.next_test(state, group + 1, effective_samples)
                }
            },
        }
    }

    /// Judges the finished refit of `group` and moves on to its window check or the next group.
    fn refit_done<const W: usize>(
        &mut self,
        state: State<'_, '_, W>,
        group: FaultGroup,
        effective_samples: f32,
    ) -> Next {
        let Selection::Refit { search, .. } = self else { return Next::Stay };
        let (x, without) = search.best();
        let x = *x;
        match judge_refit(state, group, effective_samples, x, without) {
            Some(check) => {
                *self = Selection::WindowCheck { group: group.index(), effective_samples, check };
                Next::Stay
            }
            None => self.next_test(state, group.index() + 1, effective_samples),
        }
    }

    /// The pre-check of `group` (one evaluation): `E` of the best vector with the group set back
    /// to healthy and nothing refitted. A refit can only lower that cost, and a lower
    /// `E_without` makes the group pay less, so a group that fails the information criterion
    /// against the unrefitted cost fails it against any refit: it is dropped at once (and an
    /// unrefitted vector that fits better than the best becomes the one to beat). A group that
    /// pays gets its refit, which starts from this point with its cost known, so the refit's
    /// trials and the evaluations spent are those of a refit without the pre-check
    /// (`docs/decisions/0018-warm-start.md`).
    fn pre_check<const W: usize>(
        &mut self,
        state: State<'_, '_, W>,
        group: FaultGroup,
        effective_samples: f32,
    ) -> Next {
        let start = without_group(state.best(), group);
        let cost = state.evaluate(Account::Later, |fit| fit.error(&FaultVector(start)));
        let parameters = group_size(group);
        let best_cost = state.best_cost();
        let pays = cost >= best_cost && group_pays(best_cost, cost, parameters, effective_samples);
        if !pays {
            if cost < best_cost {
                state.set_best(start, cost);
            }
            state.keep(group, false);
            return self.next_test(state, group.index() + 1, effective_samples);
        }
        // The refit's budget as `next_test` gave it before this evaluation, less the evaluation
        // of its start point done here (at least 1: that budget was at least 2).
        let refit_budget = SELECTION_REFIT.max_evaluations.min(state.budget_left()).saturating_sub(1).max(1);
        let mut free = [false; FAULT_COUNT];
        for other in FaultGroup::ALL {
            let (first, last) = other.params();
            let movable = other != group && state.kept(other) && group_present(state.best(), other);
            // The group's indices by iteration, not by slicing: no range to check, no panic path.
            let in_group = |i: usize| (first..=last).contains(&i);
            free.iter_mut().enumerate().filter(|&(i, _)| in_group(i)).for_each(|(_, f)| *f = movable);
        }
        let config = PatternConfig { max_evaluations: refit_budget, ..SELECTION_REFIT };
        match PatternSearch::new(fault_bounds(), config, start, Some(cost), free) {
            Ok(search) => {
                let done = matches!(search.status(), SearchStatus::Done(_));
                *self = Selection::Refit { group: group.index(), effective_samples, search };
                if done {
                    return self.refit_done(state, group, effective_samples); // nothing free: judged on the pre-check
                }
                Next::Stay
            }
            Err(_) => self.next_test(state, group.index() + 1, effective_samples),
        }
    }

    /// Starts the refit for the first present group from `group` on, or ends model selection and
    /// starts the polish. Spends no evaluation (the refit's first step evaluates its start point).
    /// A refit gets at most what is left of the budget but one, kept for the cost of a vector
    /// selection changed; with fewer than two to give, the groups not yet tested stay.
    fn next_test<const W: usize>(&mut self, state: State<'_, '_, W>, mut group: usize, effective_samples: f32) -> Next {
        let refit_budget = SELECTION_REFIT.max_evaluations.min(state.budget_left().saturating_sub(1));
        while let Some(tested) = FaultGroup::from_index(group) {
            if refit_budget < 2 {
                state.leave_untested_from(tested);
                break;
            }
            if group_present(state.best(), tested) {
                *self = Selection::PreCheck { group, effective_samples };
                return Next::Stay;
            }
            group += 1;
        }
        drop_unpaid_groups(state);
        if PHASE_MOVES.iter().any(|&mv| phase_moved(state.best(), mv).is_some()) {
            *self = Selection::PhaseMove { next: 0, origin: *state.best() };
            Next::Stay
        } else {
            Next::Polish(state.global_reason())
        }
    }

    /// One step of the phase moves ([`Selection::PhaseMove`]): at most one evaluation, so the
    /// moves spend at most 1 + [`PHASE_MOVES`]`.len()` = 7 evaluations, from the budget of
    /// selection and the polish. A move is kept only when `E` falls: no threshold, and the
    /// number of parameters does not change (a merge of two shorts removes one). The group a
    /// short moves to is kept, so the polish refines it.
    fn phase_move_step<const W: usize>(
        &mut self,
        state: State<'_, '_, W>,
        next: usize,
        mut origin: [f32; FAULT_COUNT],
    ) -> Next {
        if state.budget_left() == 0 {
            return Next::Polish(state.global_reason());
        }
        if state.best_cost().is_nan() {
            state.rescore(Account::Later);
            return Next::Stay;
        }
        let mut index = next;
        while let Some(&mv) = PHASE_MOVES.get(index) {
            if index.is_multiple_of(2) {
                origin = *state.best(); // the first move of a phase
            }
            index += 1;
            let Some(x) = phase_moved(&origin, mv) else { continue };
            let best_cost = state.best_cost();
            let cost = state.evaluate(Account::Later, |fit| fit.error_abandoning(&FaultVector(x), best_cost));
            if cost < best_cost {
                state.set_best(x, cost);
                if let Some(to) = FaultParam::ALL.get(mv.1) {
                    state.keep(to.group(), true);
                }
            }
            *self = Selection::PhaseMove { next: index, origin };
            return Next::Stay;
        }
        Next::Polish(state.global_reason())
    }
}

/// Decides on `group` once its refit `x` (cost `without`) is done: a smaller model that fits
/// better becomes the one to beat; otherwise the information criterion decides, and a group
/// that pays gets its window check when two evaluations are left for it (without them, the
/// plain test stands). Returns the window check to run, if any.
fn judge_refit<const W: usize>(
    state: State<'_, '_, W>,
    group: FaultGroup,
    effective_samples: f32,
    x: [f32; FAULT_COUNT],
    without: f32,
) -> Option<WindowCheck> {
    if without < state.best_cost() {
        state.set_best(x, without);
        state.keep(group, false);
        return None;
    }
    let kept = group_pays(state.best_cost(), without, group_size(group), effective_samples);
    state.keep(group, kept);
    (kept && state.budget_left() >= 2).then_some(WindowCheck::With { without: x })
}

/// Sets every group model selection refused back to healthy; the cost is re-evaluated by the
/// polish (or by a rescore when there is none).
fn drop_unpaid_groups<const W: usize>(state: State<'_, '_, W>) {
    for group in FaultGroup::ALL {
        if !state.kept(group) && group_present(state.best(), group) {
            state.drop_group(group);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fitness::MAX_EVIDENCE_WINDOWS;

    #[test]
    fn group_helpers_follow_the_groups() {
        let k = [0.2, 0.0, 0.0, 0.3, 0.0, 0.0, 0.9, 0.5]; // friction, short B, a phase without eccentricity
        let present = FaultGroup::ALL.map(|g| group_present(&k, g));
        assert_eq!(present, [true, false, false, true, false, false, false]);
        assert_eq!(without_group(&k, FaultGroup::ShortB), [0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.9, 0.5]);
        assert_eq!(without_group(&k, FaultGroup::Eccentricity), [0.2, 0.0, 0.0, 0.3, 0.0, 0.0, 0.5, 0.5]);
        assert_eq!(FaultGroup::ALL.map(group_size), [1, 1, 1, 1, 1, 2, 1]);
    }

    #[test]
    fn a_gain_from_one_window_alone_does_not_help() {
        let windows = |e: &[f32]| {
            let mut w = WindowErrors { errors: [0.0; MAX_EVIDENCE_WINDOWS], window_samples: 100, samples: 2125 };
            w.errors[..e.len()].copy_from_slice(e);
            w
        };
        let with = windows(&[1.0, 1.0, 1.0, 1.0]);
        // all the gain in window 2, a little loss elsewhere: local
        assert!(!helps_without_its_best_window(&with, &windows(&[0.99, 1.0, 1.5, 0.995]), 0.0));
        // the same window, the rest gaining a little (2 % of it): enough against a refit that
        // replaced the group, local when the refit brought in nothing
        assert!(helps_without_its_best_window(&with, &windows(&[1.01, 1.0, 1.5, 1.0]), 0.0));
        assert!(!helps_without_its_best_window(&with, &windows(&[1.01, 1.0, 1.5, 1.0]), WINDOW_GAIN_SHARE));
        // the rest gaining more than a quarter of it
        assert!(helps_without_its_best_window(&with, &windows(&[1.1, 1.0, 1.5, 1.05]), WINDOW_GAIN_SHARE));
        // spread gains
        assert!(helps_without_its_best_window(&with, &windows(&[1.1, 1.2, 1.1, 1.05]), WINDOW_GAIN_SHARE));
        // no gain anywhere
        assert!(!helps_without_its_best_window(&with, &with, 0.0));
        // a refit that moves another group by more than a step replaced the tested one
        let (a_and_c, c) = ([0.0, 0.0, 0.06, 0.0, 0.05, 0.0, 0.5, 0.5], [0.0, 0.0, 0.0, 0.0, 0.11, 0.0, 0.5, 0.5]);
        assert!(refit_replaces(&a_and_c, &c, FaultGroup::ShortA));
        // an eccentricity dropped, friction and gain moving by specks: nothing took its place
        let ecc = [0.0006, 0.0, 0.0, 0.0, 0.0, 0.18, 0.18, 0.498];
        assert!(!refit_replaces(&ecc, &[0.002, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5], FaultGroup::Eccentricity));
    }

    #[test]
    fn the_information_criterion_prices_parameters() {
        // n = 2000: one parameter must lower E by more than ln(2000)/2000 = 0.38 %, two by 0.76 %.
        assert!(group_pays(1.0, 1.005, 1, 2000.0));
        assert!(!group_pays(1.0, 1.005, 2, 2000.0));
        assert!(!group_pays(1.0, 1.001, 1, 2000.0));
        assert!(!group_pays(1.0, 0.99, 1, 2000.0), "a group that makes E worse never pays");
        assert!(group_pays(0.0, 1e-9, 1, 2000.0), "an exact fit keeps what it needs");
        assert!(!group_pays(1.0, f32::NAN, 1, 2000.0));
    }

    #[test]
    fn a_phase_move_carries_the_severity_and_merges_a_split_short() {
        let k = [0.2, 0.0, 0.0, 0.3, 0.0, 0.0, 0.5, 0.5]; // friction, short B
        assert_eq!(phase_moved(&k, (3, 2)), Some([0.2, 0.0, 0.3, 0.0, 0.0, 0.0, 0.5, 0.5]));
        assert_eq!(phase_moved(&k, (3, 4)), Some([0.2, 0.0, 0.0, 0.0, 0.3, 0.0, 0.5, 0.5]));
        assert_eq!(phase_moved(&k, (2, 3)), None, "no short on A to move");
        let split = [0.0, 0.0, 0.6, 0.0, 0.7, 0.0, 0.5, 0.5];
        assert_eq!(phase_moved(&split, (2, 4)), Some([0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.5, 0.5]), "capped");
        assert_eq!(phase_moved(&split, (3, 3)), None);
        assert_eq!(phase_moved(&split, (4, 9)), None);
        assert!(PHASE_MOVES.iter().all(|&(from, to)| from != to && (2..=4).contains(&from) && (2..=4).contains(&to)));
        // the two moves of a phase side by side, starting at an even index
        assert!(PHASE_MOVES.chunks(2).all(|pair| pair[0].0 == pair[1].0));
    }
}
