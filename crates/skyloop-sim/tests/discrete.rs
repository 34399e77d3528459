//! Runtime controllers built from an LTI model (Tustin via skyloop-lti c2d) reproduce scipy's
//! discretization of the bicopter's H∞ controller eq. (12) at 250 Hz (tools/gen_control.py fixture).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use skyloop_sim::runtime_controller;

const HINF_EQ12: &str = "24.02*(s+54.01)*(s+0.2474)*(s^2+139.3*s+26240)/(s*(s^2+24.14*s+8544)*(s^2+232.4*s+70410))";

fn fixture() -> (Vec<f64>, Vec<f64>) {
    let v = skyloop_fixtures::load(
        env!("CARGO_MANIFEST_DIR"),
        "../skyloop-control/tests/fixtures/control/control.json",
    );
    let get = |k: &str| skyloop_fixtures::f64s(&v["hinf_bicopter"][k]);
    (get("input"), get("output"))
}

fn rel(got: &[f64], want: &[f64]) -> f64 {
    let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    got.iter().zip(want).fold(0.0f64, |m, (g, w)| m.max((g - w).abs())) / scale
}

#[test]
fn state_space_and_sos_match_scipy_tustin() {
    let c = skyloop_lti::expr::parse_model(HINF_EQ12).expect("parses");
    let d = runtime_controller::discretize(&c, 1.0 / 250.0).expect("c2d");
    let (e, want) = fixture();
    let mut ss = runtime_controller::to_ss_controller::<8, 1, 1>(&d).expect("ss");
    let y: Vec<f64> = e.iter().map(|&x| ss.step_siso(x)).collect();
    assert!(rel(&y, &want) < 1e-8, "state space: {:e}", rel(&y, &want));
    let mut sos = runtime_controller::to_sos_controller::<4>(&d, -1e30, 1e30).expect("sos");
    assert_eq!(sos.len(), 3);
    let y: Vec<f64> = e.iter().map(|&x| sos.step(x)).collect();
    assert!(rel(&y, &want) < 1e-7, "sos: {:e}", rel(&y, &want));
}

#[test]
fn bad_controllers_are_errors() {
    let c = skyloop_lti::expr::parse_model("exp(-0.01*s)/(s+1)").expect("parses");
    assert!(runtime_controller::discretize(&c, 0.004).is_err());
    let c = skyloop_lti::expr::parse_model("1/(s+1)").expect("parses");
    assert!(runtime_controller::discretize(&c, -1.0).is_err());
    let d = runtime_controller::discretize(&c, 0.01).expect("ok");
    assert!(runtime_controller::discretize(&d, 0.02).is_err());
}
