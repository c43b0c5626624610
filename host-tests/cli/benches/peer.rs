//! Peer comparison: our particle swarm and argmin's particle swarm on the SAME objective, from the SAME
//! starting points, followed by the SAME model selection and polish, at the SAME evaluation budget.
//!
//! `cd host-tests && cargo bench -p ema-cli --bench peer` (about 15 min on a 2-core x86_64 machine):
//!
//! 1. four reference-model recordings of the standard manoeuvre, noise on, noise seed 7 (healthy; friction
//!    k1 = 0.2; short circuit of phase B k4 = 0.2; gain k8 = 0.4), each conditioned as `ema identify` does
//!    ([`condition_recording`]);
//! 2. on each, one identification per method, budget and optimizer seed ([`OPTIMIZER_SEEDS`]), one after
//!    the other (wall times are per identification on one core), every method on the on-board fitness (fast
//!    regime weighted by `FAST_REGIME_WEIGHT`, [`objective`]):
//!    - **ours PSO**: the `no_std` core's swarm alone (`IdentifyConfig::paper()` with the on-board weight):
//!      50 particles, `max_iterations` 30 (on board) or 200, the paper's stall rule (relative 1e-9 over 20
//!      iterations, so a run may stop before the budget), the basin seeds ([`starting_guesses`]) as the first
//!      particles, early abandoning against each particle's best;
//!    - **argmin PSO as shipped**: `argmin::solver::particleswarm::ParticleSwarm` 0.11 with its defaults
//!      (SPSO 2011 coefficients, uniform random start in the box, clamping), 50 particles, `max_iters` 29 or
//!      199 (argmin's initial sweep is not an iteration: 50 + 29·50 = 1 500 and 50 + 199·50 = 10 000
//!      evaluations), seeded `Xoshiro256PlusPlus::seed_from_u64(seed)`; it calls [`EquivalentCurrentFit`] in `f64`
//!      through a thin adapter that rounds to `f32` and brings the point into our box ([`fault_bounds`]);
//!    - **argmin PSO, our objective and seeds**: the same argmin solver given our start (the basin seeds as
//!      its first particles) and our early-abandoning objective ([`ArgminFit`]);
//!    - **ours PSO + selection + polish**: the whole `Identification` (what `ema identify` runs);
//!    - **argmin + selection + polish**: the argmin swarm with our objective and seeds, then the core's model
//!      selection and polish started from its best vector ([`refine`]), the same stages ours runs after
//!      its swarm.
//! 3. a Markdown table: per method and budget, over the four recordings and the seeds, the mean and worst of
//!    the paper's Err% ([`FaultVector::paper_error_percent`]), the mean final fitness (A²), the mean wall time
//!    per identification and the mean evaluations actually used; then per recording the mean Err% and
//!    fitness, with the fitness of the injected vector itself (a method can end below it by fitting the model
//!    mismatch, so a lower fitness need not mean a lower Err%);
//! 4. criterion: one identification of each method at the small budget on the friction recording.
//!
//! `PEER_SKIP_CRITERION=1` skips step 4. `PEER_DE_SWEEP=1` instead compares DE variants on the same recordings
//! (optimizer seeds 1 and 2, both budgets, two threads): the measurement behind the default of
//! `ema_monitor::optimizer::de`. Run without `--bench` (`cargo test --release -p ema-cli --bench peer`, a suite
//! of `scripts/test-all`) it is a smoke test: one recording, 2 iterations, and checks of the evaluation counts.

use std::cell::{Cell, RefCell};
use std::path::Path;
use std::time::Instant;

use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::particleswarm::{Particle, ParticleSwarm as ArgminParticleSwarm};
use criterion::Criterion;
use ema_cli::identify::{condition_recording, identify_trace, HOST_WINDOW};
use ema_cli::recording::Recording;
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::{
    fault_bounds, starting_guesses, Algorithm, Identification, IdentifyConfig, ONBOARD_MAX_ITERATIONS,
    ONBOARD_POPULATION,
};
use ema_monitor::fitness::{EquivalentCurrentFit, FAST_REGIME_WEIGHT};
use ema_monitor::optimizer::de::{DeConfig, DifferentialEvolution, Strategy};
use ema_monitor::optimizer::{run, Optimizer};
use ema_monitor::{EmaParams, FaultVector, Profile, FAULT_COUNT};
use ema_reference::{simulate, SimConfig};
use rand_xoshiro::rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Noise seed of every recording.
const NOISE_SEED: u64 = 7;

