//! Physics steps per second: the SSI-PI quadrotor with motors, RK4 at 1 kHz, controllers and gyro in
//! the loop (target ≥ 2 M steps/s on one core). Throughput is reported in elements (= steps).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure
#![allow(missing_docs)] // criterion_group! generates undocumented functions

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use skyloop_sim::{Scenario, Simulation};

fn bench(c: &mut Criterion) {
    let text = include_str!("../../../examples/quadrotor-ssi.toml");
    let scn = Scenario::from_toml(text).expect("example");
    let mut g = c.benchmark_group("quadrotor_rk4_1khz");
    const N: u64 = 10_000;
    g.throughput(Throughput::Elements(N));
    g.bench_function("closed_loop_10k_steps", |b| {
        b.iter_batched(
            || Simulation::new(&scn, 1).expect("sim"),
            |mut sim| {
                for _ in 0..N {
                    sim.step();
                }
                sim
            },
            criterion::BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
