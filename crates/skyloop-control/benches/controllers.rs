//! One step of the bicopter's 5th-order H∞ controller (eq. (12), Tustin 250 Hz) as state space and as
//! SOS, f32 and f64; the target is < 100 ns per step.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure
#![allow(missing_docs)] // criterion_group! generates undocumented functions

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use skyloop_control::{Biquad, SosController, SsController};

fn fixture() -> serde_json::Value {
    serde_json::from_str(include_str!("../tests/fixtures/control/control.json")).expect("fixture")
}

fn flat(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .flat_map(|r| match r.as_array() {
            Some(row) => row.iter().map(|x| x.as_f64().expect("num")).collect::<Vec<_>>(),
            None => vec![r.as_f64().expect("num")],
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let f = &fixture()["hinf_bicopter"];
    let (a, b, cc, d) = (flat(&f["a"]), flat(&f["b"]), flat(&f["c"]), flat(&f["d"]));
    let mut k = SsController::<f64, 5, 1, 1>::new(5, 1, 1, &a, &b, &cc, &d)
        .expect("ok")
        .with_limits(&[-1.0], &[1.0])
        .expect("ok")
        .with_hanus_aw()
        .expect("ok");
    let mut e = 0.01f64;
    c.bench_function("hinf5_ss_f64_step", |bch| {
        bch.iter(|| {
            e = -e;
            black_box(k.step_siso(black_box(e)))
        })
    });
    let to32 = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
    let mut k32 = SsController::<f32, 5, 1, 1>::new(5, 1, 1, &to32(&a), &to32(&b), &to32(&cc), &to32(&d))
        .expect("ok")
        .with_limits(&[-1.0], &[1.0])
        .expect("ok");
    let mut e32 = 0.01f32;
    c.bench_function("hinf5_ss_f32_step", |bch| {
        bch.iter(|| {
            e32 = -e32;
            black_box(k32.step_siso(black_box(e32)))
        })
    });
    let sos: Vec<Biquad<f64>> = f["sos"]
        .as_array()
        .expect("sos")
        .iter()
        .map(|r| {
            let v = flat(r);
            Biquad {
                b0: v[0],
                b1: v[1],
                b2: v[2],
                a1: v[4],
                a2: v[5],
            }
        })
        .collect();
    let mut ks = SosController::<f64, 3>::new(&sos, 1.0, -1.0, 1.0).expect("ok");
    c.bench_function("hinf5_sos_f64_step", |bch| {
        bch.iter(|| {
            e = -e;
            black_box(ks.step(black_box(e)))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