/// Optimizer seeds: every method runs once per seed on every recording.
const OPTIMIZER_SEEDS: [u64; 3] = [1, 2, 3];

/// Iteration limits of our optimizers: × 50 individuals = 1 500 (on board) and 10 000 (the paper) evaluations.
const BUDGET_ITERATIONS: [u32; 2] = [ONBOARD_MAX_ITERATIONS, 200];

/// The recordings: name and injected fault vector.
fn cases() -> Vec<(&'static str, FaultVector)> {
    let with = |i: usize, k: f32| {
        let mut v = FaultVector::HEALTHY;
        v.0[i] = k;
        v
    };
    vec![
        ("healthy", FaultVector::HEALTHY),
        ("friction 0.2", with(0, 0.2)),
        ("short B 0.2", with(3, 0.2)),
        ("gain 0.4", with(7, 0.4)),
    ]
}

/// The reference model records the standard manoeuvre with faults `truth`; conditioned like `ema identify`.
fn record(name: &str, truth: FaultVector) -> Box<ConditionedWindow<HOST_WINDOW>> {
    let rec = simulate(&SimConfig { faults: truth, seed: NOISE_SEED, ..SimConfig::default() })
        .expect("the reference model simulates the standard manoeuvre");
    let recording = Recording::from_reference(&rec, Vec::new());
    condition_recording(&recording, Path::new(name), &EmaParams::NOMINAL, &Profile::STANDARD)
        .expect("a reference recording conditions")
}

/// One identification's outcome.
#[derive(Clone, Copy, Debug)]
struct Outcome {
    estimate: FaultVector,
    fitness: f64,
    seconds: f64,
    evaluations: u64,
}

/// Our optimizer through the core's `Identification` (what `ema identify --algorithm … --max-iterations …` runs).
/// `refine`: model selection and the polish after the global search (their evaluations come on top
/// of the budget); without it, the optimizer alone at exactly the budget.
fn ours(
    trace: &ConditionedWindow<HOST_WINDOW>,
    algorithm: Algorithm,
    max_iterations: u32,
    refine: bool,
    seed: u64,
) -> Outcome {
    let base = if refine {
        IdentifyConfig::default()
    } else {
        IdentifyConfig { fast_regime_weight: FAST_REGIME_WEIGHT, ..IdentifyConfig::paper() }
    };
    let config = IdentifyConfig { algorithm, seed, max_iterations, ..base };
    let out = identify_trace(trace, &EmaParams::NOMINAL, &Profile::STANDARD, &config, Path::new("peer bench"))
        .expect("the core accepts the paper's settings");
    Outcome {
        estimate: out.report.faults,
        fitness: f64::from(out.report.fitness),
        seconds: out.seconds,
        evaluations: u64::from(out.report.evaluations),
    }
}

/// The objective every method solves: the on-board fitness, [`EquivalentCurrentFit`] with the fast regime
/// weighted by [`FAST_REGIME_WEIGHT`] (`IdentifyConfig::default()`'s).
fn objective(trace: &ConditionedWindow<HOST_WINDOW>) -> EquivalentCurrentFit<'_, HOST_WINDOW> {
    EquivalentCurrentFit::new(trace, EmaParams::NOMINAL, &Profile::STANDARD)
        .expect("a conditioned trace is finished")
        .with_fast_regime_weight(FAST_REGIME_WEIGHT)
        .expect("the on-board weight is valid")
}

/// Brings an argmin point into our search box: `f32`, the eccentricity phase wrapped, the rest clamped.
fn to_fault_vector(p: &[f64]) -> FaultVector {
    let mut x = [0.0f32; FAULT_COUNT];
    for (xi, pi) in x.iter_mut().zip(p) {
        *xi = *pi as f32;
    }
    fault_bounds().enforce_point(&mut x);
    FaultVector(x)
}

