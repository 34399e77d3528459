//! Smallest thread CPU times of the analysis and identification workloads that `bench/compare.py`
//! compares with python-control, slycot, scipy and pyulog (modules `compare_step`,
//! `compare_reduce`, `compare_sysid`), printed as one JSON object of seconds with check values.
//! Run from anywhere: `cargo run --release -p skyloop --example time_workflows`.
#![allow(clippy::unwrap_used)] // a timing tool: a panic names the broken input

use skyloop::lti::reduce::{balred, Method};
use skyloop::lti::StateSpace;
use skyloop::sysid::logs::{Log, OpenOptions};
use skyloop::sysid::spectral::{estimate, IoData, Options};
use skyloop_fixtures::{best_cpu_seconds, cases, lcg_matrix};

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

fn rows(v: &serde_json::Value) -> Vec<Vec<f64>> {
    v.as_array().unwrap().iter().map(skyloop_fixtures::f64s).collect()
}

/// The 100-state 2×2 model `rss_n100` of the reduction fixtures (control.rss, tools/gen_reduce.py).
fn rss_n100() -> StateSpace {
    let all = cases(ROOT, "crates/skyloop-lti/tests/fixtures/reduce/cases.json");
    let c = all.iter().find(|c| c["name"] == "rss_n100").unwrap();
    StateSpace::from_rows(&rows(&c["a"]), &rows(&c["b"]), &rows(&c["c"]), &rows(&c["d"]), 0.0).unwrap()
}

/// Ten minutes at 1 kHz of a deterministic broadband input through a first-order lag; the same
/// record `compare_sysid` builds in numpy (y = lfilter([0, 0.1], [1, -0.9], u)).
fn record() -> (Vec<f64>, Vec<f64>) {
    let (n, dt) = (600_000, 0.001);
    let u: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            (7.1 * t).sin() + (113.0 * t).sin() + (1337.0 * t).cos() + ((i * 7919) % 1000) as f64 / 500.0 - 1.0
        })
        .collect();
    let mut y = vec![0.0; n];
    for i in 1..n {
        y[i] = 0.9 * y[i - 1] + 0.1 * u[i - 1];
    }
    (u, y)
}

fn main() {
    let text = std::fs::read_to_string(format!("{ROOT}/bench/step20.json")).unwrap();
    let step_sys = skyloop::lti::json::from_json_str(&text).unwrap();
    let t: Vec<f64> = (0..1000).map(|k| 10.0 * k as f64 / 999.0).collect();
    let step = best_cpu_seconds(50, || skyloop::lti::timeresp::step(&step_sys, Some(&t)).unwrap());

    let big = rss_n100();
    let bt = best_cpu_seconds(10, || balred(&big, 10, Method::Balanced).unwrap());
    let spa = best_cpu_seconds(10, || balred(&big, 10, Method::Spa).unwrap());

    // Reduction at n = 1000 (issue 15: no slower than SLICOT AB09AD): A = LCG − √n·I (stable: the
    // random part's spectral radius is about √(n/3)), B, C from the LCG, to order 10.
    let mut a1k = lcg_matrix(1000, 1000, 11);
    for (i, row) in a1k.iter_mut().enumerate() {
        row[i] -= 1000f64.sqrt();
    }
    let sys1k = StateSpace::from_rows(
        &a1k,
        &lcg_matrix(1000, 2, 12),
        &lcg_matrix(2, 1000, 13),
        &[vec![0.0; 2], vec![0.0; 2]],
        0.0,
    )
    .unwrap();
    let bt1k = best_cpu_seconds(1, || balred(&sys1k, 10, Method::Balanced).unwrap());

    let (u, y) = record();
    let data = IoData {
        u: &u,
        y: &y,
        r: None,
        dist: None,
        dt_s: 0.001,
    };
    let spafdr = best_cpu_seconds(5, || estimate(&data, &Options::default()).unwrap());

    let ulg = std::path::PathBuf::from(format!("{ROOT}/testdata/logs/sample.ulg"));
    let read_ulog = best_cpu_seconds(5, || Log::open(&ulg, &OpenOptions::default()).unwrap());

    println!(
        "{}",
        serde_json::json!({
            "step_20_states_1000_points": step,
            "balred_100_2x2_to_10": bt,
            "balred_spa_100_2x2_to_10": spa,
            "balred_1000_2x2_to_10": bt1k,
            "spafdr_600k_samples": spafdr,
            "read_sample_ulg_4mb": read_ulog,
            "check_y_last": y[y.len() - 1],
        })
    );
}
