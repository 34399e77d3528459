//! skyloop-control against scipy references (tools/gen_control.py → tests/fixtures/control/control.json).
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use skyloop_control::*;

fn fixture() -> serde_json::Value {
    skyloop_fixtures::load(env!("CARGO_MANIFEST_DIR"), "tests/fixtures/control/control.json")
}

fn vec(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn mat(v: &serde_json::Value) -> Vec<f64> {
    v.as_array().expect("array").iter().flat_map(vec).collect()
}

fn max_rel_err(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-300);
    a.iter().zip(b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / scale
}

#[test]
fn hinf_state_space_matches_dlsim() {
    let f = &fixture()["hinf_bicopter"];
    let (a, b, c, d) = (mat(&f["a"]), mat(&f["b"]), mat(&f["c"]), mat(&f["d"]));
    let mut k = SsController::<f64, 5, 1, 1>::new(5, 1, 1, &a, &b, &c, &d).expect("valid");
    let e = vec(&f["input"]);
    let y: Vec<f64> = e.iter().map(|&x| k.step_siso(x)).collect();
    let err = max_rel_err(&y, &vec(&f["output"]));
    assert!(err < 1e-10, "f64 state space vs scipy dlsim: {err}");
    // f32 on a microcontroller: same controller, single precision.
    let a32: Vec<f32> = a.iter().map(|&v| v as f32).collect();
    let b32: Vec<f32> = b.iter().map(|&v| v as f32).collect();
    let c32: Vec<f32> = c.iter().map(|&v| v as f32).collect();
    let d32: Vec<f32> = d.iter().map(|&v| v as f32).collect();
    let mut k32 = SsController::<f32, 5, 1, 1>::new(5, 1, 1, &a32, &b32, &c32, &d32).expect("valid");
    let y32: Vec<f64> = e.iter().map(|&x| k32.step_siso(x as f32) as f64).collect();
    let err32 = max_rel_err(&y32, &vec(&f["output"]));
    assert!(err32 < 1e-3, "f32 state space vs scipy dlsim: {err32}");
}

#[test]
fn hinf_sos_matches_dlsim() {
    let f = &fixture()["hinf_bicopter"];
    let secs: Vec<Biquad<f64>> = f["sos"]
        .as_array()
        .expect("sos")
        .iter()
        .map(|r| {
            let v = vec(r);
            // scipy rows are [b0 b1 b2 a0 a1 a2] with a0 = 1.
            assert!((v[3] - 1.0).abs() < 1e-15);
            Biquad {
                b0: v[0],
                b1: v[1],
                b2: v[2],
                a1: v[4],
                a2: v[5],
            }
        })
        .collect();
    let mut k = SosController::<f64, 4>::new(&secs, 1.0, -1e9, 1e9).expect("valid");
    let e = vec(&f["input"]);
    let y: Vec<f64> = e.iter().map(|&x| k.step(x)).collect();
    let err = max_rel_err(&y, &vec(&f["output"]));
    assert!(err < 1e-9, "SOS vs scipy dlsim: {err}");
    let secs32: Vec<Biquad<f32>> = secs
        .iter()
        .map(|q| Biquad {
            b0: q.b0 as f32,
            b1: q.b1 as f32,
            b2: q.b2 as f32,
            a1: q.a1 as f32,
            a2: q.a2 as f32,
        })
        .collect();
    let mut k32 = SosController::<f32, 4>::new(&secs32, 1.0, -1e9, 1e9).expect("valid");
    let y32: Vec<f64> = e.iter().map(|&x| k32.step(x as f32) as f64).collect();
    assert!(max_rel_err(&y32, &vec(&f["output"])) < 1e-3);
}

#[test]
fn pid_matches_discretized_parallel_form() {
    let f = &fixture()["pid"];
    let g = PidGains {
        tf_s: f["tf"].as_f64().expect("tf"),
        ..PidGains::new(
            f["kp"].as_f64().expect("kp"),
            f["ki"].as_f64().expect("ki"),
            f["kd"].as_f64().expect("kd"),
        )
    };
    let mut pid = Pid::new(g).expect("valid");
    let dt = f["dt"].as_f64().expect("dt");
    let (r, y) = (vec(&f["r"]), vec(&f["y"]));
    let u: Vec<f64> = r.iter().zip(&y).map(|(&r, &y)| pid.step(r, y, dt)).collect();
    let err = max_rel_err(&u, &vec(&f["u"]));
    assert!(err < 1e-10, "PID vs scipy: {err}");
}

#[test]
fn ssi_pi_matches_eq31() {
    let f = &fixture()["ssi_pi"];
    let g = SsiPiGains {
        kp: f["kp"].as_f64().expect("kp"),
        ki: f["ki"].as_f64().expect("ki"),
        jm: f["jm"].as_f64().expect("jm"),
        out_min: -1e9,
        out_max: 1e9,
        kt: 0.0,
    };
    let mut c = SsiPi::new(g).expect("valid");
    let dt = f["dt"].as_f64().expect("dt");
    let (wr, w) = (vec(&f["w_ref"]), vec(&f["w"]));
    let u: Vec<f64> = wr.iter().zip(&w).map(|(&r, &y)| c.step(r, y, dt)).collect();
    let err = max_rel_err(&u, &vec(&f["u"]));
    assert!(err < 1e-10, "SSI-PI vs scipy: {err}");
}

/// First-order plant y' = -y + u under a saturating integral controller: anti-windup shortens the
/// overshoot after a long saturation. Compared: no anti-windup (clamp at huge limit) vs each scheme.
fn overshoot_with(aw: AntiWindup<f64>) -> f64 {
    let g = PidGains {
        out_min: -1.0,
        out_max: 1.0,
        anti_windup: aw,
        ..PidGains::new(0.5, 2.0, 0.0)
    };
    let mut pid = Pid::new(g).expect("valid");
    let (dt, mut y, mut peak) = (1e-3, 0.0f64, 0.0f64);
    // setpoint 0.9 needs u = 0.9 (close to the limit), so the integral winds up while saturated.
    for _ in 0..20_000 {
        let u = pid.step(0.9, y, dt);
        y += dt * (-y + u);
        peak = peak.max(y);
    }
    peak - 0.9
}

#[test]
fn anti_windup_reduces_overshoot() {
    let none = overshoot_with(AntiWindup::Clamp);
    let cond = overshoot_with(AntiWindup::Conditional);
    let back = overshoot_with(AntiWindup::BackCalculation(5.0));
    assert!(none > 0.02, "the test case must wind up without anti-windup: {none}");
    assert!(
        cond < 0.5 * none && back < 0.5 * none,
        "none {none}, conditional {cond}, back-calc {back}"
    );
}

#[test]
fn hanus_conditioning_keeps_states_consistent() {
    // PI controller 1 + 1/s at dt = 0.01 by Tustin (closed form): x+ = x + dt·e, v = x + (1 + dt/2)·e
    // is the realization A=1, B=dt, C=1, D=1+dt/2 of (1 + dt/2)(z − 1) / (z − 1) + ... (a PI).
    let dt = 0.01;
    let mk = || SsController::<f64, 1, 1, 1>::new(1, 1, 1, &[1.0], &[dt], &[1.0], &[1.0 + dt / 2.0]).expect("ok");
    let mut plain = mk().with_limits(&[-1.0], &[1.0]).expect("ok");
    let mut hanus = mk()
        .with_limits(&[-1.0], &[1.0])
        .expect("ok")
        .with_hanus_aw()
        .expect("ok");
    for _ in 0..1000 {
        plain.step_siso(5.0);
        hanus.step_siso(5.0);
    }
    // Without conditioning the integrator state grows to 1000·dt·5 = 50. Conditioned, the update is
    // x⁺ = (A − B·C/D)·x + (B/D)·u_sat (Hanus), whose fixed point for A = C = 1 is x = u_sat = 1; after
    // 1000 steps the distance is (1 − dt/D)^1000 ≈ 5e-5 of the start.
    assert!((plain.state()[0] - 50.0).abs() < 1e-9);
    let contraction = (1.0f64 - dt / (1.0 + dt / 2.0)).powi(1000);
    assert!(
        (hanus.state()[0] - 1.0).abs() <= contraction * 1.0001,
        "{}",
        hanus.state()[0]
    );
    // back inside the linear range the conditioned controller leaves saturation immediately
    assert!(hanus.step_siso(-0.5) < 1.0);
    assert_eq!(plain.step_siso(-0.5), 1.0);
}

#[test]
fn bad_configurations_are_errors() {
    assert_eq!(
        SsController::<f64, 2, 1, 1>::new(3, 1, 1, &[0.0; 9], &[0.0; 3], &[0.0; 3], &[0.0]).err(),
        Some(ControlError::TooLarge("states", 3, 2))
    );
    assert!(SsController::<f64, 2, 1, 1>::new(2, 1, 1, &[0.0; 3], &[0.0; 2], &[0.0; 2], &[0.0]).is_err());
    assert_eq!(
        SsController::<f64, 2, 1, 1>::new(1, 1, 1, &[f64::NAN], &[0.0], &[0.0], &[0.0]).err(),
        Some(ControlError::NonFinite("A entries"))
    );
    let zero_d = SsController::<f64, 2, 1, 1>::new(1, 1, 1, &[1.0], &[1.0], &[1.0], &[0.0]).expect("ok");
    assert_eq!(zero_d.with_hanus_aw().err(), Some(ControlError::SingularFeedthrough));
    let g = PidGains {
        out_min: 1.0,
        out_max: -1.0,
        ..PidGains::new(1.0, 0.0, 0.0)
    };
    assert_eq!(Pid::new(g).err(), Some(ControlError::InvalidLimits));
    assert_eq!(
        Pid::new(PidGains::new(f64::INFINITY, 0.0, 0.0)).err(),
        Some(ControlError::NonFinite("kp"))
    );
    assert!(SosController::<f64, 1>::new(&[Biquad::default(); 2], 1.0, -1.0, 1.0).is_err());
    let s = SsiPiGains {
        kp: 1.0,
        ki: 1.0,
        jm: 1.0,
        out_min: 0.0,
        out_max: -1.0,
        kt: 0.0,
    };
    assert!(SsiPi::new(s).is_err());
}