/// [`EquivalentCurrentFit`] as an argmin cost function (`f64` in and out), counting its calls.
///
/// With `particle_best` it abandons early as our swarm does: argmin evaluates the swarm in a fixed
/// particle order after its initial sweep ([`argmin_pso`] hands it the evaluated initial swarm), so
/// call `i` belongs to particle `i mod P`, and a run is abandoned once its partial sum exceeds that
/// particle's best cost. The returned partial sum is then above the particle's best, so argmin keeps
/// the same personal and global bests as with the full cost.
struct ArgminFit<'a> {
    fit: EquivalentCurrentFit<'a, HOST_WINDOW>,
    calls: &'a Cell<u64>,
    particle_best: Option<RefCell<Vec<f32>>>,
}

impl CostFunction for ArgminFit<'_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, p: &Self::Param) -> Result<Self::Output, Error> {
        let call = self.calls.get();
        self.calls.set(call + 1);
        let k = to_fault_vector(p);
        let Some(best) = &self.particle_best else {
            return Ok(f64::from(self.fit.error(&k)));
        };
        let mut best = best.borrow_mut();
        let i = (call % best.len() as u64) as usize;
        let cost = self.fit.error_abandoning(&k, best[i]);
        best[i] = best[i].min(cost);
        Ok(f64::from(cost))
    }
}

/// The core's model selection and polish started from `k` (an outside optimizer's best), as
/// `ema identify` runs them after its own swarm ([`Identification::skip_global_search`]).
fn refine(trace: &ConditionedWindow<HOST_WINDOW>, k: FaultVector) -> Outcome {
    let start = Instant::now();
    let mut id: Box<Identification<'_, HOST_WINDOW, ONBOARD_POPULATION>> = Box::new(
        Identification::new(trace, EmaParams::NOMINAL, &Profile::STANDARD, &IdentifyConfig::default())
            .expect("the default settings are valid"),
    );
    id.skip_global_search(&k);
    id.run(u32::MAX);
    let report = id.report();
    Outcome {
        estimate: report.faults,
        fitness: f64::from(report.fitness),
        seconds: start.elapsed().as_secs_f64(),
        evaluations: u64::from(report.evaluations),
    }
}

/// How argmin's swarm is set up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ArgminSetup {
    /// As shipped: uniform random start, the full cost on every call.
    Shipped,
    /// Our objective and start: early abandoning against each particle's best, and our basin seeds
    /// ([`starting_guesses`]) as the first particles (the rest uniform random).
    Ours,
}

