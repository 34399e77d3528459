#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure
#![allow(missing_docs)] // criterion_group! generates an undocumented function
//! The whole bicopter design of examples/bicopter.toml (ncfsyn with Padé, gain boost, balanced
//! reduction to 5 states, Tustin at 250 Hz + SOS, γ / b(P,C) / classic and disk margins after each
//! step; no plots). Target < 20 ms.

use criterion::{criterion_group, criterion_main, Criterion};
use skyloop::design::{design, DesignSpec};
use std::path::Path;

const BICOPTER: &str = include_str!("../../../examples/bicopter.toml");

fn bench(c: &mut Criterion) {
    let spec = DesignSpec::from_toml_str(BICOPTER, Path::new(".")).expect("spec");
    let mut g = c.benchmark_group("design");
    g.sample_size(20);
    g.bench_function("bicopter", |b| b.iter(|| design(&spec).expect("design")));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
