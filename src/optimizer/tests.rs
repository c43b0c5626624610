//! The optimizer contract, checked against all four optimizers, and the test functions the
//! optimizers' own tests share.
//!
//! Every optimizer ([`ParticleSwarm`], [`Genetic`], [`DifferentialEvolution`], [`PatternSearch`])
//! must: do exactly one objective evaluation per [`Optimizer::step`] and none once done; count
//! its evaluations; never let its best worsen, and report an evaluated point with its cost;
//! evaluate only points inside the box (periodic parameters wrapped); stop on its budget, and
//! resume from a partial [`run`] exactly where one long run would be; give the same result for
//! the same seed; rank a non-finite cost worst without panicking; never offer an `abandon_above`
//! below its best, so that early abandoning changes nothing; stop on a flat function by the
//! tolerance; evaluate a given starting point first; refuse invalid bounds; and find the minimum
//! of a simple bowl and of a bowl across the wrap point of a periodic parameter.
//! [`contract_suite!`] instantiates each check for one optimizer through [`Subject`].

use super::de::{DeConfig, DifferentialEvolution};
use super::ga::{GaConfig, Genetic};
use super::pattern::{PatternConfig, PatternSearch};
use super::pso::{ParticleSwarm, PsoConfig};
use super::{run, Bounds, ConfigError, Objective, Optimizer, SearchStatus, TerminationReason};

// ---- test functions ----

/// `Σ (xᵢ − sᵢ)²`; minimum 0 at `shift`.
pub(crate) struct Sphere<const D: usize> {
    pub shift: [f32; D],
}

impl<const D: usize> Objective<D> for Sphere<D> {
    fn cost(&mut self, x: &[f32; D], _: f32) -> f32 {
        x.iter().zip(self.shift.iter()).map(|(a, s)| (a - s) * (a - s)).sum()
    }
}

/// Rastrigin `10·D + Σ (xᵢ² − 10 cos 2πxᵢ)` on `[−5.12, 5.12]^D`; global minimum 0 at the origin, a local
/// minimum near every integer point.
pub(crate) struct Rastrigin;

impl<const D: usize> Objective<D> for Rastrigin {
    fn cost(&mut self, x: &[f32; D], _: f32) -> f32 {
        x.iter().map(|&a| a * a - 10.0 * libm::cosf(core::f32::consts::TAU * a) + 10.0).sum()
    }
}

/// Rosenbrock `(1 − x)² + 100 (y − x²)²`; minimum 0 at (1, 1) at the end of a curved valley.
pub(crate) struct Rosenbrock;

impl Objective<2> for Rosenbrock {
    fn cost(&mut self, x: &[f32; 2], _: f32) -> f32 {
        let (a, b) = (1.0 - x[0], x[1] - x[0] * x[0]);
        a * a + 100.0 * b * b
    }
}

/// Wraps an objective: counts the calls, checks every evaluated point is inside the box and records how
/// often a finite `abandon_above` was passed.
pub(crate) struct Recorder<'a, O, const D: usize> {
    pub inner: O,
    pub bounds: &'a Bounds<D>,
    pub calls: u32,
    pub finite_abandon: u32,
    pub outside: u32,
}

impl<'a, O, const D: usize> Recorder<'a, O, D> {
    pub(crate) fn new(inner: O, bounds: &'a Bounds<D>) -> Self {
        Self { inner, bounds, calls: 0, finite_abandon: 0, outside: 0 }
    }
}

impl<O: Objective<D>, const D: usize> Objective<D> for Recorder<'_, O, D> {
    fn cost(&mut self, x: &[f32; D], abandon_above: f32) -> f32 {
        self.calls += 1;
        if abandon_above.is_finite() {
            self.finite_abandon += 1;
        }
        for (d, &xd) in x.iter().enumerate() {
            let (lo, hi) = (self.bounds.lower[d], self.bounds.upper[d]);
            let inside = xd >= lo && if self.bounds.periodic[d] { xd < hi } else { xd <= hi };
            if !inside {
                self.outside += 1;
            }
        }
        self.inner.cost(x, abandon_above)
    }
}

