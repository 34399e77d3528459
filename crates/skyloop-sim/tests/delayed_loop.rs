#![allow(clippy::unwrap_used)] // a panic is how a test reports failure
//! The exact-delay closed-loop step against independent references: the method of steps in closed
//! form for an integrator with delay, and a high-order Padé closed loop for the bicopter paper's loop.

use skyloop_lti::expr::parse_model;
use skyloop_lti::interconnect::feedback;
use skyloop_lti::StateSpace;
use skyloop_sim::delayed_loop::closed_loop_step;

/// y' = 1 − y(t − τ) from rest: y = 0 on [0, τ], t − τ on [τ, 2τ], and on [2τ, 3τ]
/// y = (t − τ) − (t − 2τ)²/2 (method of steps).
#[test]
fn integrator_with_delay_matches_the_method_of_steps() {
    let tau = 0.1;
    let l = parse_model("exp(-0.1*s)/s").unwrap();
    let t: Vec<f64> = (0..=300).map(|k| k as f64 * 0.001).collect();
    let y = closed_loop_step(&l, &t).unwrap();
    for (k, &tk) in t.iter().enumerate() {
        let want = if tk <= tau {
            0.0
        } else if tk <= 2.0 * tau {
            tk - tau
        } else {
            (tk - tau) - (tk - 2.0 * tau).powi(2) / 2.0
        };
        // The error signal is held over each inner step δ = 1 ms: on [2τ, 3τ] it is a ramp, so the
        // hold lags by δ/2 and y by (t − 2τ)·δ/2 ≤ 5e-5.
        assert!((y[k] - want).abs() < 6e-5, "t = {tk}: {} vs {want}", y[k]);
    }
}

/// The bicopter roll-rate loop L = P·C (paper eq. (8) and (12)) with its 32 ms delay: nothing moves
/// before the delay has passed (a Padé closed loop does: 1.2e-3 at 32 ms even at order 20, 1e-2 at
/// order 10), and from 0.1 s on the exact-delay response agrees with the order-20 Padé closed loop
/// to 5e-4 (measured 1.5e-4; it falls with the Padé order: 3.6e-3 at 6, 1.9e-4 at 10).
#[test]
fn bicopter_loop_matches_a_high_order_pade_closed_loop() {
    let l = parse_model(
        "0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2-s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5) * \
         24.02*(s+54.01)*(s+0.2474)*(s^2+139.3*s+2.624e4) / (s*(s^2+24.14*s+8544)*(s^2+232.4*s+7.041e4))",
    )
    .unwrap();
    let t: Vec<f64> = (0..=2000).map(|k| k as f64 * 0.001).collect();
    let y = closed_loop_step(&l, &t).unwrap();
    let unity = StateSpace::gain(skyloop_lti::Mat::identity(1, 1), 0.0).unwrap();
    let cl = feedback(&l.try_pade(20).unwrap(), &unity, -1.0).unwrap();
    let r = skyloop_lti::timeresp::step(&cl, Some(&t)).unwrap();
    for (k, tk) in t.iter().enumerate() {
        if *tk < 0.032 - 1e-12 {
            assert_eq!(y[k], 0.0, "y({tk}) before the delay");
        }
    }
    let worst = (100..t.len()).map(|k| (y[k] - r.y[0][0][k]).abs()).fold(0.0, f64::max);
    assert!(worst < 5e-4, "max deviation after 0.1 s: {worst}");
    // It is the tracking loop of a stable design: it settles at the reference.
    assert!((y[2000] - 1.0).abs() < 0.05, "y(2 s) = {}", y[2000]);
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let l = parse_model("exp(-0.1*s)/s").unwrap();
    assert!(closed_loop_step(&l, &[0.0]).is_err());
    assert!(closed_loop_step(&l, &[0.1, 0.2]).is_err());
    assert!(closed_loop_step(&l, &[0.0, 0.1, 0.3]).is_err());
    let mimo = parse_model("1/(s+1)").unwrap();
    let two = skyloop_lti::interconnect::append(&mimo, &mimo).unwrap();
    assert!(closed_loop_step(&two, &[0.0, 0.1]).is_err());
    // An absurd horizon is refused by its step count, not run.
    let t: Vec<f64> = vec![0.0, 1e9, 2e9];
    assert!(closed_loop_step(&parse_model("exp(-1e-6*s)/(s+1)").unwrap(), &t).is_err());
}
