//! Riccati and Schur timings. The CARE/DARE problems are the 50-state fixtures also timed with scipy
//! by `bench/compare.py` (through `examples/time_linalg.rs`).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure
#![allow(missing_docs)] // criterion's macros generate undocumented public functions

use criterion::{criterion_group, criterion_main, Criterion};
use faer::Mat;
use serde_json::Value;
use skyloop_linalg::riccati::{care, dare};
use skyloop_linalg::schur::{real_schur, reorder_schur};
use std::hint::black_box;

fn mat(v: &Value) -> Option<Mat<f64>> {
    let rows = v.as_array()?;
    let n = rows.len();
    let m = rows.first().and_then(|r| r.as_array()).map(|r| r.len()).unwrap_or(0);
    Some(Mat::from_fn(n, m, |i, j| rows[i][j].as_f64().unwrap_or(f64::NAN)))
}

fn fixture(file: &str, name: &str) -> (Mat<f64>, Mat<f64>, Mat<f64>, Mat<f64>) {
    let path = format!("{}/tests/fixtures/riccati/{file}", env!("CARGO_MANIFEST_DIR"));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(path).expect("fixture")).expect("json");
    let c = v["cases"]
        .as_array()
        .expect("cases")
        .iter()
        .find(|c| c["name"] == name)
        .expect("case")
        .clone();
    let get = |k: &str| mat(&c[k]).expect(k);
    (get("a"), get("b"), get("q"), get("r"))
}

fn random(n: usize, seed: u64) -> Mat<f64> {
    let mut next = skyloop_fixtures::lcg(seed);
    Mat::from_fn(n, n, |_, _| 2.0 * next() - 1.0)
}

fn benches(c: &mut Criterion) {
    let (a, b, q, r) = fixture("care.json", "random_n50_m10");
    c.bench_function("care_n50", |bch| {
        bch.iter(|| care(black_box(a.as_ref()), b.as_ref(), q.as_ref(), r.as_ref(), None).expect("care"))
    });
    let (a, b, q, r) = fixture("dare.json", "random_n50_m5");
    c.bench_function("dare_n50", |bch| {
        bch.iter(|| dare(black_box(a.as_ref()), b.as_ref(), q.as_ref(), r.as_ref(), None).expect("dare"))
    });
    let m = random(100, 7);
    c.bench_function("schur_n100", |bch| {
        bch.iter(|| real_schur(black_box(m.as_ref())).expect("schur"))
    });
    let s = real_schur(m.as_ref()).expect("schur");
    c.bench_function("reorder_schur_n100_lhp", |bch| {
        bch.iter(|| {
            let mut s2 = s.clone();
            reorder_schur(&mut s2, |z| z.re < 0.0).expect("reorder")
        })
    });
}

criterion_group!(riccati_benches, benches);
criterion_main!(riccati_benches);
