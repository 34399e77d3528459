//! Model reduction and minimal realization against SLICOT (AB09AD/AB09MD/AB09ND, TB01PD through
//! slycot and python-control; fixtures from tools/gen_reduce.py), with the error bound checked on a
//! dense frequency grid.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use faer::{c64, Mat};
use serde_json::Value;
use skyloop_linalg::schur::real_schur;
use skyloop_lti::freqresp::{evalfr, freqresp};
use skyloop_lti::minreal::minreal;
use skyloop_lti::reduce::{balreal, balred, hsvd, Method};
use skyloop_lti::stabsep::{is_stable_pole, stabsep};
use skyloop_lti::{gramian, StateSpace};

fn rows(v: &Value) -> Vec<Vec<f64>> {
    v.as_array()
        .expect("rows")
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

fn fixture() -> Value {
    skyloop_fixtures::load(env!("CARGO_MANIFEST_DIR"), "tests/fixtures/reduce/cases.json")
}

fn model(c: &Value) -> StateSpace {
    StateSpace::from_rows(
        &rows(&c["a"]),
        &rows(&c["b"]),
        &rows(&c["c"]),
        &rows(&c["d"]),
        c["dt"].as_f64().unwrap(),
    )
    .expect("fixture model")
}

/// The fixture's responses as complex matrices.
fn responses(v: &Value) -> Vec<Mat<c64>> {
    v.as_array()
        .expect("responses")
        .iter()
        .map(|g| {
            let (re, im) = (rows(&g["re"]), rows(&g["im"]));
            Mat::from_fn(re.len(), re[0].len(), |i, j| c64::new(re[i][j], im[i][j]))
        })
        .collect()
}

fn sigma_max(m: &Mat<c64>) -> f64 {
    m.as_ref().singular_values().expect("svd")[0]
}

fn eigs(sys: &StateSpace) -> Vec<c64> {
    real_schur(sys.a.as_ref()).expect("schur").eigenvalues()
}

/// A dense grid: 600 log-spaced points over [1e-3, 1e4]·(pole scale), plus Nyquist in discrete time.
fn dense_grid(sys: &StateSpace) -> Vec<f64> {
    let top = if sys.dt > 0.0 {
        std::f64::consts::PI / sys.dt
    } else {
        1e4
    };
    let mut w: Vec<f64> = (0..600).map(|k| 1e-3 * (top / 1e-3).powf(k as f64 / 599.0)).collect();
    w.push(0.0);
    w
}

#[test]
fn hankel_singular_values_match_slicot() {
    let f = fixture();
    let mut worst: f64 = 0.0;
    for c in f["cases"].as_array().unwrap() {
        let name = c["name"].as_str().unwrap();
        let sys = model(c);
        let hsv = hsvd(&sys).unwrap();
        let href: Vec<f64> = c["hsv"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(hsv.len(), href.len(), "{name}: number of stable-part HSVs");
        let s1 = href[0];
        for (i, (&h, &r)) in hsv.iter().zip(&href).enumerate() {
            // Relative 1e-8 for σᵢ ≥ 1e-4·σ₁. Smaller σᵢ are only determined to about ε·σ₁·κ
            // absolutely: for drss_n8, σ₇/σ₁ = 1e-5 and a 40-digit mpmath solution of the gramians gives
            // σ₇ = 0.416402526154, off by 6.5e-9 relative in SLICOT's and 5.3e-9 in ours.
            if r >= 1e-4 * s1 {
                let e = (h - r).abs() / r;
                worst = worst.max(e);
                assert!(e <= 1e-8, "{name}: σ{i} = {h} vs SLICOT {r} (rel {e:.2e})");
            } else if r >= 1e-6 * s1 {
                let e = (h - r).abs() / r;
                assert!(e <= 5e-8, "{name}: σ{i} = {h} vs SLICOT {r} (rel {e:.2e})");
            } else {
                assert!((h - r).abs() <= 1e-12 * s1, "{name}: σ{i} = {h} vs SLICOT {r}");
            }
        }
    }
    eprintln!("worst relative HSV error vs SLICOT: {worst:.2e}");
}

#[test]
fn reduced_models_match_slicot_and_satisfy_the_error_bound() {
    let f = fixture();
    for c in f["cases"].as_array().unwrap() {
        let name = c["name"].as_str().unwrap();
        let sys = model(c);
        let order = c["order"].as_u64().unwrap() as usize;
        let w: Vec<f64> = c["w"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        let grid = dense_grid(&sys);
        let g_full = freqresp(&sys, &grid).unwrap();
        let gmax = g_full.iter().map(sigma_max).fold(0.0, f64::max);
        for (method, key) in [(Method::Balanced, "balanced"), (Method::Spa, "spa")] {
            let red = balred(&sys, order, method).unwrap();
            assert_eq!(red.sys.nx(), order, "{name} {key}: order");
            // Same reduced transfer function as SLICOT (realizations differ by a similarity).
            let g_ref = responses(&c[key]);
            let g_ours = freqresp(&red.sys, &w).unwrap();
            for (k, (x, y)) in g_ours.iter().zip(&g_ref).enumerate() {
                let d = sigma_max(&(x - y));
                assert!(
                    d <= 1e-7 * gmax,
                    "{name} {key}: w={} differs from SLICOT by {d:.3e} (|G|max {gmax:.3e})",
                    w[k]
                );
            }
            // ‖G − Gr‖∞ ≤ 2·Σ discarded σ on the dense grid.
            let g_red = freqresp(&red.sys, &grid).unwrap();
            let err = g_full
                .iter()
                .zip(&g_red)
                .map(|(x, y)| sigma_max(&(x - y)))
                .fold(0.0, f64::max);
            assert!(
                err <= red.error_bound * (1.0 + 1e-8) + 1e-10 * gmax,
                "{name} {key}: error {err:.4e} above bound {:.4e}",
                red.error_bound
            );
            // Unstable poles survive exactly.
            let unstable: Vec<c64> = eigs(&sys).into_iter().filter(|&l| !is_stable_pole(l, sys.dt)).collect();
            assert_eq!(red.n_unstable, unstable.len(), "{name}: unstable count");
            let reduced_eigs = eigs(&red.sys);
            for l in unstable {
                let near = reduced_eigs
                    .iter()
                    .map(|&m| (m - l).norm())
                    .fold(f64::INFINITY, f64::min);
                assert!(near <= 1e-9 * l.norm().max(1.0), "{name} {key}: unstable pole {l} lost");
            }
            if method == Method::Spa {
                // Singular perturbation matches the DC gain (s = 0, or z = 1 in discrete time).
                let (g0, r0) = (
                    evalfr(&sys, c64::new(0.0, 0.0)).unwrap(),
                    evalfr(&red.sys, c64::new(0.0, 0.0)).unwrap(),
                );
                assert!(
                    sigma_max(&(&g0 - &r0)) <= 1e-8 * sigma_max(&g0).max(1.0),
                    "{name}: DC gain not matched"
                );
            }
        }
    }
}

#[test]
fn balanced_realization_has_equal_diagonal_gramians() {
    let f = fixture();
    let c = &f["cases"][1];
    let sys = model(c);
    let (bal, hsv) = balreal(&sys).unwrap();
    let p = gramian::gram(&bal, gramian::Gramian::Controllability).unwrap();
    let q = gramian::gram(&bal, gramian::Gramian::Observability).unwrap();
    for i in 0..bal.nx() {
        for j in 0..bal.nx() {
            let want = if i == j { hsv[i] } else { 0.0 };
            assert!((p[(i, j)] - want).abs() <= 1e-10 * hsv[0], "P[{i},{j}]");
            assert!((q[(i, j)] - want).abs() <= 1e-10 * hsv[0], "Q[{i},{j}]");
        }
    }
}

#[test]
fn minreal_matches_slicot_order_and_keeps_the_response() {
    let f = fixture();
    for c in f["minreal"].as_array().unwrap() {
        let name = c["name"].as_str().unwrap();
        let sys = model(c);
        let m = minreal(&sys, c["tol"].as_f64()).unwrap();
        assert_eq!(
            m.nx(),
            c["order"].as_u64().unwrap() as usize,
            "{name}: minimal order vs TB01PD"
        );
        let w: Vec<f64> = c["w"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        let g_ref = responses(&c["response"]);
        let g = freqresp(&m, &w).unwrap();
        let gmax = g_ref.iter().map(sigma_max).fold(0.0, f64::max);
        for (x, y) in g.iter().zip(&g_ref) {
            assert!(sigma_max(&(x - y)) <= 1e-7 * gmax, "{name}: response changed");
        }
    }
}

#[test]
fn stabsep_parts_add_up_for_the_unstable_fixture() {
    let f = fixture();
    let c = f["cases"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == "unstable_n12")
        .unwrap();
    let sys = model(c);
    let (gs, gu) = stabsep(&sys).unwrap();
    assert_eq!((gs.nx(), gu.nx()), (9, 3));
    let w = [0.01, 0.7, 3.0, 50.0];
    let (g, a, b) = (
        freqresp(&sys, &w).unwrap(),
        freqresp(&gs, &w).unwrap(),
        freqresp(&gu, &w).unwrap(),
    );
    for k in 0..w.len() {
        assert!(sigma_max(&(&g[k] - &a[k] - &b[k])) <= 1e-9 * sigma_max(&g[k]));
    }
}

#[test]
fn bad_requests_are_errors() {
    let f = fixture();
    let c = f["cases"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == "unstable_n12")
        .unwrap();
    let sys = model(c);
    // 3 unstable poles cannot fit in 2 states.
    assert!(balred(&sys, 2, Method::Balanced).is_err());
    assert!(balred(&sys, 99, Method::Spa).is_err());
    assert!(balreal(&sys).is_err());
    assert!("hankel".parse::<Method>().is_err());
}

#[test]
fn static_gain_reduces_to_itself() {
    let g = StateSpace::gain(Mat::from_fn(2, 1, |i, _| 1.0 + i as f64), 0.0).unwrap();
    let r = balred(&g, 0, Method::Spa).unwrap();
    assert_eq!((r.sys.nx(), r.hsv.len(), r.error_bound), (0, 0, 0.0));
    assert_eq!(r.sys.d, g.d);
    assert_eq!(minreal(&g, None).unwrap().nx(), 0);
}

/// Issue 15: a 1000-state stable model with two inputs (its gramian factors decay geometrically,
/// which once made the Cholesky factor non-finite and the reduction fail) reduces to order 10;
/// the Hankel singular values match SLICOT AB09AD (tools/gen_reduce_large.py) and the reduced
/// model is stable within the balanced-truncation error bound at DC.
#[test]
fn reduction_of_a_1000_state_model_matches_slicot() {
    let fx = skyloop_fixtures::load(env!("CARGO_MANIFEST_DIR"), "tests/fixtures/reduce/lcg_n1000.json");
    let n = 1000;
    let mut a = skyloop_fixtures::lcg_matrix(n, n, 11);
    for (i, row) in a.iter_mut().enumerate() {
        row[i] -= (n as f64).sqrt();
    }
    let (b, c) = (
        skyloop_fixtures::lcg_matrix(n, 2, 12),
        skyloop_fixtures::lcg_matrix(2, n, 13),
    );
    let check = skyloop_fixtures::f64s(&fx["check"]);
    assert_eq!(
        [a[3][2], b[999][1], c[1][999]],
        [check[0], check[1], check[2]],
        "LCG mismatch"
    );
    let sys = StateSpace::from_rows(&a, &b, &c, &[vec![0.0; 2], vec![0.0; 2]], 0.0).unwrap();
    let hsv = hsvd(&sys).unwrap();
    for (k, want) in skyloop_fixtures::f64s(&fx["hsv"]).iter().enumerate() {
        assert!(
            (hsv[k] - want).abs() <= 1e-6 * want,
            "σ{k}: {} vs SLICOT {want}",
            hsv[k]
        );
    }
    let r = balred(&sys, 10, Method::Balanced).unwrap().sys;
    assert_eq!(r.nx(), 10);
    assert!(eigs(&r).iter().all(|p| p.re < 0.0));
    let bound = 2.0 * hsv[10..].iter().sum::<f64>();
    let (g, gr) = (
        evalfr(&sys, c64::new(0.0, 0.0)).unwrap(),
        evalfr(&r, c64::new(0.0, 0.0)).unwrap(),
    );
    let err = sigma_max(&(&g - &gr));
    assert!(err <= bound * (1.0 + 1e-6), "DC error {err} above the bound {bound}");
}
