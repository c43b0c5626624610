//! Peer comparison: our particle swarm, argmin's particle swarm and our differential evolution solve the SAME
//! objective at the SAME evaluation budget.
//!
//! `cd host-tests && cargo bench -p ema-cli --bench peer` (≈ 3–4 min on a 2-core x86_64 machine):
//!
//! 1. four reference-model recordings of the standard manoeuvre, noise on, noise seed 7 (healthy; friction
//!    k1 = 0.2; short circuit of phase B k4 = 0.2; gain k8 = 0.4), each conditioned as `ema identify` does
//!    ([`condition_recording`]);
//! 2. on each, one identification per method and budget, one after the other (wall times are per
//!    identification on one core), optimizer seed 1, every method on the on-board fitness (fast regime
//!    weighted by `FAST_REGIME_WEIGHT`, [`objective`]):
//!    - **ours PSO** and **ours DE**: the `no_std` core's [`Identification`] (`ema identify --algorithm pso|de`):
//!      50 individuals, `max_iterations` 30 (on board) or 200, the paper's stall rule (relative 1e-9 over 20 iterations,
//!      so a run may stop before the budget), the healthy vector as individual 0, early abandoning;
//!    - **argmin PSO**: `argmin::solver::particleswarm::ParticleSwarm` 0.11 with its defaults (SPSO 2011
//!      coefficients, uniform random start in the box, clamping), 50 particles, `max_iters` 29 or 199 (argmin's
//!      initial sweep is not an iteration: 50 + 29·50 = 1 500 and 50 + 199·50 = 10 000 evaluations),
//!      seeded `Xoshiro256PlusPlus::seed_from_u64(1)`; it calls [`CurrentFit`] in `f64` through a thin adapter
//!      that rounds to `f32` and brings the point into our box (the eccentricity phase k7 wraps, the rest is
//!      clamped, [`fault_bounds`]) and counts the calls;
//! 3. a Markdown table: per method and budget, the means over the four recordings of the paper's Err%
//!    ([`FaultVector::paper_error_percent`]), of the final fitness (A²), of the wall time per identification and
//!    of the evaluations actually used; then the Err% and final fitness of every recording, with the fitness of
//!    the injected vector itself (a method can end below it by fitting the model mismatch, so a lower fitness
//!    need not mean a lower Err%);
//! 4. criterion: one identification of each method at the small budget on the friction recording.
//!
//! `PEER_SKIP_CRITERION=1` skips step 4. `PEER_DE_SWEEP=1` instead compares DE variants on the same recordings
//! (optimizer seeds 1 and 2, both budgets, two threads): the measurement behind the default of
//! `ema_monitor::optimizer::de`. Run without `--bench` (`cargo test --release -p ema-cli --bench peer`, a suite of `scripts/test-all`) it is a smoke test:
//! one recording, 2 iterations, and checks of the evaluation counts.

use std::cell::Cell;
use std::path::Path;
use std::time::Instant;

use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::particleswarm::ParticleSwarm as ArgminParticleSwarm;
use criterion::Criterion;
use ema_cli::identify::{condition_recording, identify_trace, HOST_WINDOW};
use ema_cli::recording::Recording;
use ema_monitor::conditioning::MeasuredTrace;
use ema_monitor::fitness::{CurrentFit, FAST_REGIME_WEIGHT};
use ema_monitor::monitor::{fault_bounds, Algorithm, IdentifyConfig, ONBOARD_MAX_ITERATIONS, ONBOARD_POPULATION};
use ema_monitor::optimizer::de::{DeConfig, DifferentialEvolution, Strategy};
use ema_monitor::optimizer::{run, Optimizer};
use ema_monitor::{EmaParams, FaultVector, Profile, FAULT_COUNT};
use ema_reference::{simulate, SimConfig};
use rand_xoshiro::rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Noise seed of every recording.
const NOISE_SEED: u64 = 7;

