//! Real-coded genetic algorithm, step-wise and allocation-free (the paper's comparison optimizer).
//!
//! # Variant
//!
//! A generational GA on real vectors as in K. Deb's NSGA-II reference code (K. Deb, A. Pratap, S. Agarwal and
//! T. Meyarivan, IEEE TEC 6(2), 2002; operators from K. Deb and R. B. Agrawal, "Simulated binary crossover for
//! continuous search space", Complex Systems 9, 1995, and K. Deb and M. Goyal, "A combined genetic adaptive search
//! (GeneAS)", Computer Science and Informatics 26(4), 1996), single-objective:
//!
//! - **selection**: binary tournament (two uniform picks with replacement, the lower cost wins, ties to the first);
//! - **crossover**: with probability `p_c = 0.9` per pair, bounded SBX with `η_c = 15`: each parameter takes part
//!   with probability ½, its spread factor is drawn from the polynomial distribution truncated to the box (Deb's
//!   NSGA-II `realcross`), and the two children swap that parameter with probability ½; otherwise the children are
//!   copies of the parents;
//! - **mutation**: each parameter with probability `p_m = 1/D`, bounded polynomial mutation with `η_m = 20`
//!   (NSGA-II `real_mutate_ind`, the version whose perturbation shrinks near a bound);
//! - **elitism**: the best `elite_count = 2` individuals go into the next generation unchanged, with their costs
//!   (they are not re-evaluated: the objective is assumed deterministic); the other `P − 2` are children;
//! - **periodic parameters**: the second parent is first moved to the image nearest to the first
//!   ([`Interval::delta`](super::Interval::delta)), crossover and mutation use the unbounded formulas, then the
//!   child wraps ([`Interval::enforce`](super::Interval::enforce)); other parameters are clamped.
//! - **initialisation**: a Latin-hypercube sample ([`Rng::latin_hypercube`]); [`Genetic::with_initial_guesses`] may
//!   put known points in as the first individuals.
//!
//! # Generations, evaluations and termination
//!
//! Generation 1 evaluates all `P` initial individuals; every later generation evaluates its `P − elite_count`
//! children, one per [`Optimizer::step`]. With the defaults and `P = 50` the paper's 200 generations are
//! `50 + 199·48 = 9 602` evaluations. Termination is the shared MATLAB-style rule: target cost (after every
//! evaluation), relative change of the best cost over `stall_iterations` generations `<= function_tolerance`,
//! generation limit.
//!
//! # Early abandoning
//!
//! Not used: every child is evaluated with `abandon_above = ∞`. In a generational GA the exact cost of every child
//! decides tournaments and elites in the next generation, so no finite bound is sound without changing the
//! search (bounding by, say, the worst parent would tie all children above it and change which of them win their
//! tournaments).
//!
//! # Memory
//!
//! `size_of::<Genetic<P, D>>()` is `2·P·D·4` (two populations) `+ 2·P·4` (their costs) plus bounds, configuration,
//! a 65-entry stall history and counters:
//!
//! | type | thumbv7em-none-eabihf | x86_64 |
//! |---|---|---|
//! | `Genetic<50, 8>` | 4 060 B | 4 064 B |
//! | `Genetic<50, 2>` | 1 584 B | 1 592 B |
//!
//! (`memory_footprint` in the tests asserts `Genetic<50, 8>` ≤ 4 100 B.)
//!
//! NaN policy: a non-finite cost is treated as `+∞`; nothing in [`Optimizer::step`] can panic.

use super::rng::Rng;
use super::{Bounds, ConfigError, Objective, Optimizer, SearchState, SearchStatus, Stopping};

/// Settings of [`Genetic`]; `Default` is the variant of the module doc with the paper's stopping rule.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GaConfig {
    /// Generation limit (the first generation is the initial population). Default 200 (paper).
    pub max_iterations: u32,
    /// Relative change of the best cost over `stall_iterations` below which the GA stops. Default 1e-9 (paper).
    pub function_tolerance: f32,
    /// Stall window in generations, `1..=`[`MAX_STALL_ITERATIONS`](super::MAX_STALL_ITERATIONS). Default 20.
    pub stall_iterations: u32,
    /// Stop as soon as a cost `<=` this is found. Default `−∞` (disabled).
    pub target_cost: f32,
    /// Probability that a pair of parents is recombined, in `[0, 1]`. Default 0.9.
    pub crossover_probability: f32,
    /// SBX distribution index `η_c >= 0` (larger = children closer to their parents). Default 15.
    pub crossover_eta: f32,
    /// Probability that a parameter is mutated, in `[0, 1]`; `None` = `1/D`. Default `None`.
    pub mutation_probability: Option<f32>,
    /// Polynomial-mutation distribution index `η_m >= 0`. Default 20.
    pub mutation_eta: f32,
    /// Best individuals copied unchanged into the next generation, `< P`. Default 2.
    pub elite_count: u16,
}

