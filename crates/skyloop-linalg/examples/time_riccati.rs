//! Best-of timings of the benchmark problems, printed as JSON for `bench/compare_riccati.py`
//! (the same statistic the script uses for scipy/SLICOT; robust on a busy machine).
//! Run: `cargo run --release -p skyloop-linalg --example time_riccati [repeats]`.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use faer::Mat;
use serde_json::Value;
use skyloop_linalg::riccati::{care, dare};
use skyloop_linalg::schur::real_schur;
use std::time::Instant;

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

/// Same deterministic matrix as `benches/riccati.rs`.
fn random(n: usize, seed: u64) -> Mat<f64> {
    let mut state = seed;
    Mat::from_fn(n, n, |_, _| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    })
}

fn best_of(repeats: usize, mut f: impl FnMut() -> Result<(), String>) -> Result<f64, String> {
    let mut best = f64::INFINITY;
    for _ in 0..repeats {
        let t = Instant::now();
        f()?;
        best = best.min(t.elapsed().as_secs_f64());
    }
    Ok(best)
}

fn main() -> Result<(), String> {
    let repeats: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(50);
    let (a, b, q, r) = fixture("care.json", "random_n50_m10")?;
    let t_care = best_of(repeats, || {
        care(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None)
            .map(|_| ())
            .map_err(|e| e.to_string())
    })?;
    let (a, b, q, r) = fixture("dare.json", "random_n50_m5")?;
    let t_dare = best_of(repeats, || {
        dare(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None)
            .map(|_| ())
            .map_err(|e| e.to_string())
    })?;
    let m = random(100, 7);
    let t_schur = best_of(repeats, || {
        real_schur(m.as_ref()).map(|_| ()).map_err(|e| e.to_string())
    })?;
    println!("{{\"care_n50\": {t_care:e}, \"dare_n50\": {t_dare:e}, \"schur_n100\": {t_schur:e}}}");
    Ok(())
}