/// Shifted sphere computed term by term that gives up as soon as the partial sum exceeds `abandon_above`,
/// returning `garbage(partial, abandon_above)` (any value `> abandon_above` is allowed by the contract).
pub(crate) struct Abandoning<const D: usize> {
    pub shift: [f32; D],
    pub abandoned: u32,
    pub garbage: fn(f32, f32) -> f32,
}

impl<const D: usize> Objective<D> for Abandoning<D> {
    fn cost(&mut self, x: &[f32; D], abandon_above: f32) -> f32 {
        let mut sum = 0.0;
        for (a, s) in x.iter().zip(self.shift.iter()) {
            sum += (a - s) * (a - s);
            if sum > abandon_above {
                self.abandoned += 1;
                return (self.garbage)(sum, abandon_above);
            }
        }
        sum
    }
}

/// The box `[−half_width, half_width]^D`, nothing periodic.
pub(crate) fn symmetric<const D: usize>(half_width: f32) -> Bounds<D> {
    Bounds { lower: [-half_width; D], upper: [half_width; D], periodic: [false; D] }
}

/// A shift of the 8-D sphere away from the origin and the box's centre.
pub(crate) const SHIFT8: [f32; 8] = [1.5, -2.25, 3.0, 0.75, -4.0, 2.5, -0.5, 4.5];

/// Parameter 0 is an angle in `[0, 2π)` whose optimum, 0.05 rad before the wrap point, has its basin on both
/// ends of the range; parameter 1 is an ordinary bounded one (optimum 0.3).
pub(crate) struct AcrossWrap;

/// The optimum of [`AcrossWrap`]'s angle.
pub(crate) const WRAP_TARGET: f32 = core::f32::consts::TAU - 0.05;

impl Objective<2> for AcrossWrap {
    fn cost(&mut self, x: &[f32; 2], _: f32) -> f32 {
        // Circular distance to the target, then a parabola: the function is periodic in x[0].
        let mut d = libm::fmodf(libm::fabsf(x[0] - WRAP_TARGET), core::f32::consts::TAU);
        if d > core::f32::consts::PI {
            d = core::f32::consts::TAU - d;
        }
        d * d + (x[1] - 0.3) * (x[1] - 0.3)
    }
}

// ---- the optimizers under test ----

/// One optimizer as the contract suite builds it. `limit` is the optimizer's own budget: the
/// iteration (generation) limit of a population optimizer, five times that in evaluations for
/// the compass search.
pub(crate) trait Subject<const D: usize>: Optimizer<D> + Sized {
    /// Whether the seed changes the search (the compass search is deterministic from its start).
    const SEEDED: bool;
    /// An optimizer over `bounds`, or why the settings were refused.
    fn try_make(bounds: Bounds<D>, seed: u64, limit: u32) -> Result<Self, ConfigError>;
    /// Evaluations of a run that goes all the way to `limit`.
    fn budget(limit: u32) -> u32;
    /// The same with a target cost, when the optimizer has one.
    fn with_target(bounds: Bounds<D>, seed: u64, target: f32) -> Option<Self>;
    /// Puts `guess` in as the first point evaluated.
    fn with_guess(self, guess: [f32; D]) -> Self;
    /// SearchStatus after the last step.
    fn status(&self) -> SearchStatus;

    /// [`Subject::try_make`] for settings known to be valid.
    fn make(bounds: Bounds<D>, seed: u64, limit: u32) -> Self {
        Self::try_make(bounds, seed, limit).expect("valid test settings")
    }
}

