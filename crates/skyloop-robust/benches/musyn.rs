//! DK-iteration timing on the distillation column of Skogestad & Postlethwaite §8.12.4 (the plant of
//! examples/musyn-distillation.toml): one iteration (H∞ K-step + μ analysis on 51 frequencies) and
//! two (adds the D-fit and a K-step on the 22-state scaled plant).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure
#![allow(missing_docs)] // criterion_group! generates an undocumented function

use criterion::{criterion_group, criterion_main, Criterion};
use faer::Mat;
use skyloop_lti::StateSpace;
use skyloop_robust::musyn::{musyn, MusynOptions};
use skyloop_robust::uncertainty::BlockStructure;

/// Generalized plant [dI; w; u] → [wI·u; wP·(G(u+dI)+w); −G(u+dI)−w] (see tests/musyn.rs).
fn plant() -> StateSpace {
    let g0 = [[87.8, -86.4], [108.2, -109.6]];
    let pole = 1e-4;
    let (mut a, mut b, mut c, mut d) = (
        Mat::<f64>::zeros(6, 6),
        Mat::<f64>::zeros(6, 6),
        Mat::<f64>::zeros(6, 6),
        Mat::<f64>::zeros(6, 6),
    );
    for i in 0..2 {
        a[(i, i)] = -1.0 / 75.0;
        for j in 0..2 {
            b[(i, j)] = g0[i][j] / 75.0;
            b[(i, 4 + j)] = g0[i][j] / 75.0;
        }
        a[(2 + i, 2 + i)] = -2.0;
        b[(2 + i, 4 + i)] = 1.0;
        a[(4 + i, 4 + i)] = -pole;
        a[(4 + i, i)] = 1.0;
        b[(4 + i, 2 + i)] = 1.0;
        c[(i, 2 + i)] = -3.6;
        d[(i, 4 + i)] = 2.0;
        c[(2 + i, 4 + i)] = 0.5 * (0.1 - pole);
        c[(2 + i, i)] = 0.5;
        d[(2 + i, 2 + i)] = 0.5;
        c[(4 + i, i)] = -1.0;
        d[(4 + i, 2 + i)] = -1.0;
    }
    StateSpace::new(a, b, c, d, 0.0).expect("plant")
}

fn bench(c: &mut Criterion) {
    let p = plant();
    let blocks = BlockStructure::parse("c1x1,c1x1").expect("spec");
    let mut g = c.benchmark_group("musyn");
    g.sample_size(10);
    for iters in [1, 2] {
        let opts = MusynOptions {
            w_rad_s: skyloop_lti::freqresp::logspace(-3.0, 2.0, 51),
            d_order: 4,
            max_iter: iters,
            tol: 0.0,
            ..Default::default()
        };
        g.bench_function(format!("distillation_{iters}_iter"), |b| {
            b.iter(|| musyn(&p, &blocks, 2, 2, &opts).expect("musyn"));
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