/// Uniform in `[lo, hi)` from the generator's top 53 bits.
fn uniform(rng: &mut Xoshiro256PlusPlus, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

/// argmin's particle swarm, `ONBOARD_POPULATION` particles, the same evaluation budget as `max_iterations` of ours
/// (argmin's initial sweep is not an iteration: it runs `max_iterations − 1` more).
fn argmin_pso(trace: &ConditionedWindow<HOST_WINDOW>, max_iterations: u32, setup: ArgminSetup, seed: u64) -> Outcome {
    let calls = Cell::new(0u64);
    let objective = objective(trace);
    let start = Instant::now();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let (particle_best, initial) = match setup {
        ArgminSetup::Shipped => (None, None),
        ArgminSetup::Ours => {
            // The initial swarm argmin would draw (positions in the box, velocities in ±its width),
            // with our basin seeds as the first particles, evaluated in full and sorted as argmin's
            // `init` sorts a provided swarm (a stable sort by cost), so particle i keeps index i.
            let guesses = starting_guesses();
            let mut swarm: Vec<Particle<Vec<f64>, f64>> = (0..ONBOARD_POPULATION)
                .map(|i| {
                    let position: Vec<f64> = match guesses.get(i) {
                        Some(g) => g.iter().map(|&x| f64::from(x)).collect(),
                        None => (0..FAULT_COUNT).map(|_| uniform(&mut rng, 0.0, 1.0)).collect(),
                    };
                    let velocity = (0..FAULT_COUNT).map(|_| uniform(&mut rng, -1.0, 1.0)).collect();
                    let cost = f64::from(objective.error(&to_fault_vector(&position)));
                    Particle::new(position, cost, velocity)
                })
                .collect();
            swarm.sort_by(|a, b| a.cost.partial_cmp(&b.cost).unwrap_or(std::cmp::Ordering::Equal));
            let best = swarm.iter().map(|p| p.cost as f32).collect();
            (Some(RefCell::new(best)), Some(swarm))
        }
    };
    let initial_evaluations = initial.as_ref().map_or(0, |s| s.len() as u64);
    let fit = ArgminFit { fit: objective, calls: &calls, particle_best };
    let solver = ArgminParticleSwarm::new((vec![0.0; FAULT_COUNT], vec![1.0; FAULT_COUNT]), ONBOARD_POPULATION)
        .with_rng_generator(rng);
    let result = Executor::new(fit, solver)
        .configure(|state| {
            let state = state.max_iters(u64::from(max_iterations.saturating_sub(1)));
            match initial {
                Some(swarm) => state.population(swarm),
                None => state,
            }
        })
        .run()
        .expect("argmin's particle swarm runs");
    let state = result.state();
    let best = state.get_best_param().expect("argmin keeps a best particle");
    Outcome {
        estimate: to_fault_vector(&best.position),
        fitness: state.get_best_cost(),
        seconds: start.elapsed().as_secs_f64(),
        evaluations: calls.get() + initial_evaluations,
    }
}

/// Our DE with an explicit configuration (for the variant sweep), set up as `Identification` does.
fn de_variant(trace: &ConditionedWindow<HOST_WINDOW>, config: DeConfig, seed: u64) -> Outcome {
    let mut fit = objective(trace);
    let start = Instant::now();
    let mut de = Box::new(
        DifferentialEvolution::<ONBOARD_POPULATION, FAULT_COUNT>::new(fault_bounds(), config, seed)
            .expect("valid DE settings")
            .with_initial_guesses(&[FaultVector::HEALTHY.0]),
    );
    run(de.as_mut(), &mut fit, u32::MAX);
    let (best, cost) = de.best();
    Outcome {
        estimate: FaultVector(*best),
        fitness: f64::from(cost),
        seconds: start.elapsed().as_secs_f64(),
        evaluations: u64::from(de.evaluations()),
    }
}

/// A method of the comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Method {
    OursPso,
    ArgminShipped,
    ArgminOurs,
    OursPipeline,
    ArgminPipeline,
}

impl Method {
    const ALL: [Method; 5] =
        [Method::OursPso, Method::ArgminShipped, Method::ArgminOurs, Method::OursPipeline, Method::ArgminPipeline];

    fn name(self) -> &'static str {
        match self {
            Method::OursPso => "ours PSO",
            Method::ArgminShipped => "argmin PSO as shipped",
            Method::ArgminOurs => "argmin PSO, our objective and seeds",
            Method::OursPipeline => "ours PSO + selection + polish",
            Method::ArgminPipeline => "argmin PSO (our objective, seeds) + selection + polish",
        }
    }

    fn solve(self, trace: &ConditionedWindow<HOST_WINDOW>, max_iterations: u32, seed: u64) -> Outcome {
        match self {
            Method::OursPso => ours(trace, Algorithm::Pso, max_iterations, false, seed),
            Method::ArgminShipped => argmin_pso(trace, max_iterations, ArgminSetup::Shipped, seed),
            Method::ArgminOurs => argmin_pso(trace, max_iterations, ArgminSetup::Ours, seed),
            Method::OursPipeline => ours(trace, Algorithm::Pso, max_iterations, true, seed),
            Method::ArgminPipeline => {
                let global = argmin_pso(trace, max_iterations, ArgminSetup::Ours, seed);
                let refined = refine(trace, global.estimate);
                Outcome {
                    seconds: global.seconds + refined.seconds,
                    evaluations: global.evaluations + refined.evaluations,
                    ..refined
                }
            }
        }
    }
}

fn mean(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        sum / n as f64
    }
}

