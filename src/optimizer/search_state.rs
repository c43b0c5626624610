//! The bookkeeping every optimizer shares: the best point and its cost, the evaluation and
//! iteration counters, the status and the stopping rule.
//!
//! An optimizer keeps its own algorithm state (a swarm, a population, a compass step) and one
//! [`SearchState`]. After each objective evaluation it calls [`SearchState::record`], which
//! counts the evaluation, treats a non-finite cost as `+∞`, keeps the strictly better point and
//! stops on the target cost; after each completed iteration a population optimizer calls
//! [`SearchState::end_iteration`], which applies the [`Stopping`] rule.

use super::{ConfigError, SearchStatus, TerminationReason};

/// Largest accepted stall window (`stall_iterations`); the window is a fixed ring of this many + 1 costs.
pub const MAX_STALL_ITERATIONS: u32 = 64;

/// What a stopping rule says after one evaluation: whether a cost reaches the target.
pub(crate) trait TargetRule {
    /// `true` when `cost` reaches the target (the search then stops at once).
    fn target_reached(&self, cost: f32) -> bool;
}

/// Termination rule of the population optimizers (MATLAB `particleswarm` / `ga` discipline): after each
/// completed iteration `k` with best cost `f_k`, stop when
/// 1. `f_k <= target_cost` ([`TerminationReason::TargetReached`]; also checked after every evaluation),
/// 2. `k > s` and `f_{k−s} − f_k <= tol · max(1, |f_k|)` with `s = stall_iterations`
///    ([`TerminationReason::FunctionTolerance`]; an infinite best never stalls since `∞ − ∞` is NaN),
/// 3. `k >= max_iterations` ([`TerminationReason::MaxIterations`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Stopping {
    max_iterations: u32,
    stall_iterations: u32,
    function_tolerance: f32,
    target_cost: f32,
    /// `history[k % len]` = best cost after iteration `k`.
    history: [f32; MAX_STALL_ITERATIONS as usize + 1],
}

impl Stopping {
    /// Validates the termination settings (see [`ConfigError::Termination`]).
    pub(crate) fn new(
        max_iterations: u32,
        stall_iterations: u32,
        function_tolerance: f32,
        target_cost: f32,
    ) -> Result<Self, ConfigError> {
        let tolerance_ok = function_tolerance.is_finite() && function_tolerance >= 0.0;
        let target_ok = !target_cost.is_nan() && target_cost != f32::INFINITY;
        if max_iterations == 0
            || stall_iterations == 0
            || stall_iterations > MAX_STALL_ITERATIONS
            || !tolerance_ok
            || !target_ok
        {
            return Err(ConfigError::Termination);
        }
        Ok(Self {
            max_iterations,
            stall_iterations,
            function_tolerance,
            target_cost,
            history: [f32::INFINITY; MAX_STALL_ITERATIONS as usize + 1],
        })
    }

    /// Records the best cost after completed iteration `k >= 1` and says whether to stop.
    pub(crate) fn after_iteration(&mut self, k: u32, best: f32) -> Option<TerminationReason> {
        const LEN: usize = MAX_STALL_ITERATIONS as usize + 1;
        if let Some(slot) = self.history.get_mut(k as usize % LEN) {
            *slot = best;
        }
        if self.target_reached(best) {
            return Some(TerminationReason::TargetReached);
        }
        if k > self.stall_iterations {
            let then = self.history.get((k - self.stall_iterations) as usize % LEN).copied().unwrap_or(f32::INFINITY);
            let scale = if libm::fabsf(best) > 1.0 { libm::fabsf(best) } else { 1.0 };
            // NaN (∞ − ∞) compares false: an all-infinite history never counts as stalled.
            if then - best <= self.function_tolerance * scale {
                return Some(TerminationReason::FunctionTolerance);
            }
        }
        if k >= self.max_iterations {
            return Some(TerminationReason::MaxIterations);
        }
        None
    }
}

impl TargetRule for Stopping {
    /// `true` when `cost <= target_cost` (never for the default `−∞` and a finite cost).
    fn target_reached(&self, cost: f32) -> bool {
        cost <= self.target_cost
    }
}