impl<const P: usize, const D: usize> Subject<D> for ParticleSwarm<P, D> {
    const SEEDED: bool = true;
    fn try_make(bounds: Bounds<D>, seed: u64, limit: u32) -> Result<Self, ConfigError> {
        ParticleSwarm::new(bounds, PsoConfig { max_iterations: limit, ..PsoConfig::default() }, seed)
    }
    fn budget(limit: u32) -> u32 {
        P as u32 * limit
    }
    fn with_target(bounds: Bounds<D>, seed: u64, target: f32) -> Option<Self> {
        ParticleSwarm::new(bounds, PsoConfig { target_cost: target, ..PsoConfig::default() }, seed).ok()
    }
    fn with_guess(self, guess: [f32; D]) -> Self {
        self.with_initial_guesses(&[guess])
    }
    fn status(&self) -> SearchStatus {
        ParticleSwarm::status(self)
    }
}

impl<const P: usize, const D: usize> Subject<D> for Genetic<P, D> {
    const SEEDED: bool = true;
    fn try_make(bounds: Bounds<D>, seed: u64, limit: u32) -> Result<Self, ConfigError> {
        Genetic::new(bounds, GaConfig { max_iterations: limit, ..GaConfig::default() }, seed)
    }
    fn budget(limit: u32) -> u32 {
        // The first generation evaluates every individual, the later ones all but the 2 elites.
        P as u32 + (limit - 1) * (P as u32 - 2)
    }
    fn with_target(bounds: Bounds<D>, seed: u64, target: f32) -> Option<Self> {
        Genetic::new(bounds, GaConfig { target_cost: target, ..GaConfig::default() }, seed).ok()
    }
    fn with_guess(self, guess: [f32; D]) -> Self {
        self.with_initial_guesses(&[guess])
    }
    fn status(&self) -> SearchStatus {
        Genetic::status(self)
    }
}

impl<const P: usize, const D: usize> Subject<D> for DifferentialEvolution<P, D> {
    const SEEDED: bool = true;
    fn try_make(bounds: Bounds<D>, seed: u64, limit: u32) -> Result<Self, ConfigError> {
        DifferentialEvolution::new(bounds, DeConfig { max_iterations: limit, ..DeConfig::default() }, seed)
    }
    fn budget(limit: u32) -> u32 {
        P as u32 * limit
    }
    fn with_target(bounds: Bounds<D>, seed: u64, target: f32) -> Option<Self> {
        DifferentialEvolution::new(bounds, DeConfig { target_cost: target, ..DeConfig::default() }, seed).ok()
    }
    fn with_guess(self, guess: [f32; D]) -> Self {
        self.with_initial_guesses(&[guess])
    }
    fn status(&self) -> SearchStatus {
        DifferentialEvolution::status(self)
    }
}

impl<const D: usize> Subject<D> for PatternSearch<D> {
    const SEEDED: bool = false;
    fn try_make(bounds: Bounds<D>, _: u64, limit: u32) -> Result<Self, ConfigError> {
        // Steps from a tenth of the first parameter's range down to a millionth of it.
        let span = bounds.upper[0] - bounds.lower[0];
        let config = PatternConfig { initial_step: 0.1 * span, min_step: 1e-6 * span, max_evaluations: 5 * limit };
        PatternSearch::new(bounds, config, bounds.centre(), None, [true; D])
    }
    fn budget(limit: u32) -> u32 {
        5 * limit
    }
    fn with_target(_: Bounds<D>, _: u64, _: f32) -> Option<Self> {
        None
    }
    fn with_guess(self, guess: [f32; D]) -> Self {
        PatternSearch::new(*self.bounds(), *self.config(), guess, None, [true; D]).expect("valid test settings")
    }
    fn status(&self) -> SearchStatus {
        PatternSearch::status(self)
    }
}

// ---- the contract ----

