//! The ducted fan of Pross ("H∞ and μ-synthesis of a ducted-fan VTOL micro-UAV"): its hover linearization at
//! yaw 45° against partial derivatives of eq. (3)–(4) worked out by hand, the actuator/body split
//! of Section II-D, and the linear outputs measured on the nonlinear state.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use skyloop_lti::freqresp::evalfr;
use skyloop_lti::{c64, interconnect};
use skyloop_sim::linear_models::actuator_split;
use skyloop_sim::linearize::{linearize, output_deviation};
use skyloop_sim::rigid::{AUX, G, MAXS, QUAT, RATE, VEL};
use skyloop_sim::vehicle::{DuctedFanParams, Vehicle};
use std::f64::consts::{FRAC_PI_4, PI};

fn fan() -> (Vehicle, DuctedFanParams) {
    let spec = skyloop_sim::presets::ducted_fan_pross();
    let v = skyloop_sim::VehicleSpec::DuctedFan(spec).build().expect("valid preset");
    (v, spec)
}

const ACT: [&str; 9] = [
    "alpha1_rad",
    "alpha2_rad",
    "alpha3_rad",
    "alpha4_rad",
    "alpha1_dot_rad_s",
    "alpha2_dot_rad_s",
    "alpha3_dot_rad_s",
    "alpha4_dot_rad_s",
    "omega_rad_s",
];
const DRIVE: [&str; 5] = ["alpha1_rad", "alpha2_rad", "alpha3_rad", "alpha4_rad", "omega_rad_s"];

#[test]
fn hover_linearization_matches_hand_derived_partials() {
    let (v, p) = fan();
    let psi = FRAC_PI_4;
    let (x0, u0) = v.trim_hover(10.0, psi);
    let lin = linearize(&v, &x0, &u0).expect("linearizes");
    let (act, body) = actuator_split(&lin, &ACT, &DRIVE).expect("splits");
    let a = &body.ss.a;
    let b = &body.ss.b;
    let m = p.body.mass_kg;
    let [jx, jy, jz] = p.body.inertia_kg_m2;
    let w0 = x0[AUX + 8];
    // eq. (3): ν² = ω²·kT/(π²·2aϱ); flap force per unit coefficient ½ϱSν².
    let qs = 0.5 * p.rho_kg_m3 * p.s_m2 * w0 * w0 * p.kt / (PI * PI * 2.0 * p.a_m * p.rho_kg_m3);
    let lift = qs * p.cl;
    let close = |got: f64, want: f64, what: &str| {
        assert!(
            (got - want).abs() <= 1e-6 * want.abs().max(1e-3),
            "{what}: linearization {got}, hand-derived {want}"
        );
    };
    let (s, c) = psi.sin_cos();
    // eq. (4a): flap 1 lifts along body +x, rotated into NED by the 45° yaw.
    close(b[(3, 0)], lift * c / m, "dvx/dalpha1");
    close(b[(4, 0)], lift * s / m, "dvy/dalpha1");
    // flap 2 along body +y.
    close(b[(3, 1)], -lift * s / m, "dvx/dalpha2");
    close(b[(4, 1)], lift * c / m, "dvy/dalpha2");
    // eq. (4b): d·ẑ × n̂ gives pitch from flap 1, roll (negative) from flap 2; the per-flap lever
    // (a/3)·t̂ gives yaw from every flap.
    close(b[(10, 0)], lift * p.d_m / jy, "dq/dalpha1");
    close(b[(9, 1)], -lift * p.d_m / jx, "dp/dalpha2");
    close(b[(11, 0)], lift * p.a_m / 3.0 / jz, "dr/dalpha1");
    // Vertical: d/dω of (−kT·ω² + 4·c0·½ϱSν²) along NED z.
    close(
        b[(5, 4)],
        (-2.0 * p.kt * w0 + 4.0 * p.c0 * 2.0 * qs / w0) / m,
        "dvz/domega",
    );
    // Gravity tilt: pitching the thrust by ξ_y accelerates along the body −x axis.
    close(a[(3, 7)], -G * c, "dvx/dpitch");
    close(a[(4, 7)], -G * s, "dvy/dpitch");
    close(a[(3, 6)], -G * s, "dvx/droll");
    close(a[(4, 6)], G * c, "dvy/droll");
    // Gyroscopic torque ω·Jr·(ẑ × Ω) couples p and q.
    close(a[(9, 10)], -p.jr_kg_m2 * w0 / jx, "dp/dq");
    close(a[(10, 9)], p.jr_kg_m2 * w0 / jy, "dq/dp");
    // Section II-D actuators: flaps ωn²/(s + ωn)², propeller 1/(τs + 1).
    for w in [0.3, 7.0, 60.0] {
        let g = evalfr(&act.ss, c64::new(0.0, w)).expect("evaluates");
        let s = c64::new(0.0, w);
        let wn = p.flap_wn_rad_s;
        let flap = c64::new(wn * wn, 0.0) / ((s + wn) * (s + wn));
        let prop = c64::new(1.0, 0.0) / (s * p.prop_tau_s + 1.0);
        assert!((g[(0, 0)] - flap).norm() < 1e-9 && g[(0, 1)].norm() < 1e-12);
        assert!((g[(4, 4)] - prop).norm() < 1e-9);
    }
}

