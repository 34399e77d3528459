//! Frequency-analysis benchmarks (issue 2 targets; bench/compare.py prints the ratios against
//! python-control + slycot): frequency response of a 20-state 2×2 model at 10,000 frequencies,
//! H∞ norm of a 40-state 3×3 model (and its Hamiltonian eigenvalue solve), margins of the bicopter loop.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure
#![allow(missing_docs)] // criterion_group! generates an undocumented function

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use skyloop_lti::freqresp::{logspace, FreqEvaluator};
use skyloop_lti::{Mat, StateSpace};

/// A stable random model: A = Q·diag-ish·Qᵀ-like mix of a random matrix shifted left of its spectral radius.
fn random_stable(n: usize, ny: usize, nu: usize, seed: u64) -> StateSpace {
    let mut r = rand::rngs::StdRng::seed_from_u64(seed);
    let mut m = |rows: usize, cols: usize| Mat::from_fn(rows, cols, |_, _| r.gen_range(-1.0..1.0));
    let mut a = m(n, n);
    let eig = a.eigenvalues().expect("eigenvalues");
    let shift = eig.iter().map(|l| l.re).fold(f64::NEG_INFINITY, f64::max) + 0.1;
    for i in 0..n {
        a[(i, i)] -= shift;
    }
    StateSpace::new(a, m(n, nu), m(ny, n), m(ny, nu), 0.0).expect("valid model")
}

fn bench(c: &mut Criterion) {
    let sys = random_stable(20, 2, 2, 1);
    let w = logspace(-2.0, 3.0, 10_000);
    c.bench_function("freqresp 20 states 2x2 10k freqs", |b| {
        b.iter(|| {
            let ev = FreqEvaluator::new(black_box(&sys)).expect("prepare");
            ev.freqresp(black_box(&w)).expect("freqresp")
        })
    });
    let big = random_stable(40, 3, 3, 2);
    c.bench_function("hinf_norm 40 states 3x3", |b| {
        b.iter(|| skyloop_lti::norms::hinf_norm(black_box(&big)).expect("hinf"))
    });
    // The H∞ iteration's inner problem: eigenvalues of the 80 × 80 Hamiltonian
    // [[A, −BBᵀ], [−CᵀC, −Aᵀ]], square-reduced (ours) against a dense eigenvalue solve (faer).
    let n = big.nx();
    let (bbt, ctc) = (&big.b * big.b.transpose(), big.c.transpose() * &big.c);
    let ham = Mat::from_fn(2 * n, 2 * n, |i, j| match (i < n, j < n) {
        (true, true) => big.a[(i, j)],
        (true, false) => -bbt[(i, j - n)],
        (false, true) => -ctc[(i - n, j)],
        (false, false) => -big.a[(j - n, i - n)],
    });
    c.bench_function("hamiltonian eigenvalues 80x80 (square-reduced)", |b| {
        b.iter(|| skyloop_linalg::hamiltonian::hamiltonian_eigenvalues(black_box(ham.as_ref())).expect("eig"))
    });
    c.bench_function("hamiltonian eigenvalues 80x80 (faer dense)", |b| {
        b.iter(|| black_box(&ham).eigenvalues().expect("eig"))
    });
    let l = skyloop_lti::expr::parse_model(
        "0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2 - s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5) \
         * 24.02*(s+54.01)*(s+0.2474)*(s^2+139.3*s+2.624e4)/(s*(s^2+24.14*s+8544)*(s^2+232.4*s+7.041e4))",
    )
    .expect("bicopter loop");
    c.bench_function("allmargin bicopter L = P*C (delay)", |b| {
        b.iter(|| skyloop_lti::margins::allmargin(black_box(&l)).expect("margins"))
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_main!(benches);