/// Seed of every optimizer.
const OPTIMIZER_SEED: u64 = 1;

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
fn record(name: &str, truth: FaultVector) -> Box<MeasuredTrace<HOST_WINDOW>> {
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
fn ours(trace: &MeasuredTrace<HOST_WINDOW>, algorithm: Algorithm, max_iterations: u32, refine: bool) -> Outcome {
    let base = if refine {
        IdentifyConfig::default()
    } else {
        IdentifyConfig { fast_regime_weight: FAST_REGIME_WEIGHT, ..IdentifyConfig::paper() }
    };
    let config = IdentifyConfig { algorithm, seed: OPTIMIZER_SEED, max_iterations, ..base };
    let out = identify_trace(trace, &EmaParams::NOMINAL, &Profile::STANDARD, &config, Path::new("peer bench"))
        .expect("the core accepts the paper's settings");
    Outcome {
        estimate: out.report.faults,
        fitness: f64::from(out.report.fitness),
        seconds: out.seconds,
        evaluations: u64::from(out.report.evaluations),
    }
}

/// The objective every method solves: the on-board fitness, [`CurrentFit`] with the fast regime
/// weighted by [`FAST_REGIME_WEIGHT`] (`IdentifyConfig::default()`'s).
fn objective(trace: &MeasuredTrace<HOST_WINDOW>) -> CurrentFit<'_, HOST_WINDOW> {
    CurrentFit::new(trace, EmaParams::NOMINAL, Profile::STANDARD)
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

/// [`CurrentFit`] as an argmin cost function (`f64` in and out), counting its calls.
struct ArgminFit<'a> {
    fit: CurrentFit<'a, HOST_WINDOW>,
    calls: &'a Cell<u64>,
}

impl CostFunction for ArgminFit<'_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, p: &Self::Param) -> Result<Self::Output, Error> {
        self.calls.set(self.calls.get() + 1);
        Ok(f64::from(self.fit.error(&to_fault_vector(p))))
    }
}

/// argmin's particle swarm, `ONBOARD_POPULATION` particles, the same evaluation budget as `max_iterations` of ours.
fn argmin_pso(trace: &MeasuredTrace<HOST_WINDOW>, max_iterations: u32) -> Outcome {
    let calls = Cell::new(0u64);
    let fit = ArgminFit { fit: objective(trace), calls: &calls };
    let solver = ArgminParticleSwarm::new((vec![0.0; FAULT_COUNT], vec![1.0; FAULT_COUNT]), ONBOARD_POPULATION)
        .with_rng_generator(Xoshiro256PlusPlus::seed_from_u64(OPTIMIZER_SEED));
    let start = Instant::now();
    let result = Executor::new(fit, solver)
        .configure(|state| state.max_iters(u64::from(max_iterations.saturating_sub(1))))
        .run()
        .expect("argmin's particle swarm runs");
    let seconds = start.elapsed().as_secs_f64();
    let state = result.state();
    let best = state.get_best_param().expect("argmin keeps a best particle");
    Outcome {
        estimate: to_fault_vector(&best.position),
        fitness: state.get_best_cost(),
        seconds,
        evaluations: calls.get(),
    }
}

/// Our DE with an explicit configuration (for the variant sweep), set up as `Identification` does.
fn de_variant(trace: &MeasuredTrace<HOST_WINDOW>, config: DeConfig, seed: u64) -> Outcome {
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
    ArgminPso,
    OursDe,
    OursPsoRefined,
}

impl Method {
    const ALL: [Method; 4] = [Method::OursPso, Method::ArgminPso, Method::OursDe, Method::OursPsoRefined];

