//! Cost of the reference model: the standard 0.85 s profile at its default step, 0.25 µs (3 400 000 steps).
//! Bar: ≤ 2 s of wall time per simulated second on one core.

use criterion::{criterion_group, criterion_main, Criterion};
use ema_reference::{simulate, SimConfig};

fn standard_profile(c: &mut Criterion) {
    let cfg = SimConfig::default();
    let mut group = c.benchmark_group("reference_model");
    group.sample_size(10).measurement_time(std::time::Duration::from_secs(10));
    group.bench_function("standard_profile_0.85s", |b| b.iter(|| simulate(std::hint::black_box(&cfg))));
    group.finish();
}

criterion_group!(benches, standard_profile);
criterion_main!(benches);