/// One step, one evaluation, all counted; iterations never go back; once done, a step does nothing.
pub(crate) fn one_evaluation_per_step<S: Subject<3>>() {
    let bounds = symmetric::<3>(2.0);
    let mut f = Recorder::new(Sphere { shift: [0.5, -0.25, 1.0] }, &bounds);
    let mut s = S::make(bounds, 8, 30);
    let (mut steps, mut iterations) = (0, 0);
    while s.step(&mut f) == SearchStatus::Running {
        steps += 1;
        assert_eq!(f.calls, steps);
        assert_eq!(s.evaluations(), steps);
        assert!(s.iterations() >= iterations);
        iterations = s.iterations();
    }
    let done = f.calls;
    assert_eq!(done, s.evaluations());
    assert_eq!(S::status(&s), s.step(&mut f));
    assert_eq!((f.calls, s.evaluations()), (done, done));
}

/// The best cost is the lowest cost evaluated so far, and the best point is a point that cost it.
pub(crate) fn best_never_worsens<S: Subject<3>>() {
    struct Lowest {
        point: [f32; 3],
        cost: f32,
    }
    impl Objective<3> for Lowest {
        fn cost(&mut self, x: &[f32; 3], _: f32) -> f32 {
            let c = Rastrigin.cost(x, f32::INFINITY);
            if c < self.cost {
                (self.point, self.cost) = (*x, c);
            }
            c
        }
    }
    let mut f = Lowest { point: [0.0; 3], cost: f32::INFINITY };
    let mut s = S::make(symmetric(5.12), 3, 40);
    assert_eq!(s.best().1, f32::INFINITY, "nothing evaluated yet");
    let mut previous = f32::INFINITY;
    while s.step(&mut f) == SearchStatus::Running {
        let (x, cost) = s.best();
        assert!(cost <= previous, "{cost} > {previous}");
        previous = cost;
        assert_eq!((x.map(f32::to_bits), cost.to_bits()), (f.point.map(f32::to_bits), f.cost.to_bits()));
    }
}

/// Every evaluated point lies in the box (a periodic parameter in `[l, u)`), even with the optimum outside.
pub(crate) fn stays_in_the_box<S: Subject<5>>() {
    let bounds = Bounds {
        lower: [-1.0, 0.0, 2.0, -3.0, 0.0],
        upper: [1.0, 0.5, 2.001, 3.0, 1.0],
        periodic: [false, false, false, false, true],
    };
    let shift = [5.0, -5.0, 0.0, 10.0, 0.99];
    for seed in 0..10 {
        let mut f = Recorder::new(Sphere { shift }, &bounds);
        let mut s = S::make(bounds, seed, 40);
        run(&mut s, &mut f, u32::MAX);
        assert_eq!(f.outside, 0, "seed {seed}");
        assert_eq!(f.calls, s.evaluations());
        // The optimum lies outside: the best point is pressed against the walls.
        let (x, _) = s.best();
        assert!(x[0] > 0.99 && x[1] < 0.01 && x[3] > 2.99, "seed {seed}: {x:?}");
    }
}

/// A run stops on its limit with the whole budget spent; [`run`] stops on its evaluation budget, and
/// resuming in small budgets ends exactly where one long run does.
pub(crate) fn stops_on_its_budget<S: Subject<3>>() {
    let bounds = symmetric::<3>(5.0);
    let mut f = Sphere { shift: [1.5, -2.25, 3.0] };
    let mut whole = S::make(bounds, 10, 10);
    assert_eq!(run(&mut whole, &mut f, u32::MAX), SearchStatus::Done(TerminationReason::MaxIterations));
    assert_eq!(whole.evaluations(), S::budget(10));
    let mut parts = S::make(bounds, 10, 10);
    assert_eq!(run(&mut parts, &mut f, 37), SearchStatus::Running);
    assert_eq!(parts.evaluations(), 37);
    while run(&mut parts, &mut f, 13) == SearchStatus::Running {}
    assert_eq!(parts.best().0.map(f32::to_bits), whole.best().0.map(f32::to_bits));
    assert_eq!(parts.best().1.to_bits(), whole.best().1.to_bits());
    assert_eq!((parts.evaluations(), parts.iterations()), (whole.evaluations(), whole.iterations()));
}

