//! Speed targets of issue 5: SPAFDR of 10 minutes of 1 kHz data under 100 ms; reading a 4 MB ULog
//! under 50 ms.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure
#![allow(missing_docs)]

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use skyloop_sysid::logs::{Log, OpenOptions};
use skyloop_sysid::spectral::{estimate, IoData, Options};

fn spafdr_10min_1khz(c: &mut Criterion) {
    let n = 600_000;
    let dt = 0.001;
    // A deterministic broadband input (sum of incommensurate sines) through a first-order lag.
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
    let o = Options::default();
    c.bench_function("spafdr_600k_samples", |b| {
        b.iter(|| {
            estimate(
                black_box(&IoData {
                    u: &u,
                    y: &y,
                    r: None,
                    dist: None,
                    dt_s: dt,
                }),
                &o,
            )
            .unwrap()
        })
    });
    let r = u.clone();
    c.bench_function("spafdr_600k_samples_closed_loop", |b| {
        b.iter(|| {
            estimate(
                black_box(&IoData {
                    u: &u,
                    y: &y,
                    r: Some(&r),
                    dist: None,
                    dt_s: dt,
                }),
                &o,
            )
            .unwrap()
        })
    });
}

fn read_ulog_4mb(c: &mut Criterion) {
    let p = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../testdata/logs/sample.ulg"));
    c.bench_function("read_sample_ulg_4mb", |b| {
        b.iter(|| Log::open(black_box(p), &OpenOptions::default()).unwrap())
    });
}

criterion_group!(benches, spafdr_10min_1khz, read_ulog_4mb);
criterion_main!(benches);
