//! Linearization checks against the papers' closed forms.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use num_complex::Complex64 as C;
use skyloop_sim::linear_models::{self, SsiLoop};
use skyloop_sim::rigid::{External, MAXS};
use skyloop_sim::{linearize, VehicleSpec};

#[test]
fn trim_points_are_equilibria() {
    for name in skyloop_sim::presets::NAMES {
        let v = skyloop_sim::presets::vehicle(name)
            .expect("preset")
            .build()
            .expect("valid");
        let (x, u) = v.trim_hover(5.0, 0.3);
        let mut dx = [0.0; MAXS];
        v.derivative(&x, &u, &External::default(), &mut dx);
        let worst = dx[..v.nx()].iter().fold(0.0f64, |m, d| m.max(d.abs()));
        assert!(worst < 1e-9, "{name}: trim residual {worst}");
    }
}

/// Eq. (5) of the bicopter paper: roll rate / servo angle = (GH − Im·s²)/((Ib + Im)·s), checked as
/// G_p,cmd(jω) / G_δ,cmd(jω) of the linearized nonlinear model (collective servo command).
#[test]
fn bicopter_linearization_reproduces_eq5() {
    let spec = skyloop_sim::presets::vehicle("bicopter-li").expect("preset");
    let VehicleSpec::Bicopter(p) = spec else {
        panic!("bicopter")
    };
    let v = spec.build().expect("valid");
    let (x0, u0) = v.trim_hover(10.0, 0.0);
    let lin = linearize(&v, &x0, &u0).expect("linearize");
    let (ip, id) = (lin.output("p_rad_s").expect("p"), lin.output("delta1_rad").expect("d"));
    let (s1, s2) = (
        lin.input("servo1_cmd").expect("s1"),
        lin.input("servo2_cmd").expect("s2"),
    );
    // the servo delay of eq. (6)/(8) is kept exactly as an input delay
    assert_eq!(lin.ss.input_delay[s1], p.servo_delay_s);
    let gh = p.body.mass_kg * skyloop_sim::rigid::G * p.h_m;
    let w = [0.3, 2.0, 10.0, 41.0, 42.0, 43.0, 100.0, 400.0];
    let resp = skyloop_lti::freqresp::freqresp(&lin.ss, &w).expect("freqresp");
    for (k, g) in resp.iter().enumerate() {
        let gp = g[(ip, s1)] + g[(ip, s2)];
        let gd = g[(id, s1)] + g[(id, s2)];
        let s = C::new(0.0, w[k]);
        let eq5 = (C::new(gh, 0.0) - s * s * p.im_kg_m2) / (s * (p.ib_kg_m2 + p.im_kg_m2));
        let rel = ((gp / gd) - eq5).norm() / eq5.norm();
        assert!(rel < 1e-6, "w = {} rad/s: relative error {rel:e}", w[k]);
    }
    // the RHP zero √(GH/Im) is the identified 42 rad/s of eq. (8) (the preset is built from it)
    assert!(((gh / p.im_kg_m2).sqrt() - 42.0).abs() < 1e-9);
}

fn charpoly3(a: &faer::Mat<f64>) -> [f64; 4] {
    // det(sI − A) for 3×3: s³ − tr·s² + (sum of principal 2×2 minors)·s − det.
    let m = |i: usize, j: usize| a[(i, j)];
    let tr = m(0, 0) + m(1, 1) + m(2, 2);
    let minors = m(0, 0) * m(1, 1) - m(0, 1) * m(1, 0) + m(0, 0) * m(2, 2) - m(0, 2) * m(2, 0) + m(1, 1) * m(2, 2)
        - m(1, 2) * m(2, 1);
    let det = m(0, 0) * (m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1)) - m(0, 1) * (m(1, 0) * m(2, 2) - m(1, 2) * m(2, 0))
        + m(0, 2) * (m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0));
    [1.0, -tr, minors, -det]
}

