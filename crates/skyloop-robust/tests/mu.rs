//! μ bounds against the reference values of tools/gen_mu.py and against closed forms.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use faer::{c64, Mat, MatRef};
use skyloop_robust::mu::{mu, mu_frequency, robust_performance, robust_stability, MuOptions};
use skyloop_robust::uncertainty::{BlockKind, BlockStructure};

mod common;
use common::pseudo_random;

fn sigma_min(x: MatRef<c64>) -> f64 {
    let s = x.singular_values().expect("svd");
    s.iter().copied().fold(f64::INFINITY, f64::min)
}

fn sigma_max(x: MatRef<c64>) -> f64 {
    x.singular_values().expect("svd").first().copied().unwrap_or(0.0)
}

/// Checks that Δ is block diagonal for `s`, each δI block a multiple of I (real when required),
/// σ̄(Δ) = 1/lower and I − MΔ singular.
fn check_delta(m: MatRef<c64>, s: &BlockStructure, delta: MatRef<c64>, lower: f64) {
    assert_eq!((delta.nrows(), delta.ncols()), (m.ncols(), m.nrows()));
    for j in 0..s.len() {
        for k in 0..s.len() {
            if j == k {
                continue;
            }
            for p in s.col_range(j) {
                for q in s.row_range(k) {
                    assert!(delta[(p, q)].norm() == 0.0, "Δ has an entry outside its blocks");
                }
            }
        }
        if let BlockKind::ComplexScalar { .. } | BlockKind::RealScalar { .. } = s.blocks()[j] {
            let (cr, rr) = (s.col_range(j), s.row_range(j));
            let d0 = delta[(cr.start, rr.start)];
            for (p, q) in cr.clone().zip(rr.clone()) {
                assert!((delta[(p, q)] - d0).norm() <= 1e-12 * d0.norm().max(1e-300));
            }
            if s.blocks()[j].is_real() {
                assert!(
                    d0.im.abs() <= 1e-12 * d0.norm().max(1e-300),
                    "real block got a complex value"
                );
            }
        }
    }
    let md = m * delta;
    let n = md.nrows();
    let i_md = Mat::from_fn(
        n,
        n,
        |i, j| if i == j { c64::new(1.0, 0.0) } else { c64::new(0.0, 0.0) } - md[(i, j)],
    );
    assert!(sigma_min(i_md.as_ref()) < 1e-8, "I - MΔ is not singular");
    assert!((sigma_max(delta) * lower - 1.0).abs() < 1e-8, "σ̄(Δ) is not 1/lower");
}

#[test]
fn upper_at_least_lower_on_random_structures() {
    for (k, spec) in [
        "c1x1,c1x1,c1x1,c1x1,c1x1",
        "c2r,f2x3,c1x1",
        "f3x2,c3r,c1x1,f1x1",
        "c4r,c2r",
    ]
    .iter()
    .enumerate()
    {
        let s = BlockStructure::parse(spec).expect("spec");
        for seed in 0..4 {
            let m = pseudo_random(s.m_rows(), s.m_cols(), 100 * k as u64 + seed);
            let r = mu(m.as_ref(), &s).expect("mu");
            assert!(r.upper >= r.lower && r.lower > 0.0, "{spec}: {} {}", r.upper, r.lower);
            // μ is bracketed by the spectral radius-type bound and σ̄ (no scaling).
            assert!(r.upper <= sigma_max(m.as_ref()) * (1.0 + 1e-12));
            check_delta(m.as_ref(), &s, r.delta.as_ref(), r.lower);
        }
    }
}

