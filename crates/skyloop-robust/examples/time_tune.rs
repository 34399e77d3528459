//! The PID-tuning workload that `bench/compare_tune.py` sets beside scipy's global optimizer
//! (differential evolution) on the same objective: on the 10-state plant of the criterion bench
//! `tune`, maximize ki of C = kp + ki/s + kd·s/(tf·s + 1) under Ms ≤ 1.4 and disk margin α ≥ 0.6
//! (MIGO with a margin floor), with 8 starts. Prints one JSON object: the smallest process CPU
//! time over the repeats (s; all threads counted, so rayon's parallel starts are charged in full),
//! the wall time of that run, and the tuned parameters with their re-verified goal values.
//! Run: `cargo run --release -p skyloop-robust --example time_tune [-- REPEATS]`.
#![allow(clippy::unwrap_used)] // a timing tool: a panic names the broken input

use skyloop_lti::expr::parse_model;
use skyloop_robust::structured::blocks::{Block, DerivativeFilter, Structure};
use skyloop_robust::structured::goals::{Bound, Goal, Requirement};
use skyloop_robust::structured::systune::{tune_loop, LoopTuning, Objective, TuneOptions};

/// The plant, as `bench/compare_tune.py` builds it: a 4th-order lag, a lightly damped mode pair
/// at 10 rad/s and a 4th-order sensor chain at 100 rad/s.
const PLANT: &str = "100/((s+1)^4*(s^2+0.4*s+100)*(0.01*s+1)^4)";

#[allow(unsafe_code)] // one libc call; std has no process CPU clock
fn process_cpu_seconds() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime only writes the timespec it is given.
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

fn main() {
    let repeats: usize = std::env::args().nth(1).map_or(3, |s| s.parse().unwrap());
    let g = parse_model(PLANT).unwrap();
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
    let mut best = (f64::INFINITY, 0.0);
    let mut result = None;
    for _ in 0..repeats.max(1) {
        let (c0, w0) = (process_cpu_seconds(), std::time::Instant::now());
        let r = tune_loop(&prob).unwrap();
        let (cpu, wall) = (process_cpu_seconds() - c0, w0.elapsed().as_secs_f64());
        if cpu < best.0 {
            best = (cpu, wall);
        }
        result = Some(r);
    }
    let r = result.unwrap();
    let goal = |label: &str| r.goals.iter().find(|g| g.label == label).map(|g| g.value);
    println!(
        "{}",
        serde_json::json!({
            "plant": PLANT,
            "cpu_seconds": best.0,
            "wall_seconds": best.1,
            "threads": rayon::current_num_threads(),
            "kp": r.params[0],
            "ki": r.params[1],
            "kd": r.params[2],
            "tf": r.params[3].exp(),
            "ms": goal("ms<=1.4"),
            "disk_alpha": goal("disk_margin>=0.6"),
            "feasible": r.feasible,
            "evaluations": r.evaluations,
        })
    );
}