/// The rule of a search that ends on criteria of its own (the compass search: its step size and
/// its evaluation budget) and has no target cost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct NoTarget;

impl TargetRule for NoTarget {
    fn target_reached(&self, _: f32) -> bool {
        false
    }
}

/// Best point, counters, status and stopping rule of one search over `D` parameters.
#[derive(Clone, Debug)]
pub(crate) struct SearchState<const D: usize, R = Stopping> {
    best_position: [f32; D],
    best_cost: f32,
    evaluations: u32,
    iterations: u32,
    status: SearchStatus,
    rule: R,
}

impl<const D: usize, R: TargetRule> SearchState<D, R> {
    /// A search that has evaluated nothing: best cost `+∞` at `start` (the point [`Self::best`]
    /// reports until the first evaluation), running.
    ///
    /// Always inlined: an optimizer's `unseeded` constructor is then constants, copies and inlined
    /// code only, which the compiler writes straight into the solver that receives it. A call
    /// writing into the middle of it (this function not inlined) leads the compiler to build the
    /// whole optimizer in a temporary of the caller's frame and copy it: a second copy of the
    /// population on the stack (7.3 KB for the board's `Solver::start_pso` at `opt-level = "s"`).
    #[inline(always)]
    pub(crate) fn new(start: [f32; D], rule: R) -> Self {
        Self {
            best_position: start,
            best_cost: f32::INFINITY,
            evaluations: 0,
            iterations: 0,
            status: SearchStatus::Running,
            rule,
        }
    }

    /// A search whose best point `start` has the known cost `cost` (nothing counted).
    pub(crate) fn with_best(start: [f32; D], cost: f32, rule: R) -> Self {
        Self { best_cost: cost, ..Self::new(start, rule) }
    }

    /// Counts one evaluation of `x` with result `cost` and returns the cost as ranked (`+∞` when
    /// it is not finite) and whether it improved the best (strictly lower). An improvement that
    /// reaches the target finishes the search with [`TerminationReason::TargetReached`].
    pub(crate) fn record(&mut self, x: &[f32; D], cost: f32) -> (f32, bool) {
        let cost = if cost.is_finite() { cost } else { f32::INFINITY };
        self.evaluations = self.evaluations.saturating_add(1);
        let improved = cost < self.best_cost;
        if improved {
            self.best_cost = cost;
            self.best_position = *x;
            if self.rule.target_reached(cost) {
                self.status = SearchStatus::Done(TerminationReason::TargetReached);
            }
        }
        (cost, improved)
    }

    /// Counts one completed iteration (for the compass search: one step halving).
    pub(crate) fn count_iteration(&mut self) {
        self.iterations = self.iterations.saturating_add(1);
    }

    /// Finishes the search with `reason`.
    pub(crate) fn finish(&mut self, reason: TerminationReason) {
        self.status = SearchStatus::Done(reason);
    }

    /// `true` while the search has not finished.
    pub(crate) fn is_running(&self) -> bool {
        self.status == SearchStatus::Running
    }

    /// SearchStatus after the last evaluation or iteration.
    pub(crate) fn status(&self) -> SearchStatus {
        self.status
    }

    /// Best point found so far and its cost.
    pub(crate) fn best(&self) -> (&[f32; D], f32) {
        (&self.best_position, self.best_cost)
    }

    /// The best cost so far (`+∞` before the first evaluation).
    pub(crate) fn best_cost(&self) -> f32 {
        self.best_cost
    }

    /// Objective evaluations counted so far.
    pub(crate) fn evaluations(&self) -> u32 {
        self.evaluations
    }

    /// Completed iterations counted so far.
    pub(crate) fn iterations(&self) -> u32 {
        self.iterations
    }
}

impl<const D: usize> SearchState<D, Stopping> {
    /// Counts one completed iteration and applies the stopping rule to the best cost; returns
    /// `true` when the search finished.
    pub(crate) fn end_iteration(&mut self) -> bool {
        self.iterations = self.iterations.saturating_add(1);
        match self.rule.after_iteration(self.iterations, self.best_cost) {
            Some(reason) => {
                self.status = SearchStatus::Done(reason);
                true
            }
            None => false,
        }
    }
}