#[test]
fn upper_bound_is_the_dense_svd_of_the_returned_scaling() {
    // The upper bound is computed by the crate's own tridiagonal eigen-solver on the Gram matrix; it
    // must be σ̄(D_L M D_R⁻¹) of the returned scales as a dense SVD (faer) computes it, so that it is
    // a valid bound and not an estimate: here at every point of a warm-started bench-like sweep.
    let s = BlockStructure::parse("f2x2,c3r,c1x1,f2x2,f2x2").expect("spec");
    let (a0, a1) = (pseudo_random(10, 10, 17), pseudo_random(10, 10, 18));
    let ms: Vec<Mat<c64>> = (0..20)
        .map(|k| {
            let p = c64::new(1.0, 10f64.powf(-1.0 + 2.0 * k as f64 / 19.0));
            Mat::from_fn(10, 10, |i, j| a0[(i, j)] + a1[(i, j)] / p)
        })
        .collect();
    let sweep = skyloop_robust::mu::mu_sweep(&ms, &s, &MuOptions::default()).expect("sweep");
    for (m, r) in ms.iter().zip(&sweep) {
        let dense = sigma_max(r.d.apply(m.as_ref()).as_ref());
        assert!(
            (r.upper - dense).abs() <= 1e-12 * dense,
            "upper {} vs dense σ̄ {dense}",
            r.upper
        );
        assert!(r.upper >= r.lower);
    }
}

#[test]
fn warm_started_sweep_matches_cold_starts() {
    // inf_D σ̄(DMD⁻¹) is a convex problem (Sezginer & Overton 1990): the sweep, which starts each
    // frequency from the previous D-scales at a sharper smoothing stage, must reach the same upper
    // bound as a cold (Osborne) start at every frequency, here for a bench-like multi-block structure.
    let s = BlockStructure::parse("f2x2,c3r,c1x1,f2x2,f2x2").expect("spec");
    let (a0, a1) = (pseudo_random(10, 10, 7), pseudo_random(10, 10, 8));
    let ms: Vec<Mat<c64>> = (0..12)
        .map(|k| {
            let p = c64::new(1.0, 10f64.powf(-1.0 + 2.0 * k as f64 / 11.0));
            Mat::from_fn(10, 10, |i, j| a0[(i, j)] + a1[(i, j)] / p)
        })
        .collect();
    let opts = MuOptions::default();
    let sweep = skyloop_robust::mu::mu_sweep(&ms, &s, &opts).expect("sweep");
    for (m, w) in ms.iter().zip(&sweep) {
        let cold = skyloop_robust::mu::mu_with(m.as_ref(), &s, &opts, None).expect("mu");
        // Both are upper bounds; the warm one may be the tighter (cold starts stop ~1e-5 short).
        assert!(
            w.upper <= cold.upper * (1.0 + 1e-5) && w.upper >= cold.upper * (1.0 - 1e-4),
            "warm {} cold {}",
            w.upper,
            cold.upper
        );
        // The power iteration finds local maxima, so this is not a theorem; here the previous
        // frequency's vectors find the same branch as the pseudo-random starts.
        assert!(
            w.lower >= cold.lower * (1.0 - 1e-3),
            "warm {} cold {}",
            w.lower,
            cold.lower
        );
        assert!(w.upper >= w.lower);
    }
}

#[test]
fn repeated_scalar_block_is_spectral_radius() {
    // Δ = δ I_n: μ = ρ(M) (Packard & Doyle 1993, sec. 3); the upper bound inf σ̄(DMD⁻¹) = ρ(M).
    let m = pseudo_random(4, 4, 7);
    let s = BlockStructure::parse("c4r").expect("spec");
    let r = mu(m.as_ref(), &s).expect("mu");
    let rho = m
        .eigenvalues()
        .expect("eig")
        .iter()
        .map(|l| l.norm())
        .fold(0.0, f64::max);
    assert!((r.lower - rho).abs() <= 1e-10 * rho);
    assert!((r.upper - rho).abs() <= 1e-4 * rho, "upper {} rho {rho}", r.upper);
}