/// SSI-PI around the linearized quadrotor's roll axis: characteristic polynomial of eq. (32); for
/// Jm = J the factorization (s + Ki)(s² + (Kp/J)s + Kp/J) of eq. (33).
#[test]
fn ssi_pi_closed_loop_has_eq32_and_eq33() {
    let v = skyloop_sim::presets::vehicle("quadrotor-ssi")
        .expect("preset")
        .build()
        .expect("valid");
    let roll = linear_models::quad_roll_axis(&v).expect("roll axis");
    let j = v.inertia()[0];
    // the residualized roll axis is θ̇ = p, J·ṗ = Mx (eq. (24))
    assert!((roll.ss.b[(1, 0)] - 1.0 / j).abs() < 1e-6 / j, "{}", roll.ss.b[(1, 0)]);
    for (kp, ki, frac) in [(0.1, 20.0, 1.0), (0.1, 20.0, 0.5), (0.05, 5.0, 1.0), (0.3, 40.0, 0.2)] {
        let c = SsiLoop {
            kp,
            ki,
            jm: frac * j,
            k_att: 1.0,
        };
        let cl = linear_models::ssi_closed_loop(&roll, "roll_rad", "p_rad_s", "mx_n_m", c).expect("loop");
        let got = charpoly3(&cl.a);
        let want = linear_models::eq32_charpoly(j, c);
        for i in 0..4 {
            assert!(
                (got[i] - want[i]).abs() <= 1e-6 * want[i].abs(),
                "Kp {kp} Ki {ki} Jm/J {frac}: {got:?} vs {want:?}"
            );
        }
        if frac == 1.0 {
            // (s + Ki)(s² + (Kp/J)s + Kp/J) expanded independently
            let (a, b) = (kp / j, kp / j);
            let eq33 = [1.0, a + ki, b + ki * a, ki * b];
            for i in 0..4 {
                assert!((got[i] - eq33[i]).abs() <= 1e-6 * eq33[i].abs());
            }
            let poles = linear_models::eigenvalues(&cl.a).expect("eig");
            assert!(
                poles.iter().any(|p| (p - C::new(-ki, 0.0)).norm() < 1e-6 * ki),
                "{poles:?}"
            );
        }
    }
}

/// Routh condition (35) against the closed-loop eigenvalues over a grid of gains and Jm/J.
#[test]
fn routh_condition_eq35_matches_eigenvalues() {
    let v = skyloop_sim::presets::vehicle("quadrotor-ssi")
        .expect("preset")
        .build()
        .expect("valid");
    let roll = linear_models::quad_roll_axis(&v).expect("roll axis");
    let j = v.inertia()[0];
    let (mut stable, mut unstable) = (0, 0);
    for kp in [0.0005, 0.002, 0.01, 0.1] {
        for ki in [0.5, 2.0, 10.0, 50.0] {
            for frac in [-0.5, -0.2, 0.0, 0.05, 0.2, 0.5, 1.0, 2.0] {
                let c = SsiLoop {
                    kp,
                    ki,
                    jm: frac * j,
                    k_att: 1.0,
                };
                let cl = linear_models::ssi_closed_loop(&roll, "roll_rad", "p_rad_s", "mx_n_m", c).expect("loop");
                let poles = linear_models::eigenvalues(&cl.a).expect("eig");
                let max_re = poles.iter().fold(f64::NEG_INFINITY, |m, p| m.max(p.re));
                let routh = linear_models::routh_eq35(j, c);
                // stay away from the boundary where the sign of max Re is numerically ambiguous
                if max_re.abs() > 1e-7 {
                    assert_eq!(max_re < 0.0, routh, "Kp {kp} Ki {ki} Jm/J {frac}: max Re {max_re}");
                    if routh {
                        stable += 1
                    } else {
                        unstable += 1
                    }
                }
            }
        }
    }
    assert!(
        stable > 10 && unstable > 5,
        "grid must cover both sides: {stable} stable, {unstable} unstable"
    );
}