/// A recording of the comparison: its name, the injected vector and the conditioned trace.
type Case = (&'static str, FaultVector, Box<ConditionedWindow<HOST_WINDOW>>);

/// The comparison table (and the per-recording Err%) for `budgets` on `recordings`, each method run once per
/// optimizer seed of [`OPTIMIZER_SEEDS`].
fn peer_table(recordings: &[Case], budgets: &[u32]) {
    // results[method][budget][recording][seed]
    let mut results: Vec<Vec<Vec<Vec<Outcome>>>> = Vec::new();
    for method in Method::ALL {
        let mut per_budget = Vec::new();
        for &iterations in budgets {
            let mut per_case = Vec::new();
            for (name, _, trace) in recordings {
                let mut per_seed = Vec::new();
                for seed in OPTIMIZER_SEEDS {
                    let o = method.solve(trace, iterations, seed);
                    eprintln!(
                        "{:<56} {:>6} evaluations  {:<13} seed {seed}  fitness {:.6} A², {:.2} s",
                        method.name(),
                        o.evaluations,
                        name,
                        o.fitness,
                        o.seconds
                    );
                    per_seed.push(o);
                }
                per_case.push(per_seed);
            }
            per_budget.push(per_case);
        }
        results.push(per_budget);
    }
    let err = |o: &Outcome, truth: &FaultVector| f64::from(o.estimate.paper_error_percent(truth));
    println!(
        "\n| method | budget (global search) | mean Err% | worst Err% | mean final fitness (A²) | mean time per identification (s) | mean evaluations used |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (b, &iterations) in budgets.iter().enumerate() {
        for (m, method) in Method::ALL.iter().enumerate() {
            let runs = || {
                results[m][b]
                    .iter()
                    .zip(recordings)
                    .flat_map(|(per_seed, (_, truth, _))| per_seed.iter().map(move |o| (o, truth)))
            };
            println!(
                "| {} | {} | {:.2} | {:.2} | {:.6} | {:.3} | {:.0} |",
                method.name(),
                iterations as usize * ONBOARD_POPULATION,
                mean(runs().map(|(o, t)| err(o, t))),
                runs().map(|(o, t)| err(o, t)).fold(0.0, f64::max),
                mean(runs().map(|(o, _)| o.fitness)),
                mean(runs().map(|(o, _)| o.seconds)),
                mean(runs().map(|(o, _)| o.evaluations as f64)),
            );
        }
    }
    let names: Vec<&str> = recordings.iter().map(|(n, _, _)| *n).collect();
    let per_recording = |title: &str, cell: &dyn Fn(&[Outcome], &FaultVector) -> String| {
        println!("\n{title}:\n\n| method | budget | {} |", names.join(" | "));
        println!("|---|---|{}", "---|".repeat(names.len()));
        for (b, &iterations) in budgets.iter().enumerate() {
            for (m, method) in Method::ALL.iter().enumerate() {
                let cells: Vec<String> =
                    results[m][b].iter().zip(recordings).map(|(runs, (_, truth, _))| cell(runs, truth)).collect();
                println!(
                    "| {} | {} | {} |",
                    method.name(),
                    iterations as usize * ONBOARD_POPULATION,
                    cells.join(" | ")
                );
            }
        }
    };
    per_recording("Mean Err% per recording over the seeds", &|runs, truth| {
        format!("{:.2}", mean(runs.iter().map(|o| err(o, truth))))
    });
    per_recording("Mean final fitness per recording over the seeds (A²)", &|runs, _| {
        format!("{:.6}", mean(runs.iter().map(|o| o.fitness)))
    });
    // The floor: the fitness of the injected vector itself. A method that ends below it has fitted the model
    // mismatch, and a lower fitness then need not mean a lower Err%.
    let at_truth: Vec<String> =
        recordings.iter().map(|(_, truth, trace)| format!("{:.6}", objective(trace).error(truth))).collect();
    println!("| fitness at the true vector | – | {} |", at_truth.join(" | "));
    println!(
        "\nRecordings: reference model, standard manoeuvre, noise seed {NOISE_SEED}; optimizer seeds {OPTIMIZER_SEEDS:?}; \
         {} individuals; one identification at a time.",
        ONBOARD_POPULATION
    );
}

/// DE variants on the same recordings (seeds 1 and 2, two worker threads): mean Err% and fitness per budget.
fn de_sweep(recordings: &[Case]) {
    let base = DeConfig::default();
    let variants = [
        DeConfig { strategy: Strategy::Rand1, differential_weight: 0.5, crossover_rate: 0.9, ..base },
        DeConfig { strategy: Strategy::Best1, differential_weight: 0.5, crossover_rate: 0.5, ..base },
        DeConfig { strategy: Strategy::Best1, differential_weight: 0.5, crossover_rate: 0.7, ..base },
        DeConfig { strategy: Strategy::CurrentToBest1, differential_weight: 0.5, crossover_rate: 0.5, ..base },
        DeConfig { strategy: Strategy::CurrentToBest1, differential_weight: 0.5, crossover_rate: 0.7, ..base },
    ];
    println!(
        "| DE variant | budget (evaluations) | mean Err% | worst Err% | mean final fitness (A²) | mean evaluations |"
    );
    println!("|---|---|---|---|---|---|");
    for iterations in BUDGET_ITERATIONS {
        for variant in variants {
            let config = DeConfig { max_iterations: iterations, ..variant };
            let jobs: Vec<(usize, u64)> = (0..recordings.len()).flat_map(|r| [(r, 1u64), (r, 2)]).collect();
            let next = std::sync::atomic::AtomicUsize::new(0);
            let outcomes = std::sync::Mutex::new(Vec::new());
            std::thread::scope(|s| {
                for _ in 0..2 {
                    s.spawn(|| loop {
                        let j = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(&(r, seed)) = jobs.get(j) else { break };
                        let o = de_variant(&recordings[r].2, config, seed);
                        let err = f64::from(o.estimate.paper_error_percent(&recordings[r].1));
                        outcomes.lock().expect("no worker panicked").push((err, o));
                    });
                }
            });
            let outcomes = outcomes.into_inner().expect("no worker panicked");
            println!(
                "| {:?} F={} CR={} | {} | {:.2} | {:.2} | {:.6} | {:.0} |",
                variant.strategy,
                variant.differential_weight,
                variant.crossover_rate,
                iterations as usize * ONBOARD_POPULATION,
                mean(outcomes.iter().map(|(e, _)| *e)),
                outcomes.iter().map(|(e, _)| *e).fold(0.0, f64::max),
                mean(outcomes.iter().map(|(_, o)| o.fitness)),
                mean(outcomes.iter().map(|(_, o)| o.evaluations as f64)),
            );
        }
    }
}

/// Criterion: one identification of each method at the small budget on the friction recording.
fn criterion_group(trace: &ConditionedWindow<HOST_WINDOW>) {
    let mut c = Criterion::default()
        .sample_size(10)
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(5))
        .configure_from_args();
    let mut group = c.benchmark_group("identification_1500_evaluations");
    for method in Method::ALL {
        group.bench_function(method.name(), |b| {
            b.iter(|| method.solve(std::hint::black_box(trace), ONBOARD_MAX_ITERATIONS, OPTIMIZER_SEEDS[0]))
        });
    }
    group.finish();
    c.final_summary();
}

