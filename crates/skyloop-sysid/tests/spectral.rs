//! Spectral estimators against scipy/numpy fixtures (tools/gen_sysid.py) and against known systems,
//! open and closed loop.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use num_complex::Complex64 as C64;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use serde_json::Value;
use skyloop_sysid::spectral::{estimate, IoData, Method, Options, Window};

fn fixture(name: &str) -> Value {
    skyloop_fixtures::load(env!("CARGO_MANIFEST_DIR"), &format!("tests/fixtures/sysid/{name}"))
}

fn vec(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

fn cvec(re: &Value, im: &Value) -> Vec<C64> {
    vec(re).into_iter().zip(vec(im)).map(|(a, b)| C64::new(a, b)).collect()
}

#[test]
fn welch_matches_scipy() {
    let fx = fixture("welch.json");
    let (u, y, dt) = (vec(&fx["u"]), vec(&fx["y"]), fx["dt"].as_f64().unwrap());
    for case in fx["cases"].as_array().unwrap() {
        let nper = case["nperseg"].as_u64().unwrap() as usize;
        let nover = case["noverlap"].as_u64().unwrap() as usize;
        let window: Window = case["window"].as_str().unwrap().parse().unwrap();
        let o = Options {
            method: Method::Welch,
            nfft: Some(nper),
            overlap: nover as f64 / nper as f64,
            window,
            ..Options::default()
        };
        let frf = estimate(
            &IoData {
                u: &u,
                y: &y,
                r: None,
                dist: None,
                dt_s: dt,
            },
            &o,
        )
        .unwrap();
        let g = cvec(&case["re"], &case["im"]);
        let f = vec(&case["freq_hz"]);
        let coh = vec(&case["coherence"]);
        assert_eq!(frf.freq_hz.len(), f.len());
        for i in 0..f.len() {
            assert!((frf.freq_hz[i] - f[i]).abs() < 1e-9);
            assert!((frf.response[i] - g[i]).norm() < 1e-9 * (1.0 + g[i].norm()), "{i}");
            assert!((frf.coherence[i] - coh[i]).abs() < 1e-9, "{i}");
        }
        // Welch's variance-reduction factor for Hann at 50 % overlap is about 1/(0.53 K) for large K
        // (Welch 1967, Table 1): the equivalent number of averages is about 0.53·(K_segments ≈ 31)·…
        let k = (u.len() - nper) / (nper - nover) + 1;
        assert!(
            frf.dof[0] > 0.4 * k as f64 && frf.dof[0] < k as f64,
            "{} vs {k}",
            frf.dof[0]
        );
    }
}

#[test]
fn etfe_and_spa_match_numpy() {
    let fx = fixture("etfe_spa.json");
    let w = fixture("welch.json");
    let n = fx["n"].as_u64().unwrap() as usize;
    let dt = fx["dt"].as_f64().unwrap();
    let (u, y) = (vec(&w["u"])[..n].to_vec(), vec(&w["y"])[..n].to_vec());
    let d = IoData {
        u: &u,
        y: &y,
        r: None,
        dist: None,
        dt_s: dt,
    };
    let frf = estimate(
        &d,
        &Options {
            method: Method::Etfe,
            ..Options::default()
        },
    )
    .unwrap();
    let g = cvec(&fx["etfe_re"], &fx["etfe_im"]);
    assert_eq!(frf.freq_hz.len(), g.len());
    for i in 0..g.len() {
        assert!((frf.response[i] - g[i]).norm() < 1e-9 * (1.0 + g[i].norm()), "{i}");
    }
    let f = vec(&fx["spa_freq_hz"]);
    let o = Options {
        method: Method::Spa,
        lag_window: Some(fx["lag_window"].as_u64().unwrap() as usize),
        fmin_hz: Some(f[0]),
        fmax_hz: Some(*f.last().unwrap()),
        n_freq: f.len(),
        ..Options::default()
    };
    let frf = estimate(&d, &o).unwrap();
    let g = cvec(&fx["spa_re"], &fx["spa_im"]);
    for i in 0..g.len() {
        assert!((frf.freq_hz[i] - f[i]).abs() < 1e-9);
        assert!(
            (frf.response[i] - g[i]).norm() < 1e-9 * (1.0 + g[i].norm()),
            "{i} {} {}",
            frf.response[i],
            g[i]
        );
    }
}

/// y = G u + v for the discrete first-order lag G(z) = b z⁻¹/(1 − a z⁻¹).
fn first_order(b: f64, a: f64, f_hz: f64, dt: f64) -> C64 {
    let z1 = C64::from_polar(1.0, -2.0 * std::f64::consts::PI * f_hz * dt);
    b * z1 / (1.0 - a * z1)
}

#[test]
fn spafdr_recovers_known_system_with_honest_bands() {
    let (b, a, dt) = (0.2, 0.8, 0.001);
    let n = 60_000;
    let mut rng = rand::rngs::StdRng::seed_from_u64(11);
    let nrm = Normal::new(0.0, 1.0).unwrap();
    let u: Vec<f64> = (0..n).map(|_| nrm.sample(&mut rng)).collect();
    let mut y = vec![0.0; n];
    let mut state = 0.0;
    for k in 0..n {
        y[k] = state + 0.3 * nrm.sample(&mut rng);
        state = a * state + b * u[k];
    }
    let frf = estimate(
        &IoData {
            u: &u,
            y: &y,
            r: None,
            dist: None,
            dt_s: dt,
        },
        &Options::default(),
    )
    .unwrap();
    assert_eq!(frf.freq_hz.len(), 100);
    let eps = frf.rel_std();
    let mut inside = 0;
    for i in 0..frf.freq_hz.len() {
        let g0 = first_order(b, a, frf.freq_hz[i], dt);
        let rel = ((frf.response[i] - g0) / g0).norm();
        assert!(
            rel < 5.0 * std::f64::consts::SQRT_2 * eps[i],
            "f {} rel {rel} eps {}",
            frf.freq_hz[i],
            eps[i]
        );
        // A complex relative error of √2·ε per standard deviation; count the 2σ-band hits.
        if rel < 2.0 * std::f64::consts::SQRT_2 * eps[i] {
            inside += 1;
        }
    }
    assert!(inside >= 80, "only {inside}/100 inside the 2σ band");
    // Frequency resolution grows with frequency: more averages at the top than at the bottom.
    assert!(frf.dof[99] > 20.0 * frf.dof[0]);
}

#[test]
fn closed_loop_estimate_is_unbiased_where_h1_is_not() {
    // Plant G(z) = 0.2 z⁻¹/(1 − 0.8 z⁻¹), controller u = −2·y_meas + r, white output noise v.
    let (b, a, kc, dt) = (0.2, 0.8, 2.0, 0.004);
    let n = 40_000;
    let mut rng = rand::rngs::StdRng::seed_from_u64(3);
    let nrm = Normal::new(0.0, 1.0).unwrap();
    let (mut u, mut y, mut r) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut x = 0.0;
    for k in 0..n {
        y[k] = x + 0.3 * nrm.sample(&mut rng);
        r[k] = 2.0 * nrm.sample(&mut rng);
        u[k] = -kc * y[k] + r[k];
        x = a * x + b * u[k];
    }
    // Both estimators that take an instrument: SPAFDR (the default) and Welch (issue 46: a Welch
    // fit on closed-loop data with the setpoint given must be the indirect Φ_yr/Φ_ur, not H1).
    for (method, nfft) in [(Method::Spafdr, None), (Method::Welch, Some(512))] {
        let mk = |r: Option<&[f64]>| {
            estimate(
                &IoData {
                    u: &u,
                    y: &y,
                    r,
                    dist: None,
                    dt_s: dt,
                },
                &Options {
                    method,
                    nfft,
                    fmax_hz: Some(60.0),
                    ..Options::default()
                },
            )
            .unwrap()
        };
        let closed = mk(Some(&r));
        let open = mk(None);
        // Mean relative error over 1..20 Hz, where each estimate averages ≥ 18 bins.
        let mean_err = |frf: &skyloop_sysid::spectral::Frf| {
            let e: Vec<f64> = frf
                .freq_hz
                .iter()
                .zip(&frf.response)
                .filter(|(f, _)| **f > 1.0 && **f < 20.0)
                .map(|(f, g)| {
                    let g0 = first_order(b, a, *f, dt);
                    ((g - g0) / g0).norm()
                })
                .collect();
            e.iter().sum::<f64>() / e.len() as f64
        };
        // H1 under feedback converges to (G·Φr − K·Φv)/(Φr + K²·Φv): a relative error ≥ 12 % here.
        let (ec, eo) = (mean_err(&closed), mean_err(&open));
        assert!(ec < 0.06, "{method:?}: closed-loop estimate error {ec}");
        assert!(eo > 0.09, "{method:?}: H1 error {eo}");
    }
}

#[test]
fn bad_input_is_an_error() {
    let u = vec![1.0; 100];
    let y = vec![0.0; 99];
    let e = estimate(
        &IoData {
            u: &u,
            y: &y,
            r: None,
            dist: None,
            dt_s: 0.01,
        },
        &Options::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("differ in length"), "{e}");
    let y = vec![0.0; 100];
    // A constant input has no power after detrending.
    for m in [Method::Etfe, Method::Welch, Method::Spa, Method::Spafdr] {
        let r = estimate(
            &IoData {
                u: &u,
                y: &y,
                r: None,
                dist: None,
                dt_s: 0.01,
            },
            &Options {
                method: m,
                ..Options::default()
            },
        );
        assert!(r.is_err(), "{m:?}");
    }
    let mut u2: Vec<f64> = (0..100).map(|i| (i as f64).sin()).collect();
    u2[5] = f64::NAN;
    assert!(estimate(
        &IoData {
            u: &u2,
            y: &y,
            r: None,
            dist: None,
            dt_s: 0.01
        },
        &Options::default()
    )
    .is_err());
    let o = Options {
        fmin_hz: Some(80.0),
        fmax_hz: Some(90.0),
        ..Options::default()
    };
    assert!(estimate(
        &IoData {
            u: &u2,
            y: &y,
            r: None,
            dist: None,
            dt_s: 0.01
        },
        &o
    )
    .is_err());
}
