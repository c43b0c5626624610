//! Memory-bounded, step-wise optimizers (contract first, algorithms in their own files).
//!
//! The contract follows argmin (`CostFunction` / `Solver::next_iter`) without an allocator:
//! - an [`Objective`] maps a candidate `x ∈ R^D` to a cost (lower is better);
//! - an optimizer owns all its storage, sized by const generics (`P` individuals × `D` parameters);
//! - [`Optimizer::step`] does at most ONE objective evaluation, so firmware can budget work per
//!   control cycle; [`run`] loops until termination or an evaluation budget.
//!
//! Invalid costs: a non-finite cost ranks worst (it is treated as `f32::INFINITY`), never a panic.

pub mod de;
pub mod ga;
pub mod pattern;
pub mod pso;
pub mod rng;

/// A function to minimise over `D` parameters.
pub trait Objective<const D: usize> {
    /// Cost of `x` (lower is better). `abandon_above` is the value the evaluation must beat to matter
    /// (`f32::INFINITY` when it must run to the end): an objective MAY stop early and return any value
    /// `> abandon_above` as soon as it knows its result will exceed it (early abandoning).
    fn cost(&mut self, x: &[f32; D], abandon_above: f32) -> f32;
}

/// Box bounds of the search space; a `periodic` parameter wraps around instead of being clamped.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Bounds<const D: usize> {
    /// Lower bound per parameter.
    pub lower: [f32; D],
    /// Upper bound per parameter (`> lower`).
    pub upper: [f32; D],
    /// Parameters that live on a circle (the eccentricity phase).
    pub periodic: [bool; D],
}

impl<const D: usize> Bounds<D> {
    /// The unit box `[0, 1]^D`, nothing periodic.
    pub const fn unit() -> Self {
        Self { lower: [0.0; D], upper: [1.0; D], periodic: [false; D] }
    }

    /// `true` when every bound is finite and `lower < upper`.
    pub fn is_valid(&self) -> bool {
        self.lower.iter().zip(self.upper.iter()).all(|(l, u)| l.is_finite() && u.is_finite() && l < u)
    }

    /// Signed difference `to − from` along parameter `i`; for a periodic parameter the shortest way round the
    /// circle, in `[−span/2, span/2]` (so a swarm or a crossover can meet across the wrap point).
    pub fn delta(&self, i: usize, from: f32, to: f32) -> f32 {
        let d = to - from;
        if self.periodic[i] {
            let span = self.upper[i] - self.lower[i];
            d - span * libm::roundf(d / span)
        } else {
            d
        }
    }

    /// Brings every coordinate of `x` into the box (see [`Bounds::enforce`]).
    pub fn enforce_point(&self, x: &mut [f32; D]) {
        for (i, xi) in x.iter_mut().enumerate() {
            self.enforce(i, xi);
        }
    }

    /// Brings `x[i]` back into the box: wraps periodic parameters, clamps the others.
    /// Returns `true` when the value was clamped (not wrapped), so the caller can damp its velocity.
    pub fn enforce(&self, i: usize, x: &mut f32) -> bool {
        let (lo, hi) = (self.lower[i], self.upper[i]);
        if !x.is_finite() {
            *x = 0.5 * (lo + hi);
            return true;
        }
        if self.periodic[i] {
            let span = hi - lo;
            let mut y = lo + libm::fmodf(*x - lo, span);
            if y < lo {
                y += span;
            }
            if y >= hi {
                y = lo;
            }
            *x = y;
            false
        } else if *x < lo {
            *x = lo;
            true
        } else if *x > hi {
            *x = hi;
            true
        } else {
            false
        }
    }
}

/// Puts `guesses` (each brought into `bounds`) in place of the first starting points: the
/// optimizers' `with_initial_guesses`. Extra guesses beyond the population are ignored.
pub(crate) fn place_guesses<const D: usize>(bounds: &Bounds<D>, points: &mut [[f32; D]], guesses: &[[f32; D]]) {
    for (point, guess) in points.iter_mut().zip(guesses) {
        *point = *guess;
        bounds.enforce_point(point);
    }
}

/// Why an optimizer stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum TerminationReason {
    /// The iteration (generation) limit was reached.
    MaxIterations,
    /// The best cost improved by less than the function tolerance over the stall window.
    FunctionTolerance,
    /// The best cost reached the target cost.
    TargetReached,
}

/// What one [`Optimizer::step`] left behind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    /// More work to do.
    Running,
    /// Finished; further steps do nothing.
    Done(TerminationReason),
}

/// Why a configuration was refused (checked once at construction; the hot loop has no checks).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConfigError {
    /// Bounds not finite or `lower >= upper`.
    Bounds,
    /// A coefficient is negative or not finite.
    Coefficient,
    /// Zero iterations, a stall window of zero or above [`MAX_STALL_ITERATIONS`], a negative or NaN tolerance,
    /// or a NaN / `+∞` target cost.
    Termination,
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ConfigError::Bounds => "bounds must be finite with lower < upper",
            ConfigError::Coefficient => "optimizer coefficients must be finite and non-negative",
            ConfigError::Termination => "iterations and stall window must be > 0 and the tolerance >= 0",
        })
    }
}

impl core::error::Error for ConfigError {}

/// Largest accepted stall window (`stall_iterations`); the window is a fixed ring of this many + 1 costs.
pub const MAX_STALL_ITERATIONS: u32 = 64;

/// Termination bookkeeping shared by the optimizers (MATLAB `particleswarm` / `ga` discipline): after each
/// completed iteration `k` with best cost `f_k`, stop when
/// 1. `f_k <= target_cost` ([`TerminationReason::TargetReached`]; the optimizers also check after every evaluation),
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

    /// `true` when `cost` reaches the target (never for the default `−∞`).
    pub(crate) fn target_reached(&self, cost: f32) -> bool {
        cost <= self.target_cost
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

/// Common step-wise interface of the population optimizers.
pub trait Optimizer<const D: usize> {
    /// Does at most one objective evaluation (plus the bookkeeping that follows it).
    fn step<O: Objective<D>>(&mut self, objective: &mut O) -> Status;
    /// Best point found so far and its cost (`f32::INFINITY` before the first evaluation).
    fn best(&self) -> (&[f32; D], f32);
    /// Objective evaluations done so far.
    fn evaluations(&self) -> u32;
    /// Completed iterations (generations).
    fn iterations(&self) -> u32;
}

/// Steps `optimizer` until it finishes or `max_evaluations` more evaluations are spent.
/// Returns the final status (`Running` when the budget ran out first).
pub fn run<const D: usize, S: Optimizer<D>, O: Objective<D>>(
    optimizer: &mut S,
    objective: &mut O,
    max_evaluations: u32,
) -> Status {
    let start = optimizer.evaluations();
    loop {
        let status = optimizer.step(objective);
        if let Status::Done(_) = status {
            return status;
        }
        if optimizer.evaluations().wrapping_sub(start) >= max_evaluations {
            return Status::Running;
        }
    }
}
