//! The global search (PSO, GA or DE from [`starting_guesses`] and random points), the first
//! stage of a cold identification: its optimizer lives in place in the identification, beside
//! the stages, since its counters and its best stay in the report after it ends. At its end its
//! best vector goes on to model selection, the polish or the end, as the configuration asks.

use super::config::{fault_bounds, starting_guesses, Algorithm, IdentifyConfig};
use super::stage::Next;
use super::state::{Account, IdentificationState};
use super::MonitorError;
use crate::faults::{FaultGroup, FaultVector, FAULT_COUNT};
#[cfg(feature = "de")]
use crate::optimizer::de::{DeConfig, DifferentialEvolution};
#[cfg(feature = "ga")]
use crate::optimizer::ga::{GaConfig, Genetic};
use crate::optimizer::pso::{ParticleSwarm, PsoConfig};
#[cfg(not(all(feature = "ga", feature = "de")))]
use crate::optimizer::ConfigError;
use crate::optimizer::{Bounds, Optimizer, SearchStatus, Stopping, TerminationReason};

/// The global search's optimizer. Its state lives in place, in the identification (no heap on
/// board), so the plan's variant is as large as the swarm's by design.
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)]
pub(super) enum Solver<const P: usize> {
    /// Checked, not started: [`Solver::start`] builds it in place at the first step that needs
    /// it (never, for a warm start that does not fall back to the global search).
    Planned(SolverPlan),
    Pso(ParticleSwarm<P, FAULT_COUNT>),
    #[cfg(feature = "ga")]
    Ga(Genetic<P, FAULT_COUNT>),
    #[cfg(feature = "de")]
    De(DifferentialEvolution<P, FAULT_COUNT>),
}

/// The global search's settings as `config` chooses them, checked: what [`Solver::start`]
/// builds from, so that building cannot fail.
#[derive(Clone, Copy, Debug)]
pub(super) enum SolverPlan {
    Pso(PsoConfig, Stopping),
    #[cfg(feature = "ga")]
    Ga(GaConfig, Stopping),
    #[cfg(feature = "de")]
    De(DeConfig, Stopping),
}

impl SolverPlan {
    /// The optimizer `config` chooses, with its settings; refused as its `new` refuses them.
    pub(super) fn of<const P: usize>(
        bounds: &Bounds<FAULT_COUNT>,
        config: &IdentifyConfig,
    ) -> Result<Self, MonitorError> {
        let (max_iterations, function_tolerance, stall_iterations) =
            (config.max_iterations, config.function_tolerance, config.stall_iterations);
        Ok(match config.algorithm {
            Algorithm::Pso => {
                let c = PsoConfig { max_iterations, function_tolerance, stall_iterations, ..PsoConfig::default() };
                Self::Pso(c, ParticleSwarm::<P, FAULT_COUNT>::check(bounds, &c)?)
            }
            #[cfg(feature = "ga")]
            Algorithm::Ga => {
                let c = GaConfig { max_iterations, function_tolerance, stall_iterations, ..GaConfig::default() };
                Self::Ga(c, Genetic::<P, FAULT_COUNT>::check(bounds, &c)?)
            }
            #[cfg(feature = "de")]
            Algorithm::De => {
                let c = DeConfig { max_iterations, function_tolerance, stall_iterations, ..DeConfig::default() };
                Self::De(c, DifferentialEvolution::<P, FAULT_COUNT>::check(bounds, &c)?)
            }
            #[cfg(not(all(feature = "ga", feature = "de")))]
            _ => return Err(MonitorError::Optimizer(ConfigError::NotBuilt)),
        })
    }
}

impl<const P: usize> Solver<P> {
    /// The optimizer of a [`Solver::Planned`] solver, its population scattered from `seed` with
    /// [`starting_guesses`] first; a started one is left as it is. Built in place: each
    /// optimizer's `unseeded`, inlined into its `start_*` (one per optimizer, not inlined), is
    /// constants (the zero arrays, a fill), copies and inlined code with no call writing into
    /// it, so the compiler writes it straight into the identification rather than building it
    /// in a temporary of this frame and copying it; the identification itself is built without
    /// it, straight where its caller keeps it. The stack holds one copy of the population.
    fn start(&mut self, seed: u64) {
        let Solver::Planned(plan) = *self else { return };
        let bounds = fault_bounds();
        match plan {
            SolverPlan::Pso(c, stopping) => self.start_pso(bounds, c, stopping, seed),
            #[cfg(feature = "ga")]
            SolverPlan::Ga(c, stopping) => self.start_ga(bounds, c, stopping, seed),
            #[cfg(feature = "de")]
            SolverPlan::De(c, stopping) => self.start_de(bounds, c, stopping, seed),
        }
    }

    /// [`Solver::start`] for the particle swarm.
    #[inline(never)]
    fn start_pso(&mut self, bounds: Bounds<FAULT_COUNT>, c: PsoConfig, stopping: Stopping, seed: u64) {
        *self = Solver::Pso(ParticleSwarm::unseeded(bounds, c, stopping));
        if let Solver::Pso(s) = self {
            s.seed(seed, &starting_guesses());
        }
    }

    /// [`Solver::start`] for the genetic algorithm.
    #[cfg(feature = "ga")]
    #[inline(never)]
    fn start_ga(&mut self, bounds: Bounds<FAULT_COUNT>, c: GaConfig, stopping: Stopping, seed: u64) {
        *self = Solver::Ga(Genetic::unseeded(bounds, c, stopping));
        if let Solver::Ga(s) = self {
            s.seed(seed, &starting_guesses());
        }
    }