/// The same seed gives the same search, bit for bit; another seed another one (seeded optimizers).
pub(crate) fn deterministic_for_a_seed<S: Subject<4>>() {
    let go = |seed, budget| {
        let mut s = S::make(symmetric(5.12), seed, 200);
        run(&mut s, &mut Rastrigin, budget);
        (s.best().0.map(f32::to_bits), s.best().1.to_bits(), s.evaluations(), s.iterations())
    };
    assert_eq!(go(11, u32::MAX), go(11, u32::MAX));
    assert_eq!(go(5, 777), go(5, 777));
    if S::SEEDED {
        assert_ne!(go(11, u32::MAX).0, go(12, u32::MAX).0);
        assert_ne!(go(5, 777).0, go(6, 777).0);
    }
}

/// A NaN or infinite cost ranks worst: the search goes on in the finite half, and an objective that is
/// never finite leaves an infinite best without a panic.
pub(crate) fn non_finite_costs_rank_worst<S: Subject<4>>() {
    struct HalfNan;
    impl Objective<4> for HalfNan {
        fn cost(&mut self, x: &[f32; 4], _: f32) -> f32 {
            if x[0] > 0.1 {
                return f32::NAN;
            }
            if x[0] < -1.9 {
                return f32::NEG_INFINITY;
            }
            let t = [-1.0, 0.5, 0.5, 0.5];
            x.iter().zip(t.iter()).map(|(a, b)| (a - b) * (a - b)).sum()
        }
    }
    let bounds = symmetric::<4>(2.0);
    let mut f = Recorder::new(HalfNan, &bounds);
    let mut s = S::make(bounds, 13, 200);
    run(&mut s, &mut f, u32::MAX);
    let (x, cost) = s.best();
    assert!(cost.is_finite() && cost < 1e-3, "{x:?} {cost}");
    assert!((x[0] + 1.0).abs() < 5e-2, "{x:?}");
    assert_eq!(f.outside, 0);
}

/// An objective that is never finite runs to the end and leaves an infinite best, without a panic.
pub(crate) fn never_finite_leaves_an_infinite_best<S: Subject<2>>() {
    struct AllNan;
    impl Objective<2> for AllNan {
        fn cost(&mut self, _: &[f32; 2], _: f32) -> f32 {
            f32::NAN
        }
    }
    let mut s = S::make(symmetric::<2>(1.0), 13, 20);
    assert!(matches!(run(&mut s, &mut AllNan, u32::MAX), SearchStatus::Done(_)));
    assert_eq!(s.best().1, f32::INFINITY);
}

/// `abandon_above` is never below the best cost, and any legal early-abandoned value leaves the search
/// unchanged, bit for bit.
pub(crate) fn early_abandoning_changes_nothing<S: Subject<8>>() {
    struct AtLeastBest {
        inner: Abandoning<8>,
        best: f32,
    }
    impl Objective<8> for AtLeastBest {
        fn cost(&mut self, x: &[f32; 8], abandon_above: f32) -> f32 {
            assert!(abandon_above >= self.best, "offered {abandon_above} below the best {}", self.best);
            self.inner.cost(x, abandon_above)
        }
    }
    let bounds = symmetric::<8>(5.0);
    let mut full = S::make(bounds, 14, 200);
    let full_status = run(&mut full, &mut Sphere { shift: SHIFT8 }, u32::MAX);
    let garbage: [fn(f32, f32) -> f32; 3] = [|partial, _| partial, |_, _| f32::MAX, |_, above| above * 2.0 + 1.0];
    for g in garbage {
        let mut f = AtLeastBest { inner: Abandoning { shift: SHIFT8, abandoned: 0, garbage: g }, best: f32::INFINITY };
        let mut s = S::make(bounds, 14, 200);
        let status = loop {
            f.best = s.best().1;
            let status = s.step(&mut f);
            if status != SearchStatus::Running {
                break status;
            }
        };
        assert_eq!(status, full_status);
        assert_eq!(s.best().0.map(f32::to_bits), full.best().0.map(f32::to_bits));
        assert_eq!(s.best().1.to_bits(), full.best().1.to_bits());
        assert_eq!((s.evaluations(), s.iterations()), (full.evaluations(), full.iterations()));
    }
}

