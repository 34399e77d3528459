//! Best-of thread CPU times of `real_schur` on random matrices, with the backward error
//! ‖A − QTQᵀ‖_F/‖A‖_F and the orthogonality ‖QᵀQ − I‖_F (for profiling and crossover checks;
//! the comparison with LAPACK is `bench/compare.py`).
//! Run: `cargo run --release -p skyloop-linalg --example time_schur -- [n...]`.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use faer::Mat;
use skyloop_linalg::schur::{real_schur, reorder_schur};

use skyloop_fixtures::thread_cpu_seconds as now;

/// Same deterministic matrix as `benches/riccati.rs`.
fn random(n: usize, seed: u64) -> Mat<f64> {
    let mut next = skyloop_fixtures::lcg(seed);
    Mat::from_fn(n, n, |_, _| 2.0 * next() - 1.0)
}

fn main() {
    let sizes: Vec<usize> = std::env::args().skip(1).filter_map(|s| s.parse().ok()).collect();
    let sizes = if sizes.is_empty() { vec![100, 400] } else { sizes };
    for n in sizes {
        let a = random(n, 7);
        let reps = (4_000_000 / (n * n * n).max(1)).clamp(1, 50);
        let mut best = f64::INFINITY;
        let mut s = None;
        for _ in 0..reps {
            let t = now();
            s = Some(real_schur(a.as_ref()).unwrap());
            best = best.min(now() - t);
        }
        let s = s.unwrap();
        let recon = &s.q * &s.t * s.q.transpose();
        let berr = (&recon - &a).norm_l2() / a.norm_l2();
        let orth = (s.q.transpose() * &s.q - Mat::<f64>::identity(n, n)).norm_l2();
        println!(
            "n={n} best={:.3} ms (of {reps}) backward={berr:.2e} orth={orth:.2e}",
            best * 1e3
        );
        // Ordered Schur form: the left half-plane eigenvalues to the top (as the CARE needs).
        let mut best = f64::INFINITY;
        let mut r = None;
        for _ in 0..reps {
            let mut s2 = s.clone();
            let t = now();
            reorder_schur(&mut s2, |z| z.re < 0.0).unwrap();
            best = best.min(now() - t);
            r = Some(s2);
        }
        let r = r.unwrap();
        let recon = &r.q * &r.t * r.q.transpose();
        let berr = (&recon - &a).norm_l2() / a.norm_l2();
        let orth = (r.q.transpose() * &r.q - Mat::<f64>::identity(n, n)).norm_l2();
        println!(
            "n={n} reorder (Re < 0 first) best={:.3} ms backward={berr:.2e} orth={orth:.2e}",
            best * 1e3
        );
    }
}
