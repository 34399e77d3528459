//! Sylvester and Lyapunov solvers against scipy and SLICOT SB03OD references
//! (fixtures from tools/gen_lyap.py), with residual checks on every solve.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use faer::{Mat, MatRef};
use serde_json::Value;
use skyloop_linalg::lyapunov::{dlyap, dlyap_chol, lyap, lyap_chol};
use skyloop_linalg::sylvester::sylvester;
use skyloop_linalg::LinalgError;

fn mat(v: &Value) -> Mat<f64> {
    let rows = v.as_array().expect("matrix rows");
    let nr = rows.len();
    let nc = rows.first().and_then(|r| r.as_array()).map_or(0, |r| r.len());
    Mat::from_fn(nr, nc, |i, j| rows[i][j].as_f64().expect("number"))
}

fn cases() -> Vec<Value> {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/lyap/cases.json"))
        .expect("fixture file");
    let v: Value = serde_json::from_str(&text).expect("fixture JSON");
    v["cases"].as_array().expect("cases").clone()
}

fn nrm(m: MatRef<f64>) -> f64 {
    m.norm_l2()
}

/// Relative difference ‖x − y‖/‖y‖.
fn rel(x: &Mat<f64>, y: &Mat<f64>) -> f64 {
    nrm((x - y).as_ref()) / nrm(y.as_ref()).max(f64::MIN_POSITIVE)
}

#[test]
fn solvers_match_references_with_small_residuals() {
    let mut counts = std::collections::HashMap::new();
    for c in cases() {
        let kind = c["kind"].as_str().expect("kind");
        *counts.entry(kind.to_string()).or_insert(0) += 1;
        let a = mat(&c["a"]);
        match kind {
            "sylvester" => {
                let (b, cc, xr) = (mat(&c["b"]), mat(&c["c"]), mat(&c["x"]));
                let x = sylvester(a.as_ref(), b.as_ref(), cc.as_ref()).unwrap();
                let res = &a * &x + &x * &b - &cc;
                let data = (nrm(a.as_ref()) + nrm(b.as_ref())) * nrm(x.as_ref()) + nrm(cc.as_ref());
                assert!(nrm(res.as_ref()) <= 1e-12 * data, "sylvester residual");
                assert!(rel(&x, &xr) <= 1e-9, "sylvester vs scipy: {}", rel(&x, &xr));
            }
            "lyap" | "dlyap" => {
                let (q, xr) = (mat(&c["q"]), mat(&c["x"]));
                let (x, res) = if kind == "lyap" {
                    let x = lyap(a.as_ref(), q.as_ref()).unwrap();
                    let r = &a * &x + &x * a.transpose() + &q;
                    (x, r)
                } else {
                    let x = dlyap(a.as_ref(), q.as_ref()).unwrap();
                    let r = &a * &x * a.transpose() - &x + &q;
                    (x, r)
                };
                let na = nrm(a.as_ref());
                let data = (2.0 * na + na * na) * nrm(x.as_ref()) + nrm(q.as_ref());
                assert!(
                    nrm(res.as_ref()) <= 1e-12 * data,
                    "{kind} residual {}",
                    nrm(res.as_ref()) / data
                );
                assert!(rel(&x, &xr) <= 1e-9, "{kind} vs scipy: {}", rel(&x, &xr));
                assert_eq!(x, x.transpose().to_owned(), "{kind}: symmetric Q gives symmetric X");
            }
            "lyap_chol" | "dlyap_chol" => {
                let (b, ur) = (mat(&c["b"]), mat(&c["u"]));
                let u = if kind == "lyap_chol" {
                    lyap_chol(a.as_ref(), b.as_ref()).unwrap()
                } else {
                    dlyap_chol(a.as_ref(), b.as_ref()).unwrap()
                };
                let p = &u * u.transpose();
                let bb = &b * b.transpose();
                let res = if kind == "lyap_chol" {
                    &a * &p + &p * a.transpose() + &bb
                } else {
                    &a * &p * a.transpose() - &p + &bb
                };
                let na = nrm(a.as_ref());
                let data = (2.0 * na + na * na) * nrm(p.as_ref()) + nrm(bb.as_ref());
                assert!(
                    nrm(res.as_ref()) <= 1e-12 * data,
                    "{kind} residual {}",
                    nrm(res.as_ref()) / data
                );
                for j in 0..u.ncols() {
                    for i in j + 1..u.nrows() {
                        assert_eq!(u[(i, j)], 0.0, "{kind}: U must be upper triangular");
                    }
                }
                // U itself (non-negative diagonal) against SB03OD's factor, relative to ‖U‖.
                assert!(rel(&u, &ur) <= 1e-8, "{kind} vs SB03OD: {}", rel(&u, &ur));
            }
            other => panic!("unknown case kind {other}"),
        }
    }
    for k in ["sylvester", "lyap", "dlyap", "lyap_chol", "dlyap_chol"] {
        assert!(
            counts.get(k).copied().unwrap_or(0) >= 5,
            "fixture has too few {k} cases"
        );
    }
}