impl Default for GaConfig {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            function_tolerance: 1e-9,
            stall_iterations: 20,
            target_cost: f32::NEG_INFINITY,
            crossover_probability: 0.9,
            crossover_eta: 15.0,
            mutation_probability: None,
            mutation_eta: 20.0,
            elite_count: 2,
        }
    }
}

impl GaConfig {
    /// Checks the operator settings (termination settings are checked by the shared stopping rule).
    fn validate_coefficients(&self, population: usize) -> Result<(), ConfigError> {
        let probability = |p: f32| (0.0..=1.0).contains(&p);
        let index = |eta: f32| eta.is_finite() && eta >= 0.0;
        let ok = probability(self.crossover_probability)
            && index(self.crossover_eta)
            && self.mutation_probability.is_none_or(probability)
            && index(self.mutation_eta)
            && usize::from(self.elite_count) < population;
        if ok {
            Ok(())
        } else {
            Err(ConfigError::Coefficient)
        }
    }
}

/// A population of `P` individuals over `D` parameters; all storage inline (see the module doc for the size).
#[derive(Clone, Debug)]
pub struct Genetic<const P: usize, const D: usize> {
    bounds: Bounds<D>,
    config: GaConfig,
    /// Best individual ever, counters, status and stopping rule.
    state: SearchState<D>,
    rng: Rng,
    /// Per-parameter mutation probability (`1/D` unless configured).
    mutation_probability: f32,
    /// The generation being evaluated.
    population: [[f32; D]; P],
    cost: [f32; P],
    /// The previous generation (the parents while breeding).
    parents: [[f32; D]; P],
    parent_cost: [f32; P],
    /// Next individual to evaluate.
    next: usize,
}

impl<const P: usize, const D: usize> Genetic<P, D> {
    /// A population initialised by a Latin-hypercube sample of `bounds` drawn from `seed`; refuses invalid bounds
    /// ([`ConfigError::Bounds`]), operator settings ([`ConfigError::Coefficient`]) and stopping settings
    /// ([`ConfigError::Termination`]). `P >= 4` and `D >= 1` are checked at compile time.
    pub fn new(bounds: Bounds<D>, config: GaConfig, seed: u64) -> Result<Self, ConfigError> {
        let stopping = Self::check(&bounds, &config)?;
        let mut optimizer = Self::unseeded(bounds, config, stopping);
        optimizer.seed(seed, &[]);
        Ok(optimizer)
    }

    /// The checks of [`Genetic::new`]: the stopping rule of `config`, or why `bounds` or `config`
    /// are refused.
    pub(crate) fn check(bounds: &Bounds<D>, config: &GaConfig) -> Result<Stopping, ConfigError> {
        const {
            assert!(P >= 4 && D >= 1, "a GA needs P >= 4 individuals and D >= 1 parameters");
            assert!(P <= u32::MAX as usize);
        }
        if !bounds.is_valid() {
            return Err(ConfigError::Bounds);
        }
        config.validate_coefficients(P)?;
        Stopping::new(config.max_iterations, config.stall_iterations, config.function_tolerance, config.target_cost)
    }

    /// A population of settings that [`Genetic::check`] accepted (`stopping` is its result),
    /// every individual at zero until [`Genetic::seed`] scatters them, built in place as
    /// [`super::ParticleSwarm::unseeded`] is.
    #[inline(always)]
    pub(crate) fn unseeded(bounds: Bounds<D>, config: GaConfig, stopping: Stopping) -> Self {
        Self {
            bounds,
            config,
            state: SearchState::new(bounds.centre(), stopping),
            rng: Rng::new(0),
            mutation_probability: config.mutation_probability.unwrap_or(1.0 / D as f32),
            population: const { [[0.0; D]; P] },
            cost: const { [0.0; P] },
            parents: const { [[0.0; D]; P] },
            parent_cost: const { [0.0; P] },
            next: 0,
        }
    }

