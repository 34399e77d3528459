//! μ bounds of a 20×20 frequency response with 6 blocks at 200 frequencies (target < 200 ms).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure
#![allow(missing_docs)] // criterion_group! generates an undocumented function

use criterion::{criterion_group, criterion_main, Criterion};
use faer::{c64, Mat};
use skyloop_robust::mu::{mu_sweep, MuOptions};
use skyloop_robust::uncertainty::BlockStructure;

/// Deterministic 20×20 responses M(jω) = A₀ + A₁/(1 + jω) + A₂/(1 + 0.1 jω) with xorshift entries.
fn responses(n: usize, nw: usize) -> Vec<Mat<c64>> {
    let mut x = 0x2545_F491_4F6C_DD1Du64;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let a: Vec<Mat<f64>> = (0..3).map(|_| Mat::from_fn(n, n, |_, _| next())).collect();
    (0..nw)
        .map(|k| {
            let w = 10f64.powf(-2.0 + 4.0 * k as f64 / (nw - 1) as f64);
            let (p1, p2) = (c64::new(1.0, w), c64::new(1.0, 0.1 * w));
            Mat::from_fn(n, n, |i, j| {
                c64::new(a[0][(i, j)], 0.0) + a[1][(i, j)] / p1 + a[2][(i, j)] / p2
            })
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let s = BlockStructure::parse("f4x4,f4x4,c3r,c1x1,f4x4,f4x4").expect("spec");
    let ms = responses(20, 200);
    let opts = MuOptions::default();
    let mut g = c.benchmark_group("mu");
    g.sample_size(10);
    g.bench_function("20x20_6blocks_200freq", |b| {
        b.iter(|| mu_sweep(&ms, &s, &opts).expect("mu"));
    });
    // The first 20 responses with the repeated complex scalar made real (r3): the D–G bound on top
    // of the complex one (no target; it shows the cost of real blocks, per 20 frequencies).
    let sr = BlockStructure::parse("f4x4,f4x4,r3,c1x1,f4x4,f4x4").expect("spec");
    g.bench_function("20x20_6blocks_r3_20freq", |b| {
        b.iter(|| mu_sweep(&ms[..20], &sr, &opts).expect("mu"));
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