/// A flat function stops the search by the tolerance (no improvement over the stall window, or the
/// compass step shrinking below its minimum), not by the limit; a target cost stops it at once.
pub(crate) fn stops_on_tolerance_and_target<S: Subject<3>>() {
    struct Flat;
    impl Objective<3> for Flat {
        fn cost(&mut self, _: &[f32; 3], _: f32) -> f32 {
            5.0
        }
    }
    let mut s = S::make(symmetric(1.0), 11, 1_000);
    assert_eq!(run(&mut s, &mut Flat, u32::MAX), SearchStatus::Done(TerminationReason::FunctionTolerance));
    assert_eq!(s.best().1, 5.0);
    assert!(s.evaluations() < S::budget(1_000));
    let Some(mut s) = S::with_target(symmetric(5.0), 12, 1e-2) else { return };
    let mut f = Sphere { shift: [1.5, -2.25, 3.0] };
    assert_eq!(run(&mut s, &mut f, u32::MAX), SearchStatus::Done(TerminationReason::TargetReached));
    let (x, cost) = s.best();
    assert!(cost <= 1e-2);
    assert_eq!(f.cost(x, f32::INFINITY), cost);
    let before = s.evaluations();
    s.step(&mut f);
    assert_eq!(s.evaluations(), before);
}

/// A given starting point is brought into the box (clamped, or wrapped when periodic) and evaluated first.
pub(crate) fn evaluates_a_given_start_first<S: Subject<3>>() {
    struct First(Option<[f32; 3]>);
    impl Objective<3> for First {
        fn cost(&mut self, x: &[f32; 3], _: f32) -> f32 {
            self.0.get_or_insert(*x);
            x.iter().map(|a| a * a).sum()
        }
    }
    let bounds = Bounds { lower: [-2.0; 3], upper: [2.0; 3], periodic: [false, false, true] };
    let mut f = First(None);
    let mut s = S::make(bounds, 15, 10).with_guess([0.25, 9.0, 2.5]); // clamped to 2, wrapped to −1.5
    s.step(&mut f);
    assert_eq!(f.0, Some([0.25, 2.0, -1.5]));
    assert_eq!(s.best(), (&[0.25, 2.0, -1.5], 0.0625 + 4.0 + 2.25));
}

/// Bounds that are not finite or not ordered are refused at construction.
pub(crate) fn refuses_invalid_bounds<S: Subject<2>>() {
    let bad = [
        Bounds { lower: [0.0, 1.0], upper: [1.0, 1.0], periodic: [false; 2] },
        Bounds { lower: [0.0, 2.0], upper: [1.0, 1.0], periodic: [false; 2] },
        Bounds { lower: [f32::NAN, 0.0], upper: [1.0, 1.0], periodic: [false; 2] },
        Bounds { lower: [f32::NEG_INFINITY, 0.0], upper: [1.0, 1.0], periodic: [false; 2] },
        Bounds { lower: [0.0, 0.0], upper: [1.0, f32::INFINITY], periodic: [true, false] },
    ];
    for b in bad {
        assert_eq!(S::try_make(b, 0, 10).err(), Some(ConfigError::Bounds), "{b:?}");
    }
    assert!(S::try_make(Bounds::unit(), 0, 10).is_ok());
}

