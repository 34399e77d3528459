//! Step response of the 20-state SISO system of bench/step20.json (committed; python-control rss, seed 7).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure
#![allow(missing_docs)] // criterion_group! generates an undocumented function

use criterion::{criterion_group, criterion_main, Criterion};
use skyloop_lti::timeresp::step;

fn bench(c: &mut Criterion) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench/step20.json");
    let text = std::fs::read_to_string(path).expect("bench/step20.json is committed");
    let sys = skyloop_lti::json::from_json_str(&text).expect("valid LTI JSON");
    let t: Vec<f64> = (0..1000).map(|k| 10.0 * k as f64 / 999.0).collect();
    c.bench_function("step_20_states_1000_points", |b| {
        b.iter(|| step(&sys, Some(&t)).expect("step"))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