#[test]
fn real_blocks_give_real_perturbations() {
    // det(I − MΔ) = 1 − δ₁δ₂ for M = [[0,1],[1,0]]: real μ = 1 with δ₁ = δ₂ = ±1 (closed form).
    let m = Mat::from_fn(2, 2, |i, j| c64::new(if i != j { 1.0 } else { 0.0 }, 0.0));
    let s = BlockStructure::parse("r1,r1").expect("spec");
    let r = mu(m.as_ref(), &s).expect("mu");
    assert!(
        (r.lower - 1.0).abs() < 1e-9 && (r.upper - 1.0).abs() < 1e-4,
        "{} {}",
        r.upper,
        r.lower
    );
    check_delta(m.as_ref(), &s, r.delta.as_ref(), r.lower);
    // Mixed: M = [[0, 1],[i, 0]] with a real and a complex scalar: 1 − i δ_r δ_c = 0 needs
    // δ_c = −i/δ_r, so μ = 1 (closed form) — the phase search must find it.
    let m = Mat::from_fn(2, 2, |i, j| match (i, j) {
        (0, 1) => c64::new(1.0, 0.0),
        (1, 0) => c64::new(0.0, 1.0),
        _ => c64::new(0.0, 0.0),
    });
    let s = BlockStructure::parse("r1,c1x1").expect("spec");
    let r = mu(m.as_ref(), &s).expect("mu");
    assert!(
        (r.lower - 1.0).abs() < 1e-8 && r.upper >= r.lower,
        "{} {}",
        r.upper,
        r.lower
    );
    check_delta(m.as_ref(), &s, r.delta.as_ref(), r.lower);
}

#[test]
fn zero_matrix_and_bad_input() {
    let s = BlockStructure::parse("c1x1,f2x2").expect("spec");
    let z = Mat::<c64>::zeros(3, 3);
    let r = mu(z.as_ref(), &s).expect("mu of zero");
    assert_eq!((r.upper, r.lower), (0.0, 0.0));
    assert!(mu(Mat::<c64>::zeros(2, 3).as_ref(), &s).is_err());
    let mut nan = pseudo_random(3, 3, 1);
    nan[(1, 1)] = c64::new(f64::NAN, 0.0);
    assert!(mu(nan.as_ref(), &s).is_err());
}

/// Test-only frequency response of a fixed 2×2 transfer matrix
/// M(s) = [[2/(s+1), 1/(s+2)], [3/(s²+0.4s+1), 1/(s+0.5)]].
fn test_system(w: f64) -> skyloop_lti::error::Result<Mat<c64>> {
    let s = c64::new(0.0, w);
    let one = c64::new(1.0, 0.0);
    Ok(Mat::from_fn(2, 2, |i, j| match (i, j) {
        (0, 0) => 2.0 * one / (s + 1.0),
        (0, 1) => one / (s + 2.0),
        (1, 0) => 3.0 * one / (s * s + 0.4 * s + 1.0),
        _ => one / (s + 0.5),
    }))
}

#[test]
fn frequency_sweep_refines_the_peak() {
    let s = BlockStructure::parse("c1x1,c1x1").expect("spec");
    let grid: Vec<f64> = (0..15).map(|k| 10f64.powf(-1.0 + 2.0 * k as f64 / 14.0)).collect();
    let opts = MuOptions::default();
    let sw = mu_frequency(test_system, &grid, &s, &opts).expect("sweep");
    let grid_max = sw.upper.iter().copied().fold(0.0, f64::max);
    assert!(sw.peak.upper >= grid_max);
    // A dense grid (2000 points) must not find a larger μ than the refined peak (2S+F = 2: exact).
    let dense: Vec<f64> = (0..2000).map(|k| 10f64.powf(-1.0 + 2.0 * k as f64 / 1999.0)).collect();
    let mut dense_max = 0.0_f64;
    let mut d = None;
    for &w in &dense {
        let m = test_system(w).expect("eval");
        let r = skyloop_robust::mu::mu_with(m.as_ref(), &s, &opts, d.as_ref()).expect("mu");
        dense_max = dense_max.max(r.upper);
        d = Some(r.d);
    }
    assert!(
        (sw.peak.upper - dense_max).abs() <= 1e-4 * dense_max,
        "refined {} dense {dense_max}",
        sw.peak.upper
    );
    let margin = robust_stability(&sw);
    assert!((margin.lower * sw.peak.upper - 1.0).abs() < 1e-12);
    assert!(margin.upper >= margin.lower);
    let m = test_system(margin.w_rad_s).expect("eval");
    check_delta(m.as_ref(), &s, margin.delta.as_ref(), 1.0 / margin.upper);
    assert!(mu_frequency(test_system, &[1.0, 0.5], &s, &opts).is_err());
    assert!(mu_frequency(test_system, &[], &s, &opts).is_err());
}