#[test]
fn unstable_a_in_factor_form_is_an_error() {
    let a = Mat::from_fn(2, 2, |i, j| if i == j { 0.1 } else { 0.0 });
    let b = Mat::from_fn(2, 1, |_, _| 1.0);
    assert!(matches!(
        lyap_chol(a.as_ref(), b.as_ref()),
        Err(LinalgError::NoSolution(_))
    ));
    let a = Mat::from_fn(2, 2, |i, j| if i == j { 1.5 } else { 0.0 });
    assert!(matches!(
        dlyap_chol(a.as_ref(), b.as_ref()),
        Err(LinalgError::NoSolution(_))
    ));
}

#[test]
fn bad_shapes_and_values_are_errors() {
    let a = Mat::<f64>::identity(3, 3);
    let q2 = Mat::<f64>::identity(2, 2);
    assert!(matches!(lyap(a.as_ref(), q2.as_ref()), Err(LinalgError::Dimension(_))));
    let rect = Mat::<f64>::zeros(2, 3);
    assert!(matches!(
        dlyap(rect.as_ref(), q2.as_ref()),
        Err(LinalgError::Dimension(_))
    ));
    let mut nan = Mat::<f64>::identity(2, 2);
    nan[(0, 1)] = f64::NAN;
    assert!(matches!(
        lyap(nan.as_ref(), q2.as_ref()),
        Err(LinalgError::InvalidArgument(_))
    ));
    // A = I: λᵢ + λⱼ = 2 ≠ 0 is fine, but A·X·Aᵀ − X = −Q has λᵢλⱼ = 1: singular.
    assert!(matches!(
        dlyap(q2.as_ref(), q2.as_ref()),
        Err(LinalgError::NoSolution(_))
    ));
}

#[test]
fn repeated_poles_keep_the_factor_accurate() {
    // Repeated eigenvalues (−0.7 twice, −0.3 twice, a Jordan block at −1) hidden by a similarity:
    // the Schur form then has 2×2 blocks with imaginary parts at rounding level, which
    // Hammarling's method must treat as real double eigenvalues. Reference: X from lyap
    // (Bartels–Stewart), which needs no factorization.
    let n = 6;
    let mut d = Mat::<f64>::zeros(n, n);
    for (i, v) in [-0.7, -0.7, -0.3, -0.3, -1.0, -1.0].iter().enumerate() {
        d[(i, i)] = *v;
    }
    d[(4, 5)] = 1.0;
    let t = Mat::from_fn(n, n, |i, j| {
        if i == j {
            2.0
        } else {
            ((3 * i + 5 * j) % 7) as f64 * 0.15 - 0.45
        }
    });
    let ti = {
        use faer::linalg::solvers::DenseSolveCore;
        t.as_ref().partial_piv_lu().inverse()
    };
    let a = &t * &d * &ti;
    let b = Mat::from_fn(n, 1, |i, _| 1.0 - 0.2 * i as f64);
    let u = lyap_chol(a.as_ref(), b.as_ref()).unwrap();
    let p = &u * u.transpose();
    let bb = &b * b.transpose();
    let x = lyap(a.as_ref(), bb.as_ref()).unwrap();
    let res = &a * &p + &p * a.transpose() + &bb;
    assert!(nrm(res.as_ref()) <= 1e-12 * (2.0 * nrm(a.as_ref()) * nrm(p.as_ref()) + nrm(bb.as_ref())));
    assert!(rel(&p, &x) <= 1e-10, "factor vs Bartels–Stewart: {}", rel(&p, &x));
    // Discrete time: the same structure scaled into the unit disc.
    let ad = Mat::from_fn(n, n, |i, j| -a[(i, j)] * 0.5);
    let u = dlyap_chol(ad.as_ref(), b.as_ref()).unwrap();
    let p = &u * u.transpose();
    let x = dlyap(ad.as_ref(), bb.as_ref()).unwrap();
    assert!(
        rel(&p, &x) <= 1e-10,
        "discrete factor vs Bartels–Stewart: {}",
        rel(&p, &x)
    );
}