#[test]
fn split_in_series_reproduces_the_full_linearization() {
    let (v, _) = fan();
    let (x0, u0) = v.trim_hover(10.0, FRAC_PI_4);
    let lin = linearize(&v, &x0, &u0).expect("linearizes");
    let (act, body) = actuator_split(&lin, &ACT, &DRIVE).expect("splits");
    assert_eq!((body.ss.nx(), body.ss.nu(), body.ss.ny()), (12, 5, 12));
    assert_eq!(body.outputs[..3], ["x_m", "y_m", "z_m"]);
    let both = interconnect::series(&act.ss, &body.ss).expect("series");
    for w in [0.05, 1.0, 20.0] {
        let s = c64::new(0.0, w);
        let g1 = evalfr(&both, s).expect("eval");
        let g0 = evalfr(&lin.ss, s).expect("eval");
        // Relative to the largest gain: entries that are exactly zero (ω → x) pick up rounding from
        // the rigid-body double integrators (gain 1/ω²) in the frequency-response evaluation.
        let scale = (0..12)
            .flat_map(|i| (0..5).map(move |j| (i, j)))
            .fold(0.0f64, |m, (i, j)| m.max(g0[(i, j)].norm()));
        for i in 0..12 {
            for j in 0..5 {
                let d = (g1[(i, j)] - g0[(i, j)]).norm();
                assert!(
                    d <= 1e-9 * g0[(i, j)].norm() + 1e-12 * scale,
                    "({i},{j}) at {w} rad/s: {d}"
                );
            }
        }
    }
    // A state that is not an actuator state cannot be a drive signal.
    assert!(actuator_split(&lin, &ACT, &["x_m"]).is_err());
    assert!(actuator_split(&lin, &["nope"], &[]).is_err());
}

#[test]
fn linear_model_predicts_the_nonlinear_derivative() {
    // Finite-difference check of the Jacobian against the nonlinear model: for a small perturbation δ
    // of the trim state, the measured outputs' derivatives match A·δ to second order in δ.
    let (v, _) = fan();
    let (x0, u0) = v.trim_hover(10.0, FRAC_PI_4);
    let lin = linearize(&v, &x0, &u0).expect("linearizes");
    let n = lin.ss.nx();
    for scale in [1e-3, 1e-4] {
        let mut x = x0;
        x[VEL] += 0.7 * scale;
        x[RATE + 1] += -0.5 * scale;
        x[AUX] += 0.9 * scale;
        x[AUX + 8] += 40.0 * scale;
        let q = skyloop_sim::geometry::qmul(
            [x0[QUAT], x0[QUAT + 1], x0[QUAT + 2], x0[QUAT + 3]],
            skyloop_sim::geometry::qexp([0.3 * scale, -0.6 * scale, 0.2 * scale]),
        );
        x[QUAT..QUAT + 4].copy_from_slice(&q);
        let dxi = output_deviation(&v, &x0, &x, &u0);
        let mut f = [0.0; MAXS];
        v.derivative(&x, &u0, &Default::default(), &mut f);
        let pred: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| lin.ss.a[(i, j)] * dxi[j]).sum())
            .collect();
        // velocity and rate rows of the state derivative.
        let mut worst: f64 = 0.0;
        for (row, full) in [
            (3, VEL),
            (4, VEL + 1),
            (5, VEL + 2),
            (9, RATE),
            (10, RATE + 1),
            (11, RATE + 2),
        ] {
            worst = worst.max((pred[row] - f[full]).abs());
        }
        let size = pred.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            worst < 50.0 * scale * size,
            "scale {scale}: error {worst} vs size {size}"
        );
    }
}
