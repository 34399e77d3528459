#![allow(clippy::unwrap_used)] // a panic is how a bench reports failure
#![allow(missing_docs)] // criterion_group! generates an undocumented function
//! The ducted-fan reproduction in its --quick form (H∞ synthesis on a 71-state plant, μ sweeps, two
//! DK-iterations, K_μ reduction, eight nonlinear 6-DOF x-steps and the worst-case Δ), end to end.
//! Target: < 60 s per run on the 2-core machine (the budget the CLI test used to assert; speed
//! lives here, not in tests).

use criterion::{criterion_group, criterion_main, Criterion};
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let out = std::env::temp_dir().join(format!("skyloop-bench-duct-{}", std::process::id()));
    let mut g = c.benchmark_group("reproduce");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(120));
    g.bench_function("ducted_fan_quick", |b| {
        b.iter(|| skyloop::papers::reproduce("ducted-fan", &out, true).expect("reproduction"))
    });
    g.finish();
    let _ = std::fs::remove_dir_all(&out);
}

criterion_group!(benches, bench);
criterion_main!(benches);
