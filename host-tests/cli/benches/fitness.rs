//! Cost of one fitness evaluation: one monitor-model run over the standard manoeuvre (8 500 steps
//! of 100 µs) against a recording, the unit every identification spends 1 500–2 300 of.
//!
//! `cd host-tests && cargo bench -p ema-cli --bench fitness`: the reference model records the
//! standard manoeuvre with the built-in trace's fault (friction k1 = 0.25, noise seed 1), conditioned
//! like `ema identify`; criterion times [`EquivalentCurrentFit::error`] (the on-board fitness, fast regime
//! weighted by [`FAST_REGIME_WEIGHT`], no early abandoning) at the true vector and at a vector with
//! eccentricity (its shape function costs a sine and cosine of the rotor angle per step). Compare
//! two builds with criterion's baselines: `-- --save-baseline before`, then `-- --baseline before`.
//! Run without `--bench` (e.g. `cargo test --all-targets`) it runs once as a smoke test.

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use ema_cli::identify::condition_recording;
use ema_cli::recording::Recording;
use ema_monitor::fitness::{EquivalentCurrentFit, FAST_REGIME_WEIGHT};
use ema_monitor::{EmaParams, FaultVector, Profile};
use ema_reference::{simulate, SimConfig};

fn bench(c: &mut Criterion) {
    let truth = FaultVector([0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5]);
    let rec = simulate(&SimConfig { faults: truth, seed: 1, ..SimConfig::default() }).expect("simulates");
    let recording = Recording::from_reference(&rec, Vec::new());
    let trace = condition_recording(&recording, Path::new("standard.csv"), &EmaParams::NOMINAL, &Profile::STANDARD)
        .expect("conditions");
    let fit = EquivalentCurrentFit::new(&trace, EmaParams::NOMINAL, &Profile::STANDARD)
        .expect("a conditioned trace is finished")
        .with_fast_regime_weight(FAST_REGIME_WEIGHT)
        .expect("the on-board weight is valid");
    let eccentric = FaultVector([0.25, 0.0, 0.0, 0.0, 0.0, 0.5, 0.3, 0.5]);
    let mut group = c.benchmark_group("fitness_evaluation");
    for (name, k) in [("true vector", truth), ("with eccentricity", eccentric)] {
        group.bench_function(name, |b| {
            b.iter(|| {
                let e = fit.error(std::hint::black_box(&k));
                assert!(e.is_finite() && e > 0.0);
                e
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
