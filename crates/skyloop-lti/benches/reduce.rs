//! Balanced reduction of a 100-state 2×2 system (control.rss, fixture rss_n100 from
//! tools/gen_reduce.py) to order 10; `bench/compare.py --group reduce` compares with python-control + slycot.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure
#![allow(missing_docs)] // criterion_group! generates an undocumented function

use criterion::{criterion_group, criterion_main, Criterion};
use skyloop_lti::reduce::{balred, hsvd, Method};
use skyloop_lti::StateSpace;
use std::hint::black_box;

fn rows(v: &serde_json::Value) -> Vec<Vec<f64>> {
    v.as_array()
        .expect("rows")
        .iter()
        .map(|r| {
            r.as_array()
                .expect("row")
                .iter()
                .map(|x| x.as_f64().expect("number"))
                .collect()
        })
        .collect()
}

fn model() -> StateSpace {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/reduce/cases.json"))
        .expect("fixture");
    let v: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    let c = v["cases"]
        .as_array()
        .expect("cases")
        .iter()
        .find(|c| c["name"] == "rss_n100")
        .expect("rss_n100");
    StateSpace::from_rows(&rows(&c["a"]), &rows(&c["b"]), &rows(&c["c"]), &rows(&c["d"]), 0.0).expect("model")
}

fn bench(c: &mut Criterion) {
    let sys = model();
    c.bench_function("balred_100_2x2_to_10", |b| {
        b.iter(|| balred(black_box(&sys), 10, Method::Balanced).expect("reduction"))
    });
    c.bench_function("balred_spa_100_2x2_to_10", |b| {
        b.iter(|| balred(black_box(&sys), 10, Method::Spa).expect("reduction"))
    });
    c.bench_function("hsvd_100_2x2", |b| b.iter(|| hsvd(black_box(&sys)).expect("hsv")));
}

criterion_group!(benches, bench);
criterion_main!(benches);