    fn name(self) -> &'static str {
        match self {
            Method::OursPso => "ours PSO (ring, early abandoning)",
            Method::ArgminPso => "argmin 0.11 ParticleSwarm",
            Method::OursDe => "ours DE",
            Method::OursPsoRefined => "ours PSO + model selection + polish (evaluations on top)",
        }
    }

    fn solve(self, trace: &MeasuredTrace<HOST_WINDOW>, max_iterations: u32) -> Outcome {
        match self {
            Method::OursPso => ours(trace, Algorithm::Pso, max_iterations, false),
            Method::ArgminPso => argmin_pso(trace, max_iterations),
            Method::OursDe => ours(trace, Algorithm::De, max_iterations, false),
            Method::OursPsoRefined => ours(trace, Algorithm::Pso, max_iterations, true),
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

/// The comparison table (and the per-recording Err%) for `budgets` on `recordings`.
fn peer_table(recordings: &[(&str, FaultVector, Box<MeasuredTrace<HOST_WINDOW>>)], budgets: &[u32]) {
    // results[method][budget][recording]
    let mut results: Vec<Vec<Vec<Outcome>>> = Vec::new();
    for method in Method::ALL {
        let mut per_budget = Vec::new();
        for &iterations in budgets {
            let mut per_case = Vec::new();
            for (name, _, trace) in recordings {
                let o = method.solve(trace, iterations);
                eprintln!(
                    "{:<36} {:>6} evaluations  {:<13} fitness {:.6} A², {:.2} s",
                    method.name(),
                    o.evaluations,
                    name,
                    o.fitness,
                    o.seconds
                );
                per_case.push(o);
            }
            per_budget.push(per_case);
        }
        results.push(per_budget);
    }
    println!("\n| method | budget (evaluations) | mean Err% | mean final fitness (A²) | mean time per identification (s) | mean evaluations used |");
    println!("|---|---|---|---|---|---|");
    for (b, &iterations) in budgets.iter().enumerate() {
        for (m, method) in Method::ALL.iter().enumerate() {
            let runs = &results[m][b];
            let err = mean(
                runs.iter().zip(recordings).map(|(o, (_, truth, _))| f64::from(o.estimate.paper_error_percent(truth))),
            );
            println!(
                "| {} | {} | {:.2} | {:.6} | {:.2} | {:.0} |",
                method.name(),
                iterations as usize * ONBOARD_POPULATION,
                err,
                mean(runs.iter().map(|o| o.fitness)),
                mean(runs.iter().map(|o| o.seconds)),
                mean(runs.iter().map(|o| o.evaluations as f64)),
            );
        }
    }
    let names: Vec<&str> = recordings.iter().map(|(n, _, _)| *n).collect();
    let per_recording = |title: &str, cell: &dyn Fn(&Outcome, &FaultVector) -> String| {
        println!("\n{title}:\n\n| method | budget | {} |", names.join(" | "));
        println!("|---|---|{}", "---|".repeat(names.len()));
        for (b, &iterations) in budgets.iter().enumerate() {
            for (m, method) in Method::ALL.iter().enumerate() {
                let cells: Vec<String> =
                    results[m][b].iter().zip(recordings).map(|(o, (_, truth, _))| cell(o, truth)).collect();
                println!(
                    "| {} | {} | {} |",
                    method.name(),
                    iterations as usize * ONBOARD_POPULATION,
                    cells.join(" | ")
                );
            }
        }
    };
    per_recording("Err% per recording", &|o, truth| format!("{:.2}", o.estimate.paper_error_percent(truth)));
    per_recording("Final fitness per recording (A²)", &|o, _| format!("{:.6}", o.fitness));
    // The floor: the fitness of the injected vector itself. A method that ends below it has fitted the model
    // mismatch, and a lower fitness then need not mean a lower Err%.
    let at_truth: Vec<String> =
        recordings.iter().map(|(_, truth, trace)| format!("{:.6}", objective(trace).error(truth))).collect();
    println!("| fitness at the true vector | – | {} |", at_truth.join(" | "));
    println!(
        "\nRecordings: reference model, standard manoeuvre, noise seed {NOISE_SEED}; optimizer seed {OPTIMIZER_SEED}; \
         {} individuals; one identification at a time.",
        ONBOARD_POPULATION
    );
}

/// DE variants on the same recordings (seeds 1 and 2, two worker threads): mean Err% and fitness per budget.
fn de_sweep(recordings: &[(&str, FaultVector, Box<MeasuredTrace<HOST_WINDOW>>)]) {
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
fn criterion_group(trace: &MeasuredTrace<HOST_WINDOW>) {
    let mut c = Criterion::default()
        .sample_size(10)
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(5))
        .configure_from_args();
    let mut group = c.benchmark_group("identification_1500_evaluations");
    for method in Method::ALL {
        group.bench_function(method.name(), |b| {
            b.iter(|| method.solve(std::hint::black_box(trace), ONBOARD_MAX_ITERATIONS))
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
            let o = method.solve(&trace, 2);
            let budget = 2 * ONBOARD_POPULATION as u64;
            if method == Method::OursPsoRefined {
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
