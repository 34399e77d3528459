//! hinfsyn against SLICOT sb10ad (python-control) on random generalized plants, plus ill-posed inputs.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use serde_json::Value;
use skyloop_lti::json::LtiJson;
use skyloop_lti::{Mat, StateSpace};
use skyloop_robust::hinfsyn::{hinfsyn, hinfsyn_with, HinfOptions};
use skyloop_robust::RobustError;

fn fixture(name: &str) -> Value {
    skyloop_fixtures::load(env!("CARGO_MANIFEST_DIR"), &format!("tests/fixtures/hinf/{name}"))
}

fn plant(v: &Value) -> StateSpace {
    let j: LtiJson = serde_json::from_value(v.clone()).expect("lti json");
    j.to_ss().expect("valid plant")
}

fn max_re(a: &Mat<f64>) -> f64 {
    a.eigenvalues()
        .expect("eig")
        .iter()
        .map(|l| l.re)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Fixture tools/gen_hinf.py: gamma within 1 % of SLICOT's, and our controller meets its own gamma.
#[test]
fn matches_slicot_on_random_plants() {
    let f = fixture("hinfsyn_random.json");
    let cases = f["cases"].as_array().expect("cases");
    assert!(cases.len() >= 8);
    for c in cases {
        let name = c["name"].as_str().expect("name");
        let p = plant(&c["plant"]);
        let nmeas = c["nmeas"].as_u64().expect("nmeas") as usize;
        let ncon = c["ncon"].as_u64().expect("ncon") as usize;
        let g_ref = c["gamma_slicot"].as_f64().expect("gamma");
        let sol = hinfsyn(&p, nmeas, ncon).unwrap_or_else(|e| panic!("{name}: {e}"));
        let rel = (sol.gamma - g_ref) / g_ref;
        // Never worse than SLICOT by more than 1 %; being better than sb10ad's gamma is allowed
        // only down to the bisection's proven lower bound.
        assert!(rel < 1e-2, "{name}: gamma {} vs slicot {g_ref}", sol.gamma);
        assert!(
            rel > -1e-2,
            "{name}: gamma {} suspiciously below slicot {g_ref}",
            sol.gamma
        );
        assert!(
            sol.gamma_lower <= g_ref * (1.0 + 1e-6),
            "{name}: infeasible bound above slicot's gamma"
        );
        assert!(max_re(&sol.closed_loop.a) < 0.0, "{name}: closed loop unstable");
        assert!(sol.closed_loop_norm <= sol.gamma * (1.0 + 1e-3), "{name}");
        assert_eq!((sol.controller.ny(), sol.controller.nu()), (ncon, nmeas));
    }
}

fn simple_plant(d12: f64, d21: f64) -> StateSpace {
    // P = [A B1 B2; C1 D11 D12; C2 D21 D22] with an unstable first-order G = 1/(s − 1).
    StateSpace::from_rows(
        &[vec![1.0]],
        &[vec![1.0, 1.0]],
        &[vec![1.0], vec![1.0]],
        &[vec![0.0, d12], vec![d21, 0.0]],
        0.0,
    )
    .expect("plant")
}

#[test]
fn rank_deficient_d12_is_a_clear_error() {
    let e = hinfsyn(&simple_plant(0.0, 1.0), 1, 1).unwrap_err();
    assert!(
        matches!(e, RobustError::RankDeficient { matrix: "D12", sigma_min } if sigma_min.abs() < 1e-12),
        "{e}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("D12 is rank deficient") && msg.contains("smallest singular value"),
        "{msg}"
    );
}

#[test]
fn rank_deficient_d21_is_a_clear_error() {
    let e = hinfsyn(&simple_plant(1.0, 0.0), 1, 1).unwrap_err();
    assert!(
        matches!(e, RobustError::RankDeficient { matrix: "D21", sigma_min } if sigma_min.abs() < 1e-12),
        "{e}"
    );
    assert!(e.to_string().contains("sensor-noise weight"), "{e}");
}

/// A nearly (not exactly) singular D12: σ_min is reported as the value it has.
#[test]
fn rank_deficient_d12_reports_its_sigma_min() {
    let e = hinfsyn(&simple_plant(1e-12, 1.0), 1, 1).unwrap_err();
    match e {
        RobustError::RankDeficient { matrix, sigma_min } => {
            assert_eq!(matrix, "D12");
            assert!((sigma_min - 1e-12).abs() < 1e-15, "{sigma_min}");
        }
        other => panic!("expected RankDeficient, got {other}"),
    }
}

#[test]
fn unstabilizable_plant_is_a_clear_error() {
    // Second state unstable and not reached by u (B2 column zero there).
    let p = StateSpace::from_rows(
        &[vec![-1.0, 0.0], vec![0.0, 2.0]],
        &[vec![1.0, 1.0], vec![1.0, 0.0]],
        &[vec![1.0, 1.0], vec![1.0, 1.0]],
        &[vec![0.0, 1.0], vec![1.0, 0.0]],
        0.0,
    )
    .expect("plant");
    let e = hinfsyn(&p, 1, 1).unwrap_err();
    match &e {
        RobustError::NotStabilizable { system, mode } => {
            assert_eq!(*system, "(A, B2)");
            assert!((mode.re - 2.0).abs() < 1e-9 && mode.im.abs() < 1e-9, "{mode}");
        }
        other => panic!("expected NotStabilizable, got {other}"),
    }
    let msg = e.to_string();
    assert!(
        msg.contains("not stabilizable") && msg.contains("2.000000+0.000000i"),
        "{msg}"
    );
}

#[test]
fn undetectable_plant_is_a_clear_error() {
    // Second state unstable and not seen by y (C2 is zero there); both states reached by u.
    let p = StateSpace::from_rows(
        &[vec![-1.0, 0.0], vec![0.0, 2.0]],
        &[vec![1.0, 1.0], vec![1.0, 1.0]],
        &[vec![1.0, 1.0], vec![1.0, 0.0]],
        &[vec![0.0, 1.0], vec![1.0, 0.0]],
        0.0,
    )
    .expect("plant");
    let e = hinfsyn(&p, 1, 1).unwrap_err();
    match &e {
        RobustError::NotDetectable { system, mode } => {
            assert_eq!(*system, "(C2, A)");
            assert!((mode.re - 2.0).abs() < 1e-9 && mode.im.abs() < 1e-9, "{mode}");
        }
        other => panic!("expected NotDetectable, got {other}"),
    }
    assert!(e.to_string().contains("not detectable"), "{e}");
}

/// An upper end of the γ range is a hard bound: below the optimum the synthesis fails with
/// `Infeasible` at that γ, and just above the optimum the returned γ never exceeds it (or the
/// synthesis fails as infeasible), however much the controller's back-off would like to.
#[test]
fn gamma_upper_bound_is_hard() {
    let f = fixture("hinfsyn_random.json");
    let p = plant(&f["cases"][0]["plant"]);
    let opt = hinfsyn(&p, 1, 1).expect("unbounded synthesis").gamma;
    let below = HinfOptions {
        gamma_range: (0.0, 0.5 * opt),
        ..HinfOptions::default()
    };
    let e = hinfsyn_with(&p, 1, 1, &below).unwrap_err();
    assert!(
        matches!(e, RobustError::Infeasible { gamma, .. } if gamma == 0.5 * opt),
        "{e}"
    );
    assert!(e.to_string().contains("gamma"), "{e}");
    for factor in [1.0002, 1.0005, 1.002, 1.1] {
        let bound = factor * opt / (1.0 + 1e-3);
        let opts = HinfOptions {
            gamma_range: (0.0, bound),
            ..HinfOptions::default()
        };
        match hinfsyn_with(&p, 1, 1, &opts) {
            Ok(sol) => {
                assert!(sol.gamma <= bound, "gamma {} above the bound {bound}", sol.gamma);
                assert!(sol.closed_loop_norm <= sol.gamma * (1.0 + 1e-3));
            }
            Err(RobustError::Infeasible { gamma, .. }) => assert!(gamma <= bound, "{gamma} > {bound}"),
            Err(e) => panic!("factor {factor}: {e}"),
        }
    }
}

#[test]
fn gamma_range_without_solution_is_an_error() {
    let p = simple_plant(1.0, 1.0);
    let opts = HinfOptions {
        gamma_range: (0.0, 0.5),
        ..HinfOptions::default()
    };
    assert!(matches!(
        hinfsyn_with(&p, 1, 1, &opts),
        Err(RobustError::Infeasible { gamma, .. }) if gamma == 0.5
    ));
    assert!(matches!(hinfsyn(&p, 0, 1), Err(RobustError::InvalidArgument(_))));
    assert!(matches!(hinfsyn(&p, 2, 1), Err(RobustError::Dimension(_))));
}

/// The discrete path against the continuous one: Tustin (skyloop-lti c2d) maps closed loops onto
/// closed loops with the same H∞ norm, so the discrete γ equals the continuous γ of the same
/// SLICOT fixture plant, and the discrete closed loop meets it (checked with the discrete hinf_norm).
#[test]
fn discrete_plant_via_bilinear_map() {
    let f = fixture("hinfsyn_random.json");
    let c = &f["cases"][1];
    let p = plant(&c["plant"]);
    let cont = hinfsyn(&p, 1, 1).expect("continuous");
    let tustin = skyloop_lti::discretize::Method::Tustin { prewarp_rad_s: None };
    let pd = skyloop_lti::discretize::c2d(&p, 0.01, tustin).expect("discrete plant");
    let disc = hinfsyn(&pd, 1, 1).expect("discrete");
    assert!(
        (disc.gamma - cont.gamma).abs() < 2e-3 * cont.gamma,
        "{} vs {}",
        disc.gamma,
        cont.gamma
    );
    assert_eq!(disc.controller.dt, 0.01);
    let ev = disc.closed_loop.a.eigenvalues().expect("eig");
    assert!(ev.iter().all(|l| l.norm() < 1.0));
    let (norm, _) = skyloop_lti::norms::hinf_norm(&disc.closed_loop).expect("norm");
    assert!(norm <= disc.gamma * (1.0 + 1e-3), "{norm} > {}", disc.gamma);
    // A discrete plant with a pole at z = −1 has no Tustin preimage: a clear error.
    let mut bad = pd.clone();
    bad.a = -Mat::<f64>::identity(pd.nx(), pd.nx());
    let e = hinfsyn(&bad, 1, 1).expect_err("pole at z = -1");
    assert!(e.to_string().contains("z = -1"), "{e}");
}
