//! Betaflight's gain mapping pinned to a flight log: on the testdata acro flight
//! (testdata/logs/btfl_all.bbl, session 4, Betaflight 4.2.8, roll P 35 I 75 D 35 d_min 27,
//! D-term BIQUAD 100 Hz) the logged PID terms are what the mapping says they are, from the logged
//! setpoint and gyro — so the plant (PID sum → gyroADC) and C_fb are in the same units.
//!
//! - axisP = PTERM_SCALE·P·(setpoint − gyroADC), a least-squares fit over the frames;
//! - axisD/gyroADC, a cross-spectral estimate at 10–44 Hz, is −DTERM_SCALE·d_min·jω·biquad(100 Hz):
//!   the D the firmware applies in flight is d_min, not d (d_min's boost is rare).
#![allow(clippy::unwrap_used)] // a panic is how a test reports failure

use skyloop::firmware::betaflight::{continuous, Gains, DTERM_SCALE};
use skyloop::firmware::Axis;
use skyloop::lti::c64;
use skyloop::sysid::logs::{Log, OpenOptions};
use std::f64::consts::PI;

fn columns(names: &[&str]) -> (f64, Vec<Vec<f64>>) {
    let path = format!("{}/../../testdata/logs/btfl_all.bbl", env!("CARGO_MANIFEST_DIR"));
    let log = Log::open(
        std::path::Path::new(&path),
        &OpenOptions {
            session: Some(4),
            ..Default::default()
        },
    )
    .unwrap();
    let d = log.uniform(names, None, None, None).unwrap();
    (d.dt_s, d.columns)
}

#[test]
fn logged_p_term_is_pterm_scale_times_the_error() {
    let (_, c) = columns(&["axisP[0]", "setpoint[0]", "gyroADC[0]"]);
    let (p, sp, g) = (&c[0], &c[1], &c[2]);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for i in 0..p.len() {
        let e = sp[i] - g[i];
        // Frames with an error well above the integer rounding of the logged terms.
        if e.abs() > 5.0 {
            sxy += p[i] * e;
            sxx += e * e;
            syy += p[i] * p[i];
        }
    }
    let k = sxy / sxx;
    let r2 = 1.0 - (syy - 2.0 * k * sxy + k * k * sxx) / syy;
    let (kp, _, _, _) = continuous(
        &Gains {
            p: 35,
            i: 75,
            d: 35,
            f: 140,
        },
        Axis::Roll,
        &skyloop::firmware::betaflight::Filters::default(),
    );
    // Measured 1.095 against 0.032029·35 = 1.121; the fit explains 99.8 % of axisP.
    assert!(r2 > 0.99, "R² {r2}");
    assert!((k / kp - 1.0).abs() < 0.05, "logged Kp {k} vs mapping {kp}");
}

/// Cross-spectral estimate of y/x at `f_hz` (Hann windows of `n` samples, half overlap), over
/// the windows where `keep` holds throughout.
fn ratio_at(x: &[f64], y: &[f64], keep: &[bool], dt: f64, f_hz: f64, n: usize) -> c64 {
    let (mut sxy, mut sxx) = (c64::new(0.0, 0.0), 0.0);
    let mut s0 = 0;
    while s0 + n <= x.len() {
        if !keep[s0..s0 + n].iter().all(|k| *k) {
            s0 += n / 2;
            continue;
        }
        let (mut fx, mut fy) = (c64::new(0.0, 0.0), c64::new(0.0, 0.0));
        for i in 0..n {
            let w = 0.5 - 0.5 * (2.0 * PI * i as f64 / n as f64).cos();
            let z = c64::from_polar(w, -2.0 * PI * f_hz * i as f64 * dt);
            fx += z * x[s0 + i];
            fy += z * y[s0 + i];
        }
        sxy += fy * fx.conj();
        sxx += fx.norm_sqr();
        s0 += n / 2;
    }
    sxy / sxx
}

#[test]
fn logged_d_term_follows_d_min_not_d() {
    let (dt, c) = columns(&["axisD[0]", "gyroADC[0]", "rcCommand[3]"]);
    let (d, g) = (&c[0], &c[1]);
    // In flight: throttle above idle (1000 µs is the bottom of the stick).
    let airborne: Vec<bool> = c[2].iter().map(|t| *t >= 1100.0).collect();
    let wc = 2.0 * PI * 100.0;
    for f in [10.0, 20.0, 30.0, 44.0] {
        let h = ratio_at(g, d, &airborne, dt, f, 500);
        let s = c64::new(0.0, 2.0 * PI * f);
        // Betaflight's D-term BIQUAD lowpass: Butterworth, Q = 1/√2.
        let biquad = wc * wc / (s * s + 2f64.sqrt() * wc * s + wc * wc);
        let model = |dgain: f64| -(DTERM_SCALE * dgain) * s * biquad;
        let (at_dmin, at_d) = (h.norm() / model(27.0).norm(), h.norm() / model(35.0).norm());
        assert!(
            (at_dmin - 1.0).abs() < 0.12,
            "{f} Hz: |axisD/gyro| / model(d_min) = {at_dmin}"
        );
        assert!(at_d < 0.85, "{f} Hz: |axisD/gyro| / model(d) = {at_d}");
        let dphase = (h / model(27.0)).arg().to_degrees();
        assert!(dphase.abs() < 10.0, "{f} Hz: phase off by {dphase}°");
    }
}