    /// Scatters the individuals of an [`Genetic::unseeded`] population in place: a
    /// Latin-hypercube sample of the box drawn from `seed`, then the first ones replaced by
    /// `guesses` ([`Genetic::with_initial_guesses`]).
    pub(crate) fn seed(&mut self, seed: u64, guesses: &[[f32; D]]) {
        self.rng = Rng::new(seed);
        self.rng.latin_hypercube(&self.bounds, &mut self.population);
        self.parents = self.population;
        self.cost = [f32::INFINITY; P];
        self.parent_cost = [f32::INFINITY; P];
        super::place_guesses(&self.bounds, &mut self.population, guesses);
    }

    /// Replaces the first starting points by `guesses` (each brought into the box), e.g. one
    /// candidate per basin of a multi-modal search. Ignored once the first evaluation has been done.
    pub fn with_initial_guesses(mut self, guesses: &[[f32; D]]) -> Self {
        if self.state.evaluations() == 0 {
            super::place_guesses(&self.bounds, &mut self.population, guesses);
        }
        self
    }

    /// The configuration in use.
    pub fn config(&self) -> &GaConfig {
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

    /// Bookkeeping after the last evaluation of a generation: stopping rule, then breeding.
    fn end_generation(&mut self) {
        if self.state.end_iteration() {
            return;
        }
        core::mem::swap(&mut self.population, &mut self.parents);
        core::mem::swap(&mut self.cost, &mut self.parent_cost);
        let elites = usize::from(self.config.elite_count).min(P - 1);
        self.select_elites(elites);
        let mut k = elites;
        while k < P {
            let a = self.tournament();
            let b = self.tournament();
            let (Some(&pa), Some(&pb)) = (self.parents.get(a), self.parents.get(b)) else {
                break;
            };
            let (mut c1, mut c2) = (pa, pb);
            if self.rng.chance(self.config.crossover_probability) {
                self.crossover(&mut c1, &mut c2);
            }
            self.mutate(&mut c1);
            self.mutate(&mut c2);

            for child in [c1, c2] {
                if let (Some(slot), Some(c)) = (self.population.get_mut(k), self.cost.get_mut(k)) {
                    *slot = child;
                    *c = f32::INFINITY;
                }
                k += 1;
            }
        }
        self.next = elites;
    }

    /// Moves the `elites` best parents to the front (partial selection sort) and copies them with their costs.
    fn select_elites(&mut self, elites: usize) {
        for e in 0..elites.min(P) {
            let (mut best, mut best_cost) = (e, self.parent_cost[e]);
            for (j, &c) in self.parent_cost.iter().enumerate().skip(e + 1) {
                if c < best_cost {
                    (best, best_cost) = (j, c);
                }
            }
            let best = best.min(P - 1); // an index of `parent_cost` already: states it, changes nothing
            self.parent_cost.swap(e, best);
            self.parents.swap(e, best);
            self.population[e] = self.parents[e];
            self.cost[e] = self.parent_cost[e];
        }
    }

    /// Binary tournament among the parents.
    fn tournament(&mut self) -> usize {
        let a = self.rng.below(P as u32) as usize;
        let b = self.rng.below(P as u32) as usize;
        let cost = |i: usize| self.parent_cost.get(i).copied().unwrap_or(f32::INFINITY);
        if cost(b) < cost(a) {
            b
        } else {
            a
        }
    }

    /// Bounded simulated binary crossover (Deb's NSGA-II `realcross`), in place.
    fn crossover(&mut self, c1: &mut [f32; D], c2: &mut [f32; D]) {
        let eta = self.config.crossover_eta;
        let exponent = 1.0 / (eta + 1.0);
        for (d, interval) in (0..D).zip(self.bounds.intervals()) {
            if !self.rng.chance(0.5) {
                continue;
            }
            let (lo, hi) = (interval.lower, interval.upper);
            let periodic = interval.periodic;
            // Work on the nearest images for a periodic parameter.
            let (a, b) = (c1[d], c1[d] + interval.delta(c1[d], c2[d]));
            let (y1, y2) = if a <= b { (a, b) } else { (b, a) };
            let spread = y2 - y1;
            if spread <= 0.0 {
                continue;
            }
            let u = self.rng.next_f32();
            // βq from the polynomial density truncated so the child stays in [lo, hi]; β = ∞ (α = 2) when the
            // parameter is periodic (no bound to respect).
            let beta_q = |room: f32| {
                let alpha = if periodic { 2.0 } else { 2.0 - libm::powf(1.0 + 2.0 * room / spread, -(eta + 1.0)) };
                if u <= 1.0 / alpha {
                    libm::powf(u * alpha, exponent)
                } else {
                    // u·α < 2 because u < 1 and α <= 2: the base is finite and positive.
                    libm::powf(1.0 / (2.0 - u * alpha), exponent)
                }
            };
            let mut x1 = 0.5 * ((y1 + y2) - beta_q(y1 - lo) * spread);
            let mut x2 = 0.5 * ((y1 + y2) + beta_q(hi - y2) * spread);
            if !periodic {
                x1 = libm::fminf(libm::fmaxf(x1, lo), hi);
                x2 = libm::fminf(libm::fmaxf(x2, lo), hi);
            }
            if self.rng.chance(0.5) {
                core::mem::swap(&mut x1, &mut x2);
            }
            interval.enforce(&mut x1);
            interval.enforce(&mut x2);
            c1[d] = x1;
            c2[d] = x2;
        }
    }

    /// Bounded polynomial mutation (Deb's NSGA-II `real_mutate_ind`), in place.
    fn mutate(&mut self, x: &mut [f32; D]) {
        let eta = self.config.mutation_eta;
        let exponent = 1.0 / (eta + 1.0);
        for (xd, interval) in x.iter_mut().zip(self.bounds.intervals()) {
            if !self.rng.chance(self.mutation_probability) {
                continue;
            }
            let (lo, hi) = (interval.lower, interval.upper);
            let span = hi - lo;
            let y = *xd;
            let u = self.rng.next_f32();
            // `xy` = 1 − distance to the bound on the side we move towards, as a fraction of the range; 0 (no
            // bound, the unbounded polynomial distribution) for a periodic parameter.
            let delta_q = if u <= 0.5 {
                let xy = if interval.periodic { 0.0 } else { 1.0 - (y - lo) / span };
                let val = 2.0 * u + (1.0 - 2.0 * u) * libm::powf(xy, eta + 1.0);
                libm::powf(val, exponent) - 1.0
            } else {
                let xy = if interval.periodic { 0.0 } else { 1.0 - (hi - y) / span };
                let val = 2.0 * (1.0 - u) + 2.0 * (u - 0.5) * libm::powf(xy, eta + 1.0);
                1.0 - libm::powf(val, exponent)
            };
            let mut m = y + delta_q * span;
            interval.enforce(&mut m);
            *xd = m;
        }
    }
}

impl<const P: usize, const D: usize> Optimizer<D> for Genetic<P, D> {
    fn step<O: Objective<D>>(&mut self, objective: &mut O) -> SearchStatus {
        if !self.state.is_running() {
            return self.state.status();
        }
        let i = self.next;
        let Some(&x) = self.population.get(i) else {
            // Unreachable (`next < P` always); restart the sweep rather than panic.
            self.next = 0;
            return self.state.status();
        };
        let (cost, _) = self.state.record(&x, objective.cost(&x, f32::INFINITY));
        if let Some(c) = self.cost.get_mut(i) {
            *c = cost;
        }
        if !self.state.is_running() {
            return self.state.status();
        }
        self.next = i + 1;
        if self.next >= P {
            self.next = 0;
            self.end_generation();
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
    use crate::optimizer::tests::{symmetric, Abandoning, Rastrigin, Recorder, Rosenbrock, Sphere, SHIFT8};

    fn solve<const P: usize, const D: usize, O: Objective<D>>(
        bounds: Bounds<D>,
        config: GaConfig,
        seed: u64,
        objective: &mut O,
    ) -> Genetic<P, D> {
        let mut ga = Genetic::<P, D>::new(bounds, config, seed).unwrap();
        let status = run(&mut ga, objective, u32::MAX);
        assert!(matches!(status, SearchStatus::Done(_)));
        ga
    }

    // ---- known answers ----
    //
    // At the paper's budget (P = 50, ≤ 200 generations, stall 20 → ≤ 9 602 evaluations) this GA reliably finds the
    // right basin but converges slowly inside it: the stall rule usually stops it first. Seeds 0..100: Rastrigin
    // 2-D global basin 100/100 but cost < 1e-4 only 24/100 (≈ 3 800 evaluations); shifted sphere 8-D median
    // 1.6e-4, < 1e-4 in 30/100. With an extended budget (≤ 1 000 generations, stall window 64): Rastrigin 2-D
    // < 1e-4 in 89/100 (≈ 10 800 evaluations); sphere 8-D < 1e-4 in 100/100 and < 1e-6 in 71/100 (≈ 37 000
    // evaluations). The PSO needs ≈ 7 800 evaluations for < 1e-6 on every seed: the paper's finding that PSO
    // needs fewer evaluations than GA holds here too.

    /// The extended budget of the known-answer tests: ≤ 1 000 generations, stall window 64.
    fn extended() -> GaConfig {
        GaConfig { max_iterations: 1_000, stall_iterations: 64, ..GaConfig::default() }
    }

    #[test]
    fn sphere_8d_paper_budget() {
        let mut worst = 0.0f32;
        for seed in 0..20 {
            let ga = solve::<50, 8, _>(symmetric(5.0), GaConfig::default(), seed, &mut Sphere { shift: SHIFT8 });
            assert!(ga.evaluations() <= 9_602);
            worst = worst.max(ga.best().1);
        }
        std::println!("GA shifted sphere 8-D, paper budget: worst of 20 seeds {worst:e}");
        // These seeds give 4.9e-4 (the median over 100 seeds is 1.6e-4).
        assert!(worst < 2e-3, "{worst}");
    }

    #[test]
    fn sphere_8d_extended_budget() {
        for (seed, shift) in [(1, [0.0; 8]), (2, SHIFT8)] {
            let ga = solve::<50, 8, _>(symmetric(5.0), extended(), seed, &mut Sphere { shift });
            let (x, cost) = ga.best();
            std::println!("GA sphere 8-D, extended budget: {cost:e} after {} evaluations", ga.evaluations());
            assert!(cost < 1e-4, "cost {cost}");
            for (a, s) in x.iter().zip(shift.iter()) {
                assert!((a - s).abs() < 1e-2, "{x:?}");
            }
        }
    }

    #[test]
    fn rastrigin_2d_paper_budget_finds_the_global_basin() {
        for seed in 0..50 {
            let ga = solve::<50, 2, _>(symmetric(5.12), GaConfig::default(), seed, &mut Rastrigin);
            let (x, cost) = ga.best();
            assert!(cost < 0.5 && x.iter().all(|v| v.abs() < 0.05), "seed {seed}: {x:?} {cost}");
        }
    }

    #[test]
    fn rastrigin_2d_extended_budget() {
        let ga = solve::<50, 2, _>(symmetric(5.12), extended(), 3, &mut Rastrigin);
        let (x, cost) = ga.best();
        std::println!("GA Rastrigin 2-D, extended budget: {cost:e} after {} evaluations", ga.evaluations());
        assert!(cost < 1e-4 && x.iter().all(|v| v.abs() < 1e-3), "{x:?} {cost}");
        // Success rate: 89/100 in the sweep (44.5 ± 2.2 of 50); fewer than 38 is a regression.
        let mut hits = 0;
        for seed in 0..50 {
            let ga = solve::<50, 2, _>(symmetric(5.12), extended(), seed, &mut Rastrigin);
            hits += u32::from(ga.best().1 < 1e-4);
        }
        std::println!("GA Rastrigin 2-D global minimum, extended budget: {hits}/50");
        assert!(hits >= 38, "{hits}/50");
    }

    #[test]
    fn rosenbrock_2d() {
        let ga = solve::<50, 2, _>(symmetric(2.048), extended(), 4, &mut Rosenbrock);
        let (x, cost) = ga.best();
        std::println!("GA Rosenbrock 2-D, extended budget: {cost:e} {x:?} after {} evaluations", ga.evaluations());
        assert!(cost < 1e-4, "cost {cost}");
        assert!((x[0] - 1.0).abs() < 2e-2 && (x[1] - 1.0).abs() < 4e-2, "{x:?}");
    }

    #[test]
    fn crossover_meets_across_the_wrap_point() {
        // Parents on both sides of the wrap point: SBX on the nearest images keeps the children near the wrap
        // point, not in the middle of the circle.
        let bounds = Bounds { lower: [0.0], upper: [10.0], periodic: [true] };
        let config = GaConfig { crossover_eta: 2.0, ..GaConfig::default() };
        let mut ga = Genetic::<4, 1>::new(bounds, config, 21).unwrap();
        let mut far = 0;
        for _ in 0..1000 {
            let (mut a, mut b) = ([9.8], [0.2]);
            ga.crossover(&mut a, &mut b);
            for c in [a[0], b[0]] {
                assert!((0.0..10.0).contains(&c));
                if (2.0..8.0).contains(&c) {
                    far += 1;
                }
            }
        }
        // With η = 2 a child lands more than 4 parent-spreads away (β > 4.5) with probability ≈ 0.4 %.
        assert!(far < 30, "{far} of 2000 children in the middle");
    }

    #[test]
    fn invalid_configs_are_rejected() {
        let ok = GaConfig::default();
        let b = symmetric::<2>(1.0);
        let new = |b: Bounds<2>, c: GaConfig| Genetic::<4, 2>::new(b, c, 0).map(|_| ());
        assert_eq!(new(b, ok), Ok(()));
        assert_eq!(new(b, GaConfig { elite_count: 3, mutation_probability: Some(1.0), ..ok }), Ok(()));
        assert_eq!(new(b, GaConfig { elite_count: 0, crossover_probability: 0.0, ..ok }), Ok(()));
        let coefficient = [
            GaConfig { crossover_probability: -0.1, ..ok },
            GaConfig { crossover_probability: 1.1, ..ok },
            GaConfig { crossover_probability: f32::NAN, ..ok },
            GaConfig { crossover_eta: -1.0, ..ok },
            GaConfig { crossover_eta: f32::INFINITY, ..ok },
            GaConfig { mutation_probability: Some(f32::NAN), ..ok },
            GaConfig { mutation_probability: Some(-0.5), ..ok },
            GaConfig { mutation_eta: f32::NAN, ..ok },
            GaConfig { elite_count: 4, ..ok },
        ];
        for c in coefficient {
            assert_eq!(new(b, c), Err(ConfigError::Coefficient), "{c:?}");
        }
        let termination = [
            GaConfig { max_iterations: 0, ..ok },
            GaConfig { stall_iterations: 0, ..ok },
            GaConfig { function_tolerance: -1.0, ..ok },
            GaConfig { target_cost: f32::NAN, ..ok },
        ];
        for c in termination {
            assert_eq!(new(b, c), Err(ConfigError::Termination), "{c:?}");
        }
        let bad = Bounds { lower: [0.0, 1.0], upper: [1.0, 0.5], periodic: [false; 2] };
        assert_eq!(new(bad, ok), Err(ConfigError::Bounds));
    }

    #[test]
    fn never_offers_early_abandoning() {
        let bounds = symmetric::<8>(5.0);
        let mut f = Recorder::new(Abandoning { shift: SHIFT8, abandoned: 0, garbage: |_, _| f32::MAX }, &bounds);
        let mut ga = Genetic::<50, 8>::new(bounds, GaConfig::default(), 14).unwrap();
        run(&mut ga, &mut f, u32::MAX);
        assert_eq!(f.finite_abandon, 0);
        assert_eq!(f.inner.abandoned, 0);
        assert_eq!(f.calls, ga.evaluations());
    }

    #[test]
    fn elites_survive_and_are_not_re_evaluated() {
        let bounds = symmetric::<2>(5.12);
        let mut ga = Genetic::<10, 2>::new(bounds, GaConfig::default(), 15).unwrap();
        let mut previous_best = f32::INFINITY;
        for _ in 0..30 {
            run(&mut ga, &mut Rastrigin, 8);
            // The best never gets worse and the elite slots hold it at the start of each generation.
            assert!(ga.best().1 <= previous_best);
            previous_best = ga.best().1;
        }
        assert_eq!(ga.evaluations(), 240);
        assert_eq!(ga.iterations(), 1 + (240 - 10) / 8);
        assert_eq!(ga.cost[0], ga.best().1);
    }

    #[test]
    fn memory_footprint() {
        let size = core::mem::size_of::<Genetic<50, 8>>();
        std::println!("Genetic<50, 8> {size} B, <50, 2> {} B", core::mem::size_of::<Genetic<50, 2>>());
        // 2 · 50 · 8 · 4 + 2 · 50 · 4 = 3 600 bytes of population, the rest bookkeeping (see the module doc).
        assert!(size <= 4_100, "Genetic<50, 8> is {size} bytes");
    }
}