/// The minimum of a shifted bowl.
pub(crate) fn finds_the_minimum_of_a_bowl<S: Subject<3>>() {
    let shift = [0.3, -0.6, 0.45];
    for seed in 0..3 {
        let mut s = S::make(symmetric(1.0), seed, 200);
        run(&mut s, &mut Sphere { shift }, u32::MAX);
        let (x, cost) = s.best();
        assert!(cost < 1e-5, "seed {seed}: cost {cost}");
        assert!(x.iter().zip(shift).all(|(a, b)| (a - b).abs() < 1e-2), "seed {seed}: {x:?}");
    }
}

/// The minimum of a bowl whose angle's optimum sits just before the wrap point while the search starts
/// just after it: the short way round crosses the wrap point.
pub(crate) fn finds_the_minimum_across_the_wrap_point<S: Subject<2>>() {
    let bounds = Bounds { lower: [0.0, -1.0], upper: [core::f32::consts::TAU, 1.0], periodic: [true, false] };
    for seed in 0..5 {
        let mut f = Recorder::new(AcrossWrap, &bounds);
        let mut s = S::make(bounds, seed, 200).with_guess([0.2, 0.0]);
        run(&mut s, &mut f, u32::MAX);
        let (x, cost) = s.best();
        assert!(cost < 1e-5, "seed {seed}: {x:?} {cost}");
        assert!((x[0] - WRAP_TARGET).abs() < 1e-2 && (x[1] - 0.3).abs() < 1e-2, "seed {seed}: {x:?}");
        assert_eq!(f.outside, 0);
    }
}

/// Instantiates every contract check for one optimizer, `$subject<D>` being its type in `D` dimensions.
macro_rules! contract_suite {
    ($name:ident, $subject:ident) => {
        mod $name {
            use super::$subject;

            #[test]
            fn one_evaluation_per_step() {
                super::one_evaluation_per_step::<$subject<3>>();
            }

            #[test]
            fn best_never_worsens() {
                super::best_never_worsens::<$subject<3>>();
            }

            #[test]
            fn stays_in_the_box() {
                super::stays_in_the_box::<$subject<5>>();
            }

            #[test]
            fn stops_on_its_budget() {
                super::stops_on_its_budget::<$subject<3>>();
            }

            #[test]
            fn deterministic_for_a_seed() {
                super::deterministic_for_a_seed::<$subject<4>>();
            }

            #[test]
            fn non_finite_costs_rank_worst() {
                super::non_finite_costs_rank_worst::<$subject<4>>();
                super::never_finite_leaves_an_infinite_best::<$subject<2>>();
            }

            #[test]
            fn early_abandoning_changes_nothing() {
                super::early_abandoning_changes_nothing::<$subject<8>>();
            }

            #[test]
            fn stops_on_tolerance_and_target() {
                super::stops_on_tolerance_and_target::<$subject<3>>();
            }

            #[test]
            fn evaluates_a_given_start_first() {
                super::evaluates_a_given_start_first::<$subject<3>>();
            }

            #[test]
            fn refuses_invalid_bounds() {
                super::refuses_invalid_bounds::<$subject<2>>();
            }

            #[test]
            fn finds_the_minimum_of_a_bowl() {
                super::finds_the_minimum_of_a_bowl::<$subject<3>>();
                super::finds_the_minimum_across_the_wrap_point::<$subject<2>>();
            }
        }
    };
}

/// The swarm under contract: 20 particles.
type Pso<const D: usize> = ParticleSwarm<20, D>;
/// The GA under contract: 20 individuals.
type Ga<const D: usize> = Genetic<20, D>;
/// DE under contract: 20 individuals.
type De<const D: usize> = DifferentialEvolution<20, D>;
/// The compass search under contract.
type Pattern<const D: usize> = PatternSearch<D>;

contract_suite!(pso, Pso);
contract_suite!(ga, Ga);
contract_suite!(de, De);
contract_suite!(pattern, Pattern);