#[test]
fn robust_performance_augments_a_full_block() {
    // With a 1×1 uncertainty channel and a 1×1 performance channel, the augmented structure
    // c1x1 + f1x1 has 2S+F = 2: μ is exact, and for the channels of test_system it must match μ
    // of the same matrix with the structure written out by hand.
    let s = BlockStructure::parse("c1x1").expect("spec");
    let grid = [0.3, 1.0, 3.0];
    let opts = MuOptions::default();
    let rp = robust_performance(test_system, &grid, &s, 1, 1, &opts).expect("rp");
    let both = BlockStructure::parse("c1x1,f1x1").expect("spec");
    for (k, &w) in grid.iter().enumerate() {
        let r = mu(test_system(w).expect("eval").as_ref(), &both).expect("mu");
        assert!((rp.upper[k] - r.upper).abs() <= 1e-6 * r.upper);
    }
    assert!(robust_performance(test_system, &grid, &s, 2, 1, &opts).is_err());
}

/// The cases of tools/gen_mu.py (numpy/scipy references; see the script for how each was made).
fn fixture_cases() -> Vec<serde_json::Value> {
    skyloop_fixtures::cases(env!("CARGO_MANIFEST_DIR"), "tests/fixtures/mu/mu_cases.json")
}

fn fixture_matrix(c: &serde_json::Value) -> Mat<c64> {
    let rows = c["m"].as_array().expect("m");
    let nc = rows[0].as_array().expect("row").len();
    Mat::from_fn(rows.len(), nc, |i, j| {
        let z = &rows[i][j];
        c64::new(z[0].as_f64().expect("re"), z[1].as_f64().expect("im"))
    })
}

#[test]
fn fixture_cases_match_the_references() {
    let cases = fixture_cases();
    let mut kinds = std::collections::BTreeMap::new();
    for c in &cases {
        let name = c["name"].as_str().expect("name");
        let kind = c["kind"].as_str().expect("kind");
        *kinds.entry(kind.to_string()).or_insert(0) += 1;
        let s = BlockStructure::parse(c["blocks"].as_str().expect("blocks")).expect("spec");
        let m = fixture_matrix(c);
        let r = mu(m.as_ref(), &s).expect("mu");
        assert!(r.upper >= r.lower, "{name}: upper {} < lower {}", r.upper, r.lower);
        check_delta(m.as_ref(), &s, r.delta.as_ref(), r.lower);
        match kind {
            // Known μ: σ̄ (one full block), Σ|uᵢ||vᵢ| (rank one), or 2S+F ≤ 3 where the D-scaling
            // bound is exact and the reference upper and lower bounds agree to 1e-7.
            "full" | "rank_one" | "exact" => {
                let want = c["mu"].as_f64().expect("mu");
                assert!(
                    (r.upper - want).abs() <= 1e-4 * want,
                    "{name}: upper {} vs mu {want}",
                    r.upper
                );
                assert!(
                    (r.lower - want).abs() <= 1e-4 * want,
                    "{name}: lower {} vs mu {want}",
                    r.lower
                );
            }
            // No exactness theorem: μ lies in [lower_ref, upper_ref]; ours must be as tight.
            "general" => {
                let (lo, up) = (
                    c["lower_ref"].as_f64().expect("lower_ref"),
                    c["upper_ref"].as_f64().expect("upper_ref"),
                );
                assert!(
                    r.upper >= lo * (1.0 - 1e-9),
                    "{name}: upper {} below a proven lower {lo}",
                    r.upper
                );
                assert!(
                    r.upper <= up * (1.0 + 1e-4),
                    "{name}: upper {} looser than {up}",
                    r.upper
                );
                assert!(
                    r.lower <= up * (1.0 + 1e-9),
                    "{name}: lower {} above a proven upper {up}",
                    r.lower
                );
            }
            other => panic!("unknown fixture kind {other}"),
        }
    }
    for k in ["full", "rank_one", "exact", "general"] {
        assert!(
            kinds.get(k).copied().unwrap_or(0) >= 2,
            "fixture has too few '{k}' cases: {kinds:?}"
        );
    }
}