fn main() {
    let bench_mode = std::env::args().any(|a| a == "--bench");
    let flag = |name: &str| std::env::var(name).is_ok_and(|v| v == "1");
    if !bench_mode {
        // Smoke test (`scripts/test-all`): the machinery works and the budgets are equal (selection and polish on top).
        let (name, truth) = cases()[1];
        let trace = record(name, truth);
        for method in Method::ALL {
            let o = method.solve(&trace, 2, OPTIMIZER_SEEDS[0]);
            let budget = 2 * ONBOARD_POPULATION as u64;
            if matches!(method, Method::OursPipeline | Method::ArgminPipeline) {
                // model selection and the polish spend their evaluations on top of the global search's
                assert!(o.evaluations > budget, "{}: {}", method.name(), o.evaluations);
            } else {
                assert_eq!(o.evaluations, budget, "{}", method.name());
            }
            assert!(o.fitness.is_finite() && o.fitness > 0.0, "{}: {}", method.name(), o.fitness);
            assert!(o.estimate.0.iter().all(|k| (0.0..=1.0).contains(k)), "{}", method.name());
        }
        println!(
            "peer-smoke: {} passed, 0 failed (run with `cargo bench -p ema-cli --bench peer` for the table)",
            Method::ALL.len()
        );
        return;
    }
    let start = Instant::now();
    let recordings: Vec<_> = cases().into_iter().map(|(name, truth)| (name, truth, record(name, truth))).collect();
    if flag("PEER_DE_SWEEP") {
        de_sweep(&recordings);
    } else {
        peer_table(&recordings, &BUDGET_ITERATIONS);
        if !flag("PEER_SKIP_CRITERION") {
            criterion_group(&recordings[1].2);
        }
    }
    eprintln!("peer bench: {:.0} s", start.elapsed().as_secs_f64());
}
