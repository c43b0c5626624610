//! Warm against cold identification on one core, in one run: the on-board identification
//! (`IdentifyConfig::onboard`) of the reference model's recording of the standard manoeuvre with
//! the built-in trace's fault (friction k1 = 0.25, noise seed 1), cold, and warm from the cold
//! diagnosis (the same recording: model selection, the polish and the new-fault probes,
//! `src/diagnosis/warm.rs`). The ratio of the two times is the figure; the machine's speed cancels.
//! A third line times the cold identification as `ema identify` runs it, each PSO sweep on a pool
//! of 2 threads (`identify::run_to_end`; the same result bit for bit).
//!
//! `cd host-tests && cargo bench -p ema-cli --bench warm`. Run without `--bench` (e.g.
//! `cargo test --all-targets`) it runs once as a smoke test.

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use ema_cli::identify::{condition_recording, run_to_end, HOST_WINDOW};
use ema_cli::recording::Recording;
use ema_monitor::conditioning::ConditionedWindow;
use ema_monitor::diagnosis::{Identification, IdentifyConfig, ONBOARD_POPULATION};
use ema_monitor::health::HealthReport;
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};

/// The on-board identification of `trace`, run to its end by `run`.
fn identify(
    trace: &ConditionedWindow<HOST_WINDOW>,
    config: &IdentifyConfig,
    run: impl FnOnce(&mut Identification<'_, HOST_WINDOW, ONBOARD_POPULATION>),
) -> HealthReport {
    let mut id: Box<Identification<'_, HOST_WINDOW, ONBOARD_POPULATION>> =
        Box::new(Identification::new(trace, EmaParams::NOMINAL, &Profile::STANDARD, config).expect("accepted"));
    run(&mut id);
    id.report()
}

/// As the firmware runs it: one evaluation after the other.
fn sequential(id: &mut Identification<'_, HOST_WINDOW, ONBOARD_POPULATION>) {
    id.run(u32::MAX);
}

fn bench(c: &mut Criterion) {
    let truth = FaultVector([0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let rec = simulate(&SimConfig { faults: truth, seed: 1, ..SimConfig::default() }).expect("simulates");
    let recording = Recording::from_reference(&rec, Vec::new());
    let trace = condition_recording(&recording, Path::new("standard.csv"), &EmaParams::NOMINAL, &Profile::STANDARD)
        .expect("conditions");
    let cold = IdentifyConfig::onboard();
    let prior = identify(&trace, &cold, sequential).faults;
    let warm = IdentifyConfig { prior: Some(prior.0), ..cold };
    let mut group = c.benchmark_group("identification");
    group.sample_size(10);
    for (name, config) in [("cold", cold), ("warm", warm)] {
        group.bench_function(name, |b| b.iter(|| identify(&trace, std::hint::black_box(&config), sequential)));
    }
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().expect("a pool of 2 threads");
    group.bench_function("cold, PSO sweeps on 2 threads", |b| {
        b.iter(|| pool.install(|| identify(&trace, std::hint::black_box(&cold), run_to_end)))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
