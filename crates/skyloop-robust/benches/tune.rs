//! PID tuning on a 10-state plant with restarts (MIGO: max ki under Ms <= 1.4 and a disk margin),
//! and hinfstruct on the 12-state bench plant at order 2.
#![allow(clippy::unwrap_used)] // a panic is how a bench reports failure
#![allow(missing_docs)] // criterion_group! generates undocumented functions

use criterion::{criterion_group, criterion_main, Criterion};
use skyloop_lti::expr::parse_model;
use skyloop_robust::structured::blocks::{Block, DerivativeFilter, Structure};
use skyloop_robust::structured::goals::{Bound, Goal, Requirement};
use skyloop_robust::structured::hinfstruct::{hinfstruct, HinfstructOptions};
use skyloop_robust::structured::systune::{tune_loop, LoopTuning, Objective, TuneOptions};

fn bench(c: &mut Criterion) {
    // Ten states: a 4th-order lag, a lightly damped mode pair and a 4th-order sensor chain.
    let g = parse_model("100/((s+1)^4*(s^2+0.4*s+100)*(0.01*s+1)^4)").unwrap();
    assert_eq!(g.nx(), 10);
    let prob = LoopTuning {
        plants: vec![g],
        structure: Structure::new(Block::Pid(DerivativeFilter::Tuned)),
        goals: vec![
            Goal::hard(Requirement::Ms, Bound::AtMost(1.4), "ms<=1.4"),
            Goal::hard(Requirement::DiskMargin, Bound::AtLeast(0.6), "disk_margin>=0.6"),
        ],
        objective: Objective::MaximizeIntegralGain,
        options: TuneOptions {
            starts: 8,
            ..Default::default()
        },
    };
    let mut grp = c.benchmark_group("tune");
    grp.sample_size(10);
    grp.bench_function("pid_10_states_8_starts", |b| b.iter(|| tune_loop(&prob).unwrap()));
    let f = skyloop_fixtures::load(env!("CARGO_MANIFEST_DIR"), "tests/fixtures/hinf/bench_plant12.json");
    if let Ok(j) = serde_json::from_value::<skyloop_lti::json::LtiJson>(f["plant"].clone()) {
        let p = j.to_ss().unwrap();
        let (nmeas, ncon) = (
            f["nmeas"].as_u64().unwrap_or(1) as usize,
            f["ncon"].as_u64().unwrap_or(1) as usize,
        );
        grp.bench_function("hinfstruct_12_states_order2_4_starts", |b| {
            b.iter(|| {
                hinfstruct(
                    &p,
                    nmeas,
                    ncon,
                    2,
                    &HinfstructOptions {
                        starts: 4,
                        ..Default::default()
                    },
                )
            })
        });
    }
    grp.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
