//! The identification workflow on a simulated closed-loop rate-loop experiment with a known plant:
//! the two halves of one flight agree within their reported errors, the reported errors are at least
//! the jackknife's, and the held-out validation predicts the unseen blocks.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use std::path::PathBuf;

use skyloop::identify::{identify, IdentifyRequest, RATE_LOOP_MODEL};

const T: f64 = 0.002;
const K: f64 = 800.0;
const TAU: f64 = 0.03;
/// Input delay, samples.
const D: usize = 2;

struct Lcg(u64);
impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (a, b) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
    }
}

/// A 240 s flight of a rate loop at 500 Hz: plant a ← α·a + (1−α)·K·u[k−D], ω ← ω + T·a (motor lag
/// and the airframe's integrator; close to K·e^(−(D+1)T·s)/(s(τs+1)) in continuous time), a PD-like
/// controller u = kp·(r − ω_meas) fed by a noisy gyro, a pilot-like setpoint (random sticks held for
/// random times plus a broadband part) and torque turbulence. Written as CSV time_s,u,gyro,setpoint.
fn flight_csv() -> PathBuf {
    let alpha = (-T / TAU).exp();
    let kp = 0.05;
    let mut rng = Lcg(2024);
    let (mut a, mut w_rate) = (0.0, 0.0);
    let mut hist = [0.0; D + 1];
    let mut stick = 0.0;
    let mut hold = 0usize;
    let n = (240.0 / T) as usize;
    let mut s = String::with_capacity(n * 40);
    s.push_str("time_s,u,gyro,setpoint\n");
    for k in 0..n {
        if hold == 0 {
            stick = 200.0 * rng.normal();
            hold = 20 + (rng.uniform() * 200.0) as usize;
        }
        hold -= 1;
        let r = stick + 100.0 * rng.normal();
        let ym = w_rate + 20.0 * rng.normal();
        let u = kp * (r - ym);
        s.push_str(&format!("{},{u},{ym},{r}\n", k as f64 * T));
        hist.rotate_right(1);
        hist[0] = u;
        w_rate += T * a;
        a = alpha * a + (1.0 - alpha) * K * hist[D] + T * 3000.0 * rng.normal();
    }
    let dir = std::env::temp_dir().join(format!("skyloop-identify-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("flight.csv");
    std::fs::write(&p, s).unwrap();
    p
}

fn request(data: &std::path::Path, from: Option<f64>, to: Option<f64>) -> IdentifyRequest {
    IdentifyRequest {
        data: data.to_path_buf(),
        input: Some("u".into()),
        output: Some("gyro".into()),
        excitation: Some("setpoint".into()),
        fmin_hz: Some(1.0),
        fmax_hz: Some(40.0),
        from,
        to,
        model: Some(RATE_LOOP_MODEL.into()),
        init: Some("K=500,tau=0.05,Td=0.01".into()),
        bounds: Some("K=0:,tau=0.0001:1,Td=0:0.1".into()),
        ..IdentifyRequest::default()
    }
}

#[test]
fn halves_of_one_flight_agree_within_their_reported_errors() {
    let p = flight_csv();
    let first = identify(&request(&p, None, Some(120.0))).unwrap();
    let second = identify(&request(&p, Some(120.0), None)).unwrap();
    let whole = identify(&request(&p, None, None)).unwrap();
    let (f1, f2, fw) = (
        &first.fit.as_ref().unwrap().1,
        &second.fit.as_ref().unwrap().1,
        &whole.fit.as_ref().unwrap().1,
    );
    for k in ["K", "tau", "Td"] {
        eprintln!(
            "{k}: halves {:.5} ± {:.5}, {:.5} ± {:.5}; whole {:.5} ± {:.5}",
            f1.params[k], f1.stderr[k], f2.params[k], f2.stderr[k], fw.params[k], fw.stderr[k]
        );
        let d = (f1.params[k] - f2.params[k]).abs();
        let se = (f1.stderr[k].powi(2) + f2.stderr[k].powi(2)).sqrt();
        assert!(
            d < 3.0 * se,
            "{k}: halves {} ± {} and {} ± {} differ by {d}, more than 3 × {se}",
            f1.params[k],
            f1.stderr[k],
            f2.params[k],
            f2.stderr[k]
        );
        // The reported error is the larger of the model-based and the jackknife one.
        let u = whole.uncertainty.as_ref().unwrap();
        assert_eq!(u.blocks_used, 8);
        assert!(
            fw.stderr[k] >= u.model_stderr[k] && fw.stderr[k] >= u.jackknife_stderr[k],
            "{k}"
        );
    }
    // The plant is known: K exactly, τ exactly, the delay D·T plus a sample of the discrete
    // integrator and lag (half a sample each, from their zero-order holds).
    let want = [("K", K), ("tau", TAU), ("Td", (D + 1) as f64 * T)];
    for (k, v) in want {
        let (x, se) = (fw.params[k], fw.stderr[k]);
        assert!((x - v).abs() < 4.0 * se + 0.03 * v, "{k} = {x} ± {se}, truth {v}");
    }
    let v = whole.validation.as_ref().unwrap();
    eprintln!("validation {v:?}, uncertainty {:?}", whole.uncertainty);
    assert!(v.fit_percent > 80.0 && v.frf_residual < 0.3, "{v:?}");
    assert!(whole.warnings.is_empty(), "{:?}", whole.warnings);
    assert!(fw.converged && fw.at_bounds.is_empty());
}