    /// [`Solver::start`] for differential evolution.
    #[cfg(feature = "de")]
    #[inline(never)]
    fn start_de(&mut self, bounds: Bounds<FAULT_COUNT>, c: DeConfig, stopping: Stopping, seed: u64) {
        *self = Solver::De(DifferentialEvolution::unseeded(bounds, c, stopping));
        if let Solver::De(s) = self {
            s.seed(seed, &starting_guesses());
        }
    }

    pub(super) fn best(&self) -> ([f32; FAULT_COUNT], f32) {
        match self {
            // what a started optimizer reports before its first evaluation
            Solver::Planned(_) => (fault_bounds().centre(), f32::INFINITY),
            Solver::Pso(s) => (*s.best().0, s.best().1),
            #[cfg(feature = "ga")]
            Solver::Ga(s) => (*s.best().0, s.best().1),
            #[cfg(feature = "de")]
            Solver::De(s) => (*s.best().0, s.best().1),
        }
    }

    pub(super) fn evaluations(&self) -> u32 {
        match self {
            Solver::Planned(_) => 0,
            Solver::Pso(s) => s.evaluations(),
            #[cfg(feature = "ga")]
            Solver::Ga(s) => s.evaluations(),
            #[cfg(feature = "de")]
            Solver::De(s) => s.evaluations(),
        }
    }

    pub(super) fn iterations(&self) -> u32 {
        match self {
            Solver::Planned(_) => 0,
            Solver::Pso(s) => s.iterations(),
            #[cfg(feature = "ga")]
            Solver::Ga(s) => s.iterations(),
            #[cfg(feature = "de")]
            Solver::De(s) => s.iterations(),
        }
    }
}

impl<const P: usize> Solver<P> {
    /// One step of the global search (one evaluation), the optimizer started at the first
    /// ([`Solver::start`]); at its end, its best goes on ([`after_global_search`]).
    pub(super) fn step<const W: usize>(&mut self, state: &mut IdentificationState<'_, W>) -> Next {
        self.start(state.config().seed);
        let status = match self {
            // not reached: started above
            Solver::Planned(_) => SearchStatus::Done(TerminationReason::MaxIterations),
            Solver::Pso(s) => state.step_optimizer(s),
            #[cfg(feature = "ga")]
            Solver::Ga(s) => state.step_optimizer(s),
            #[cfg(feature = "de")]
            Solver::De(s) => state.step_optimizer(s),
        };
        self.after_step(status, state)
    }

    /// The particles of the PSO still to be evaluated in its current sweep, each with the cost
    /// it must beat ([`ParticleSwarm::pending`]); none for another optimizer or before the
    /// swarm's first step.
    pub(super) fn pending(&self) -> impl Iterator<Item = (&[f32; FAULT_COUNT], f32)> {
        let swarm = match self {
            Solver::Pso(s) => Some(s.pending()),
            _ => None,
        };
        swarm.into_iter().flatten()
    }

    /// One step of the PSO with the cost of its next pending particle computed elsewhere;
    /// `None` (nothing done) for another optimizer or before the swarm's first step.
    pub(super) fn step_with_cost<const W: usize>(
        &mut self,
        cost: f32,
        state: &mut IdentificationState<'_, W>,
    ) -> Option<Next> {
        let Solver::Pso(swarm) = self else { return None };
        let status = swarm.step_with_cost(cost);
        Some(self.after_step(status, state))
    }

    /// After one step: once the search is done, its best moves on to the later stages.
    fn after_step<const W: usize>(&self, status: SearchStatus, state: &mut IdentificationState<'_, W>) -> Next {
        match status {
            SearchStatus::Done(reason) => {
                let (best, cost) = self.best();
                state.global_done(best, cost, reason);
                after_global_search(state, reason)
            }
            SearchStatus::Running => Next::Stay,
        }
    }

    /// Ends the global search at `k`, found by another optimizer, before it has stepped: one
    /// evaluation scores `k` (counted with selection and the polish), then the later stages run
    /// from it ([`after_global_search`]). `None` (nothing done) once the search has stepped.
    pub(super) fn skip<const W: usize>(&self, k: &FaultVector, state: &mut IdentificationState<'_, W>) -> Option<Next> {
        if self.evaluations() > 0 {
            return None;
        }
        let mut start = k.0;
        fault_bounds().enforce_point(&mut start);
        let cost = state.evaluate(Account::Later, |fit| fit.error(&FaultVector(start)));
        let reason = TerminationReason::MaxIterations;
        state.global_done(start, cost, reason);
        Some(after_global_search(state, reason))
    }
}

/// Where the identification goes from the global search's best: model selection, the polish,
/// or the end, as the configuration asks.
fn after_global_search<const W: usize>(state: &mut IdentificationState<'_, W>, reason: TerminationReason) -> Next {
    let model_selection = state.config().model_selection;
    if model_selection && state.budget_left() > 0 {
        Next::Select
    } else if model_selection {
        state.leave_untested_from(FaultGroup::Friction); // the first group: all of them
        Next::Polish(reason)
    } else if state.config().polish.is_some() {
        Next::Polish(reason)
    } else {
        Next::Done(reason) // the paper: the global search's best as is
    }
}
