//! Compass (pattern) search: the local polish after a global search.
//!
//! From the start point `x` with cost `f(x)`, for each free parameter `i` in turn, try
//! `x ± h·e_i` (brought back into the [`Bounds`]); move to the first trial that lowers the cost and
//! keep trying the same direction; after a whole sweep without improvement halve `h`. Stop when
//! `h < min_step` ([`TerminationReason::FunctionTolerance`]) or after `max_evaluations`
//! ([`TerminationReason::MaxIterations`]). Derivative-free, monotone (the cost never rises), with
//! the convergence guarantee of generating-set search on smooth functions (Kolda, Lewis, Torczon,
//! "Optimization by direct search", SIAM Review 45(3), 2003). A trial only has to beat the current
//! cost, so it is evaluated with `abandon_above = f(x)` (early abandoning).
//!
//! Storage: two points of `D` parameters and a mask; one evaluation per [`Optimizer::step`].
//! [`Optimizer::iterations`] counts the step halvings.

use super::{Bounds, ConfigError, NoTarget, Objective, Optimizer, SearchState, SearchStatus, TerminationReason};

/// Settings of a [`PatternSearch`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PatternConfig {
    /// First step `h` along each parameter (in the parameters' own units).
    pub initial_step: f32,
    /// Stop once `h` falls below this.
    pub min_step: f32,
    /// Evaluation budget (the start point's own evaluation included).
    pub max_evaluations: u32,
}

impl Default for PatternConfig {
    /// Steps from 0.02 down to 2e-4 of the unit box, at most 600 evaluations.
    fn default() -> Self {
        Self { initial_step: 0.02, min_step: 2.0e-4, max_evaluations: 600 }
    }
}

/// Compass search over the free parameters of a `D`-dimensional box.
#[derive(Clone, Debug)]
pub struct PatternSearch<const D: usize> {
    bounds: Bounds<D>,
    config: PatternConfig,
    free: [bool; D],
    /// The current point (the best so far), counters and status; iterations count step halvings.
    state: SearchState<D, NoTarget>,
    /// The start point still waits for its evaluation.
    start_pending: bool,
    step_size: f32,
    /// Parameter tried next, and the direction (+1 or −1).
    coordinate: usize,
    direction: f32,
    improved_this_sweep: bool,
}

