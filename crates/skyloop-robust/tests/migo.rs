//! MIGO against an independent optimum: the PI (and PID) with the largest ki under Ms <= 1.4 on the classic
//! Åström–Hägglund test plants, vs the brute-force + SLSQP optimum of tools/gen_migo.py (scipy,
//! exact delays, dense grid). Our result must meet Ms <= 1.4 in the exact re-verification and
//! reach at least 99 % of the reference ki (and not exceed it by more than the reference's own
//! grid accuracy).
#![allow(clippy::unwrap_used)] // a panic is how a test reports failure

use skyloop_lti::expr::parse_model;
use skyloop_robust::structured::blocks::{Block, DerivativeFilter, Structure};
use skyloop_robust::structured::goals::{Bound, Goal, Requirement};
use skyloop_robust::structured::systune::{tune_loop, LoopTuning, Objective, TuneOptions};

#[test]
fn pi_integral_gain_matches_the_scipy_optimum() {
    for c in skyloop_fixtures::cases(env!("CARGO_MANIFEST_DIR"), "tests/fixtures/migo/pi_ms14.json") {
        let name = c["name"].as_str().unwrap();
        let prob = LoopTuning {
            plants: vec![parse_model(c["plant"].as_str().unwrap()).unwrap()],
            structure: Structure::new(Block::Pi),
            goals: vec![Goal::hard(Requirement::Ms, Bound::AtMost(1.4), "ms<=1.4")],
            objective: Objective::MaximizeIntegralGain,
            options: TuneOptions {
                starts: 4,
                ..Default::default()
            },
        };
        let r = tune_loop(&prob).unwrap();
        let (kp_ref, ki_ref) = (c["kp"].as_f64().unwrap(), c["ki"].as_f64().unwrap());
        eprintln!(
            "{name}: ours kp {:.6} ki {:.6} Ms {:.6}; scipy kp {kp_ref:.6} ki {ki_ref:.6}",
            r.params[0], r.params[1], r.loops[0].ms
        );
        assert!(
            r.feasible && r.loops[0].ms <= 1.4 * (1.0 + 1e-6),
            "{name}: {:?}",
            r.goals
        );
        assert!(
            r.params[1] >= 0.99 * ki_ref,
            "{name}: ki {} vs reference {ki_ref}",
            r.params[1]
        );
        assert!(
            r.params[1] <= 1.002 * ki_ref,
            "{name}: ki {} above the reference {ki_ref}",
            r.params[1]
        );
    }
}

/// The same for a PID with a tuned derivative filter, C = kp + ki/s + kd·s/(tf·s + 1), against
/// tools/gen_migo_pid.py (scipy multi-start SLSQP with cutting planes on the exact |S|). Both keep
/// the filter within three decades above the ultimate frequency (tf ≥ 1e-3/ω_u): without that
/// floor the supremum is the ideal PID, and before the floor our tuner drove tf to 1e-10 and its
/// check reported Ms = 1.0000 for loops whose Ms was 1.43.
#[test]
fn pid_integral_gain_matches_the_scipy_optimum() {
    for c in skyloop_fixtures::cases(env!("CARGO_MANIFEST_DIR"), "tests/fixtures/migo/pid_ms14.json") {
        let name = c["name"].as_str().unwrap();
        let prob = LoopTuning {
            plants: vec![parse_model(c["plant"].as_str().unwrap()).unwrap()],
            structure: Structure::new(Block::Pid(DerivativeFilter::Tuned)),
            goals: vec![Goal::hard(Requirement::Ms, Bound::AtMost(1.4), "ms<=1.4")],
            objective: Objective::MaximizeIntegralGain,
            options: TuneOptions {
                starts: 4,
                ..Default::default()
            },
        };
        let r = tune_loop(&prob).unwrap();
        let ki_ref = c["ki"].as_f64().unwrap();
        eprintln!(
            "{name}: ours kp {:.6} ki {:.6} kd {:.6} tf {:.3e} Ms {:.6}; scipy ki {ki_ref:.6}",
            r.params[0],
            r.params[1],
            r.params[2],
            r.params[3].exp(),
            r.loops[0].ms
        );
        assert!(
            r.feasible && r.loops[0].ms <= 1.4 * (1.0 + 1e-6),
            "{name}: {:?}",
            r.goals
        );
        // The filter floor (tf ≥ 1e-3/ω_u, ω_u from a 600-point grid here) holds to 2 %.
        assert!(
            r.params[3].exp() >= 0.98 * c["tf_floor"].as_f64().unwrap(),
            "{name}: tf {} below the floor",
            r.params[3].exp()
        );
        // 1 % below the optimum, or a documented case's own fraction (the fixture says why).
        let lo = c["ki_min_fraction"].as_f64().unwrap_or(0.99);
        assert!(
            r.params[1] >= lo * ki_ref,
            "{name}: ki {} vs reference {ki_ref}",
            r.params[1]
        );
        assert!(
            r.params[1] <= 1.002 * ki_ref,
            "{name}: ki {} above the reference {ki_ref}",
            r.params[1]
        );
    }
}
