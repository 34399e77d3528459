//! Best-of timings of the linalg benchmark problems, printed as one JSON object for
//! `bench/compare.py`, which times scipy/SLICOT on the same problems in the same run with the same
//! statistic: the smallest thread CPU time of N single calls (on a shared machine with more
//! runnable jobs than cores, wall time mostly measures waiting; CPU time does not).
//! Run: `cargo run --release -p skyloop-linalg --example time_linalg [repeats]`.
//!
//! The random matrices come from a 64-bit LCG that `bench/compare.py` reproduces bit for bit; the
//! `check_*` entries let it confirm that both sides see the same matrices.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use faer::Mat;
use serde_json::Value;
use skyloop_linalg::lyapunov::{lyap, lyap_chol};
use skyloop_linalg::qz::generalized_eigenvalues;
use skyloop_linalg::riccati::{care, dare};
use skyloop_linalg::schur::real_schur;

use skyloop_fixtures::thread_cpu_seconds as now;

fn mat(v: &Value) -> Option<Mat<f64>> {
    let rows = v.as_array()?;
    let n = rows.len();
    let m = rows.first().and_then(|r| r.as_array()).map(|r| r.len()).unwrap_or(0);
    Some(Mat::from_fn(n, m, |i, j| rows[i][j].as_f64().unwrap_or(f64::NAN)))
}

type Problem = (Mat<f64>, Mat<f64>, Mat<f64>, Mat<f64>);

fn fixture(file: &str, name: &str) -> Result<Problem, String> {
    let path = format!("{}/tests/fixtures/riccati/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{path}: {e}"))?;
    let v: Value = serde_json::from_str(&text).map_err(|e| format!("{path}: {e}"))?;
    let c = v["cases"]
        .as_array()
        .and_then(|cs| cs.iter().find(|c| c["name"] == name))
        .ok_or_else(|| format!("{name} not in {path}"))?;
    let get = |k: &str| mat(&c[k]).ok_or_else(|| format!("{name}: no {k}"));
    Ok((get("a")?, get("b")?, get("q")?, get("r")?))
}

/// `rows`×`cols` uniform in [−1, 1), filled column by column from the LCG (as `benches/riccati.rs`).
fn random(rows: usize, cols: usize, seed: u64) -> Mat<f64> {
    let mut state = seed;
    let mut out = Mat::zeros(rows, cols);
    for j in 0..cols {
        for i in 0..rows {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            out[(i, j)] = ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0;
        }
    }
    out
}

/// A stable n×n matrix: random minus √n·I (the random part's spectral radius is about √(n/3)).
fn stable(n: usize, seed: u64) -> Mat<f64> {
    let mut a = random(n, n, seed);
    for i in 0..n {
        a[(i, i)] -= (n as f64).sqrt();
    }
    a
}

fn best_of(repeats: usize, mut f: impl FnMut() -> Result<(), String>) -> Result<f64, String> {
    let mut best = f64::INFINITY;
    for _ in 0..repeats {
        let t = now();
        f()?;
        best = best.min(now() - t);
    }
    Ok(best)
}

fn main() -> Result<(), String> {
    let repeats: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(30);
    let few = (repeats / 10).max(2);
    let e = |e: skyloop_linalg::LinalgError| e.to_string();
    let (a, b, q, r) = fixture("care.json", "random_n50_m10")?;
    let t_care = best_of(repeats, || {
        care(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None)
            .map(|_| ())
            .map_err(e)
    })?;
    let (a, b, q, r) = fixture("dare.json", "random_n50_m5")?;
    let t_dare = best_of(repeats, || {
        dare(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None)
            .map(|_| ())
            .map_err(e)
    })?;
    let m100 = random(100, 100, 7);
    let t_s100 = best_of(repeats, || real_schur(m100.as_ref()).map(|_| ()).map_err(e))?;
    let m400 = random(400, 400, 7);
    let t_s400 = best_of(few, || real_schur(m400.as_ref()).map(|_| ()).map_err(e))?;
    // Generalized eigenvalues of the pencil (M, N) with N from the LCG's next seed.
    let qz = |m: &Mat<f64>, reps: usize| {
        let pencil_b = random(m.nrows(), m.nrows(), 8);
        best_of(reps, || {
            generalized_eigenvalues(m.as_ref(), pencil_b.as_ref())
                .map(|_| ())
                .map_err(e)
        })
    };
    let (t_qz100, t_qz400) = (qz(&m100, repeats)?, qz(&m400, few)?);
    // Lyapunov A·X + X·Aᵀ + B·Bᵀ = 0 at n = 1000, and the Cholesky factor of the same gramian.
    let a1k = stable(1000, 11);
    let b1k = random(1000, 2, 12);
    let q1k = &b1k * b1k.transpose();
    let t_lyap = best_of(2, || lyap(a1k.as_ref(), q1k.as_ref()).map(|_| ()).map_err(e))?;
    let t_chol = best_of(2, || lyap_chol(a1k.as_ref(), b1k.as_ref()).map(|_| ()).map_err(e))?;
    println!(
        "{{\"care_n50\": {t_care:e}, \"dare_n50\": {t_dare:e}, \"schur_n100\": {t_s100:e}, \
         \"schur_n400\": {t_s400:e}, \"qz_n100\": {t_qz100:e}, \"qz_n400\": {t_qz400:e}, \"lyap_n1000\": {t_lyap:e}, \"lyap_chol_n1000\": {t_chol:e}, \
         \"check_schur\": [{:e}, {:e}], \"check_lyap\": [{:e}, {:e}]}}",
        m100[(1, 0)],
        m100[(0, 1)],
        a1k[(3, 2)],
        b1k[(999, 1)]
    );
    Ok(())
}