impl<const D: usize> PatternSearch<D> {
    /// A search from `start` (brought into `bounds`) moving only the parameters where `free` is
    /// `true`. With `start_cost = Some(f)` the start point is not evaluated again.
    pub fn new(
        bounds: Bounds<D>,
        config: PatternConfig,
        start: [f32; D],
        start_cost: Option<f32>,
        free: [bool; D],
    ) -> Result<Self, ConfigError> {
        if !bounds.is_valid() {
            return Err(ConfigError::Bounds);
        }
        let steps_ok = config.initial_step.is_finite()
            && config.min_step.is_finite()
            && config.min_step > 0.0
            && config.initial_step >= config.min_step;
        if !steps_ok {
            return Err(ConfigError::Coefficient);
        }
        if config.max_evaluations == 0 {
            return Err(ConfigError::Termination);
        }
        let mut best = start;
        bounds.enforce_point(&mut best);
        let mut state = match start_cost {
            Some(c) if c.is_nan() => SearchState::with_best(best, f32::INFINITY, NoTarget),
            Some(c) => SearchState::with_best(best, c, NoTarget),
            None => SearchState::new(best, NoTarget), // evaluated by the first step
        };
        // With nothing free there is nothing to search, but a start given without its cost is
        // still evaluated (model selection compares a lone fault group against that cost).
        if start_cost.is_some() && !free.iter().any(|f| *f) {
            state.finish(TerminationReason::FunctionTolerance);
        }
        Ok(Self {
            bounds,
            config,
            free,
            state,
            start_pending: start_cost.is_none(),
            step_size: config.initial_step,
            coordinate: 0,
            direction: 1.0,
            improved_this_sweep: false,
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &PatternConfig {
        &self.config
    }

    /// The search box.
    pub fn bounds(&self) -> &Bounds<D> {
        &self.bounds
    }

    /// SearchStatus after the last step.
    pub fn status(&self) -> SearchStatus {
        self.state.status()
    }

    /// The current step `h`.
    pub fn step_size(&self) -> f32 {
        self.step_size
    }

    /// Moves to the next (coordinate, direction); at the end of a sweep halves `h` if the sweep
    /// found nothing. Returns `false` when `h` fell below the minimum.
    fn advance(&mut self) -> bool {
        if self.direction > 0.0 {
            self.direction = -1.0;
            return true;
        }
        self.direction = 1.0;
        self.coordinate += 1;
        if self.coordinate >= D {
            self.coordinate = 0;
            if !self.improved_this_sweep {
                self.step_size *= 0.5;
                self.state.count_iteration();
                if self.step_size < self.config.min_step {
                    return false;
                }
            }
            self.improved_this_sweep = false;
        }
        true
    }

    /// The next trial point, skipping fixed parameters and trials the bounds fold back onto the
    /// current point; `None` when the search has converged.
    fn next_trial(&mut self) -> Option<[f32; D]> {
        // Each pass through the loop either returns or advances; 2·D + 2 advances cover a sweep.
        for _ in 0..(2 * D + 2) * 32 {
            let i = self.coordinate;
            if let (Some(true), Some(interval)) = (self.free.get(i).copied(), self.bounds.interval(i)) {
                let mut trial = *self.state.best().0;
                let mut v = trial[i] + self.direction * self.step_size;
                interval.enforce(&mut v);
                if v != trial[i] {
                    trial[i] = v;
                    return Some(trial);
                }
            }
            if !self.advance() {
                return None;
            }
        }
        None
    }
}

impl<const D: usize> Optimizer<D> for PatternSearch<D> {
    fn step<O: Objective<D>>(&mut self, objective: &mut O) -> SearchStatus {
        if !self.state.is_running() {
            return self.state.status();
        }
        if self.start_pending {
            self.start_pending = false;
            let start = *self.state.best().0;
            self.state.record(&start, objective.cost(&start, f32::INFINITY));
            if !self.free.iter().any(|f| *f) {
                self.state.finish(TerminationReason::FunctionTolerance);
                return self.state.status();
            }
        } else {
            let Some(trial) = self.next_trial() else {
                self.state.finish(TerminationReason::FunctionTolerance);
                return self.state.status();
            };
            let (_, improved) = self.state.record(&trial, objective.cost(&trial, self.state.best_cost()));
            if improved {
                self.improved_this_sweep = true; // same coordinate and direction next
            } else if !self.advance() {
                self.state.finish(TerminationReason::FunctionTolerance);
                return self.state.status();
            }
        }
        if self.state.evaluations() >= self.config.max_evaluations {
            self.state.finish(TerminationReason::MaxIterations);
        }
        self.state.status()
    }

    fn best(&self) -> (&[f32; D], f32) {
        self.state.best()
    }

    fn evaluations(&self) -> u32 {
        self.state.evaluations()
    }

    fn iterations(&self) -> u32 {
        self.state.iterations()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimizer::run;

    struct Quadratic {
        centre: [f32; 3],
        calls: u32,
    }

    impl Objective<3> for Quadratic {
        fn cost(&mut self, x: &[f32; 3], _abandon_above: f32) -> f32 {
            self.calls += 1;
            // anisotropic and coupled: 4(x0−c0)² + (x1−c1)² + (x0−c0)(x1−c1) + 9(x2−c2)²
            let d = [x[0] - self.centre[0], x[1] - self.centre[1], x[2] - self.centre[2]];
            4.0 * d[0] * d[0] + d[1] * d[1] + d[0] * d[1] + 9.0 * d[2] * d[2]
        }
    }

    fn config() -> PatternConfig {
        PatternConfig { initial_step: 0.05, min_step: 1e-4, max_evaluations: 2000 }
    }

    #[test]
    fn converges_to_the_minimum_of_a_coupled_quadratic() {
        let mut f = Quadratic { centre: [0.31, 0.77, 0.05], calls: 0 };
        let mut s = PatternSearch::new(Bounds::unit(), config(), [0.5; 3], None, [true; 3]).unwrap();
        let status = run(&mut s, &mut f, u32::MAX);
        assert_eq!(status, SearchStatus::Done(TerminationReason::FunctionTolerance));
        let (x, c) = s.best();
        for i in 0..3 {
            assert!((x[i] - f.centre[i]).abs() < 1e-3, "{x:?}");
        }
        assert!(c < 1e-5);
        assert_eq!(s.evaluations(), f.calls, "one evaluation per step, all counted");
        assert!(s.step_size() < 1e-4);
    }

    #[test]
    fn fixed_parameters_never_move_and_the_cost_never_rises() {
        struct Watch {
            inner: Quadratic,
            last_best: f32,
        }
        impl Objective<3> for Watch {
            fn cost(&mut self, x: &[f32; 3], abandon_above: f32) -> f32 {
                assert_eq!(x[1], 0.2, "a fixed parameter was moved");
                assert!(abandon_above <= self.last_best, "the bar to beat rose");
                self.last_best = abandon_above;
                self.inner.cost(x, abandon_above)
            }
        }
        let mut w = Watch { inner: Quadratic { centre: [0.6, 0.9, 0.4], calls: 0 }, last_best: f32::INFINITY };
        let mut s = PatternSearch::new(Bounds::unit(), config(), [0.5, 0.2, 0.5], None, [true, false, true]).unwrap();
        run(&mut s, &mut w, u32::MAX);
        let (x, _) = s.best();
        assert_eq!(x[1], 0.2);
        // With x1 held at 0.2 the best x0 moves to c0 − (x1 − c1)/8 = 0.6 + 0.7/8.
        assert!((x[0] - (0.6 + 0.7 / 8.0)).abs() < 1e-3, "{x:?}");
        assert!((x[2] - 0.4).abs() < 1e-3);
    }

    #[test]
    fn stays_in_the_box_and_wraps_periodic_parameters() {
        let mut bounds = Bounds::<3>::unit();
        bounds.periodic[2] = true;
        // minimum outside the box along x0 (clamped at 1), across the wrap point along x2
        let mut f = Quadratic { centre: [1.4, 0.5, 0.02], calls: 0 };
        let mut s = PatternSearch::new(bounds, config(), [0.5, 0.5, 0.9], None, [true; 3]).unwrap();
        run(&mut s, &mut f, u32::MAX);
        let (x, _) = s.best();
        assert_eq!(x[0], 1.0);
        assert!((0.0..1.0).contains(&x[2]));
        assert!((x[2] - 0.02).abs() < 1e-3, "{x:?}");
    }

    #[test]
    fn budget_and_refusals() {
        let mut f = Quadratic { centre: [0.3; 3], calls: 0 };
        let c = PatternConfig { max_evaluations: 7, ..config() };
        let mut s = PatternSearch::new(Bounds::unit(), c, [0.9; 3], Some(3.0), [true; 3]).unwrap();
        assert_eq!(run(&mut s, &mut f, u32::MAX), SearchStatus::Done(TerminationReason::MaxIterations));
        assert_eq!(f.calls, 7, "a given start cost is not evaluated again");
        let bad = PatternConfig { min_step: 0.0, ..config() };
        assert_eq!(
            PatternSearch::new(Bounds::<3>::unit(), bad, [0.5; 3], None, [true; 3]).err(),
            Some(ConfigError::Coefficient)
        );
        let bad = PatternConfig { initial_step: f32::NAN, ..config() };
        assert!(PatternSearch::new(Bounds::<3>::unit(), bad, [0.5; 3], None, [true; 3]).is_err());
        let bad = PatternConfig { max_evaluations: 0, ..config() };
        assert_eq!(
            PatternSearch::new(Bounds::<3>::unit(), bad, [0.5; 3], None, [true; 3]).err(),
            Some(ConfigError::Termination)
        );
        // nothing free: a start without its cost is evaluated once (model selection needs the cost
        // of a lone group's removal), one with its cost is done at once
        let calls = f.calls;
        let mut s = PatternSearch::new(Bounds::<3>::unit(), config(), [0.5; 3], None, [false; 3]).unwrap();
        assert_eq!(s.best().1, f32::INFINITY);
        assert!(matches!(s.step(&mut f), SearchStatus::Done(_)));
        assert_eq!((f.calls - calls, s.evaluations()), (1, 1));
        assert_eq!(s.best().0, &[0.5; 3]);
        assert!((s.best().1 - 0.6).abs() < 1e-6, "(4 + 1 + 1 + 9) · 0.2²: {}", s.best().1);
        let mut s = PatternSearch::new(Bounds::<3>::unit(), config(), [0.5; 3], Some(2.0), [false; 3]).unwrap();
        assert!(matches!(s.step(&mut f), SearchStatus::Done(_)));
        assert_eq!((f.calls - calls, s.evaluations(), s.best().1), (1, 0, 2.0));
    }
}
