//! Runtime of `ema discover` on the standard recording (bar ≤ 30 s on the development machine).
//!
//! `cd host-tests && cargo bench -p ema-cli --bench discover`: the standard recording is the
//! standard manoeuvre of the reference model with the built-in trace's fault (friction
//! k1 = 0.25), noise seed 1, and a hidden viscous-friction effect (severity 0.5); criterion
//! times the whole workflow (fit, where, two search rounds, refit) with 1 and 2 worker threads,
//! 10 samples each. Run without `--bench` (e.g. `cargo test --all-targets`) it runs once as a
//! smoke test.

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use ema_cli::discover::discover;
use ema_cli::identify::{condition_recording, HOST_WINDOW};
use ema_cli::recording::Recording;
use ema_monitor::{FaultVector, Profile};
use ema_reference::{simulate, Effect, Effects, SimConfig};

fn standard_recording() -> Recording {
    let faults = FaultVector([0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let effects = Effects::default().with(Effect::Viscous, 0.5).expect("severity in range");
    let rec = simulate(&SimConfig { faults, effects, seed: 1, ..SimConfig::default() }).expect("simulates");
    Recording::from_reference(&rec, vec![])
}

fn bench(c: &mut Criterion) {
    let recording = standard_recording();
    let path = Path::new("standard.csv");
    let trace = condition_recording(&recording, path, &ema_monitor::EmaParams::NOMINAL, &Profile::STANDARD)
        .expect("conditions");
    let mut group = c.benchmark_group("discover");
    group.sample_size(10);
    for threads in [1usize, 2] {
        group.bench_function(format!("standard recording, {threads} thread(s)"), |b| {
            b.iter(|| {
                let d = discover::<HOST_WINDOW>(
                    &trace,
                    &ema_monitor::EmaParams::NOMINAL,
                    &Profile::STANDARD,
                    path,
                    None,
                    1,
                    threads,
                )
                .expect("runs");
                assert_eq!(d.named.len(), 1);
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
