//! skyloop-lti against python-control 0.10.2 + slycot/scipy fixtures (tools/gen_lti.py).
#![allow(clippy::unwrap_used)]

use faer::{c64, Mat};
use serde_json::Value;
use skyloop_lti::convert::ss_to_tf;
use skyloop_lti::discretize::{c2d, matched_zpk, Method};
use skyloop_lti::pade::pade;
use skyloop_lti::poles_zeros::{poles, zeros};
use skyloop_lti::poly::Poly;
use skyloop_lti::timeresp::step;
use skyloop_lti::StateSpace;

fn load(name: &str) -> Vec<Value> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/lti/");
    let text = std::fs::read_to_string(format!("{path}{name}")).expect("fixture exists");
    let v: Value = serde_json::from_str(&text).expect("fixture is JSON");
    v["cases"].as_array().expect("cases").clone()
}

fn rows(v: &Value) -> Vec<Vec<f64>> {
    v.as_array()
        .expect("matrix")
        .iter()
        .map(|r| {
            r.as_array()
                .expect("row")
                .iter()
                .map(|x| x.as_f64().expect("number"))
                .collect()
        })
        .collect()
}

fn vecf(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("vector")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn sys(v: &Value) -> StateSpace {
    StateSpace::from_rows(
        &rows(&v["a"]),
        &rows(&v["b"]),
        &rows(&v["c"]),
        &rows(&v["d"]),
        v["dt"].as_f64().unwrap_or(0.0),
    )
    .expect("fixture model is valid")
}

fn cplx(v: &Value) -> Vec<c64> {
    vecf(&v["re"])
        .into_iter()
        .zip(vecf(&v["im"]))
        .map(|(r, i)| c64::new(r, i))
        .collect()
}

/// Largest distance from a root in `got` to its nearest partner in `want` (matched one to one).
fn set_distance(got: &[c64], want: &[c64]) -> f64 {
    assert_eq!(got.len(), want.len(), "root counts: {got:?} vs {want:?}");
    let mut rest = want.to_vec();
    let mut worst = 0.0f64;
    for g in got {
        let (k, d) = rest
            .iter()
            .enumerate()
            .map(|(k, w)| (k, (g - w).norm() / (1.0 + w.norm())))
            .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
        worst = worst.max(d);
        rest.remove(k);
    }
    worst
}

fn max_rel(a: &Mat<f64>, b: &[Vec<f64>]) -> f64 {
    let scale = b.iter().flatten().fold(1.0f64, |m, x| m.max(x.abs()));
    let mut e = 0.0f64;
    for (i, row) in b.iter().enumerate() {
        for (j, x) in row.iter().enumerate() {
            e = e.max((a[(i, j)] - x).abs() / scale);
        }
    }
    e
}

#[test]
fn poles_and_zeros_match_slycot() {
    for (k, c) in load("zeros.json").iter().enumerate() {
        let g = sys(&c["sys"]);
        let dp = set_distance(&poles(&g).unwrap(), &cplx(&c["poles"]));
        assert!(dp < 1e-9, "case {k}: poles off by {dp}");
        let dz = set_distance(&zeros(&g).unwrap(), &cplx(&c["zeros"]));
        assert!(dz < 1e-8, "case {k}: zeros off by {dz}");
    }
}

#[test]
fn ss2tf_matches_slycot() {
    for (k, c) in load("ss2tf.json").iter().enumerate() {
        let g = sys(&c["sys"]);
        let tf = ss_to_tf(&g).unwrap();
        let (num, den) = (&c["num"], &c["den"]);
        for i in 0..g.ny() {
            for j in 0..g.nu() {
                let rn = Poly::new(vecf(&num[i][j]));
                let rd = Poly::new(vecf(&den[i][j]));
                // Values agree at points across the pole range.
                for w in [0.01, 0.3, 1.0, 3.0, 30.0] {
                    let s = c64::new(0.1, w);
                    let want = rn.eval(s) / rd.eval(s);
                    let got = tf.num[i][j].eval(s) / tf.den[i][j].eval(s);
                    assert!(
                        (got - want).norm() < 1e-9 * (1.0 + want.norm()),
                        "case {k} ({i},{j}) at {w}"
                    );
                }
                // Same degree: monic-normalized coefficients agree.
                if rd.degree() == tf.den[i][j].degree() {
                    let (l1, l2) = (rd.leading(), tf.den[i][j].leading());
                    for (a, b) in rd.coeffs.iter().zip(&tf.den[i][j].coeffs) {
                        assert!((a / l1 - b / l2).abs() < 1e-9 * (1.0 + (a / l1).abs()), "case {k} den");
                    }
                }
            }
        }
    }
}

#[test]
fn c2d_matches_scipy() {
    for (k, c) in load("c2d.json").iter().enumerate() {
        let g = sys(&c["sys"]);
        let dt = c["dt"].as_f64().unwrap();
        let method = match (c["method"].as_str().unwrap(), c["prewarp_rad_s"].as_f64()) {
            ("tustin", w) => Method::Tustin { prewarp_rad_s: w },
            (m, _) => m.parse().unwrap(),
        };
        let d = c2d(&g, dt, method).unwrap();
        let o = &c["out"];
        for (m, name) in [(&d.a, "a"), (&d.b, "b"), (&d.c, "c"), (&d.d, "d")] {
            let e = max_rel(m, &rows(&o[name]));
            assert!(e < 1e-9, "case {k} {method:?} dt={dt}: {name} off by {e}");
        }
    }
}

#[test]
fn matched_matches_python_control() {
    for (k, c) in load("matched.json").iter().enumerate() {
        let g = sys(&c["sys"]);
        let dt = c["dt"].as_f64().unwrap();
        // Compare coefficients: the reference polynomials are formed from the mapped roots as ours,
        // while values near the pole cluster at z = 1 are too ill-conditioned to compare.
        let z = matched_zpk(&g, dt).unwrap();
        let tf = z.to_tf().unwrap();
        for (got, want) in [(&tf.num[0][0], vecf(&c["num"])), (&tf.den[0][0], vecf(&c["den"]))] {
            let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            assert_eq!(got.coeffs.len(), want.len(), "case {k}");
            for (a, b) in got.coeffs.iter().zip(&want) {
                assert!((a - b).abs() < 1e-9 * scale, "case {k}: {a} vs {b}");
            }
        }
        // The state-space result realizes the same model: compare at a point away from z = 1.
        let d = c2d(&g, dt, Method::Matched).unwrap();
        let zz = c64::new(-0.5, 0.5);
        let want = tf.num[0][0].eval(zz) / tf.den[0][0].eval(zz);
        let n = d.nx();
        let m = Mat::<c64>::from_fn(n, n, |i, j| if i == j { zz } else { c64::new(0.0, 0.0) } - d.a[(i, j)]);
        let b = Mat::<c64>::from_fn(n, 1, |i, _| c64::new(d.b[(i, 0)], 0.0));
        use faer::linalg::solvers::Solve;
        let x = m.partial_piv_lu().solve(&b);
        let got = (0..n).fold(c64::new(d.d[(0, 0)], 0.0), |acc, q| acc + d.c[(0, q)] * x[(q, 0)]);
        assert!(
            (got - want).norm() < 1e-9 * (1.0 + want.norm()),
            "case {k}: {got} vs {want}"
        );
    }
}

#[test]
fn step_matches_python_control() {
    for (k, c) in load("step.json").iter().enumerate() {
        let g = sys(&c["sys"]);
        let t = vecf(&c["t"]);
        let r = step(&g, Some(&t)).unwrap();
        let y = c["y"].as_array().unwrap();
        for i in 0..g.ny() {
            for j in 0..g.nu() {
                let want = vecf(&y[i][j]);
                let scale = want.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                for (n, w) in want.iter().enumerate() {
                    let e = (r.y[i][j][n] - w).abs() / scale;
                    assert!(e < 1e-9, "case {k} ({i},{j}) t={}: {} vs {w}", t[n], r.y[i][j][n]);
                }
            }
        }
    }
}

#[test]
fn pade_matches_python_control() {
    for c in load("pade.json") {
        let (num, den) = pade(c["t"].as_f64().unwrap(), c["n"].as_u64().unwrap() as usize);
        for (got, want) in [(num, vecf(&c["num"])), (den, vecf(&c["den"]))] {
            assert_eq!(got.coeffs.len(), want.len());
            for (a, b) in got.coeffs.iter().zip(&want) {
                assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0), "{a} vs {b}");
            }
        }
    }
}
