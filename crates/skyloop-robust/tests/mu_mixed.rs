//! Mixed-μ (real scalar blocks) upper bound by D–G scalings against closed forms and an exact 1-D search.
#![allow(clippy::unwrap_used)] // a panic is how a test or bench reports failure

use faer::linalg::solvers::Solve;
use faer::Side;
use faer::{c64, Mat, MatRef};
use skyloop_robust::mu::{mixed_upper_bound, mu, mu_frequency, upper_bound, MuOptions, UpperOptions};
use skyloop_robust::uncertainty::BlockStructure;

mod common;
use common::pseudo_random;

/// The complex-only bound (real blocks treated as complex), as `mu` reported before D–G scalings.
fn complex_bound(m: MatRef<c64>, s: &BlockStructure) -> f64 {
    upper_bound(m, s, None, 0.0, &UpperOptions::default())
        .expect("complex bound")
        .value
}

#[test]
fn one_real_scalar_closed_form() {
    // Δ = δ real, |δ| ≤ 1: 1 − mδ = 0 needs δ = 1/m, real only for real m, so μ = |m| for real m and
    // μ = 0 when Im m ≠ 0 (closed form).
    let s = BlockStructure::parse("r1").expect("spec");
    for &m in &[2.5, -0.75, 1e-3] {
        let mm = Mat::from_fn(1, 1, |_, _| c64::new(m, 0.0));
        let r = mu(mm.as_ref(), &s).expect("mu");
        assert!((r.upper - m.abs()).abs() <= 1e-6 * m.abs(), "m {m}: upper {}", r.upper);
        assert!((r.lower - m.abs()).abs() <= 1e-9 * m.abs(), "m {m}: lower {}", r.lower);
    }
    for &(re, im) in &[(1.0, 2.0), (3.0, 0.01), (0.0, -1.0)] {
        let mm = Mat::from_fn(1, 1, |_, _| c64::new(re, im));
        let r = mu(mm.as_ref(), &s).expect("mu");
        assert!(r.upper <= 1e-6, "m {re}+{im}j: upper {}", r.upper);
        assert!(r.lower <= r.upper);
    }
}

/// Exact μ for the structure (real δr, complex δc) and a 2×2 M: det(I − M diag(δr, δc)) = 0 is linear
/// in δc, δc(δr) = (1 − m₁₁δr) / (m₂₂ − det(M) δr), and μ = 1 / min over real δr of
/// max(|δr|, |δc(δr)|). δr = 0 gives 1/|m₂₂|, so |δr| ≤ 1/|m₂₂| suffices: a fine grid, then a
/// golden-section refinement around the best grid point.
fn exact_real_complex(m: MatRef<c64>) -> f64 {
    let det = m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)];
    let one = c64::new(1.0, 0.0);
    let cost = |dr: f64| {
        let den = m[(1, 1)] - det * dr;
        let dc = if den.norm() == 0.0 {
            f64::INFINITY
        } else {
            ((one - m[(0, 0)] * dr) / den).norm()
        };
        dr.abs().max(dc)
    };
    let r = 1.0 / m[(1, 1)].norm();
    let n = 200_000;
    let h = 2.0 * r / n as f64;
    let (mut best_x, mut best) = (0.0, cost(0.0));
    for k in 0..=n {
        let x = -r + h * k as f64;
        let c = cost(x);
        if c < best {
            best = c;
            best_x = x;
        }
    }
    let (mut a, mut b) = (best_x - h, best_x + h);
    let g = (5.0_f64.sqrt() - 1.0) / 2.0;
    for _ in 0..200 {
        let (x1, x2) = (b - g * (b - a), a + g * (b - a));
        if cost(x1) < cost(x2) {
            b = x2;
        } else {
            a = x1;
        }
    }
    best = best.min(cost(0.5 * (a + b)));
    1.0 / best
}

#[test]
fn real_and_complex_scalar_against_exact_search() {
    let s = BlockStructure::parse("r1,c1x1").expect("spec");
    let mut worst_gap: f64 = 0.0;
    let mut n_loose = 0;
    for seed in 1..=40u64 {
        let m = pseudo_random(2, 2, seed);
        let exact = exact_real_complex(m.as_ref());
        let r = mu(m.as_ref(), &s).expect("mu");
        let cplx = complex_bound(m.as_ref(), &s);
        assert!(
            r.upper >= exact * (1.0 - 1e-6),
            "seed {seed}: upper {} < exact {exact}",
            r.upper
        );
        assert!(r.upper >= r.lower, "seed {seed}");
        assert!(
            r.lower <= exact * (1.0 + 1e-9),
            "seed {seed}: lower {} > exact {exact}",
            r.lower
        );
        let gap = r.upper / exact - 1.0;
        if cplx > 1.1 * exact {
            n_loose += 1;
        }
        eprintln!(
            "seed {seed}: exact {exact:.6} dg {:.6} complex {cplx:.6} gap {gap:.2e}",
            r.upper
        );
        worst_gap = worst_gap.max(gap);
    }
    eprintln!("worst D-G gap {worst_gap:.3e}, {n_loose} cases with the complex bound > 10% loose");
    assert!(
        n_loose > 0,
        "no case where the complex bound is loose: the test shows nothing"
    );
    // Measured worst gap 5.8e-6 on these 40 matrices (the optimizer stops at rel_tol-level accuracy).
    assert!(worst_gap <= 1e-4, "D-G bound {worst_gap} above the exact mu");
}

#[test]
fn real_with_full_blocks_between_lower_and_complex_bound() {
    for (spec, n, seeds) in [("r1,f2x2,c1x1", 4, 1..=6u64), ("r2,f2x1,r1", 5, 7..=12u64)] {
        let s = BlockStructure::parse(spec).expect("spec");
        let (nr, nc) = (s.m_rows(), s.m_cols());
        assert_eq!(nr.max(nc), n);
        for seed in seeds {
            let m = pseudo_random(nr, nc, seed);
            let r = mu(m.as_ref(), &s).expect("mu");
            let cplx = complex_bound(m.as_ref(), &s);
            assert!(
                r.upper <= cplx * (1.0 + 1e-5),
                "{spec} seed {seed}: {} > complex {cplx}",
                r.upper
            );
            assert!(
                r.upper >= r.lower,
                "{spec} seed {seed}: {} < lower {}",
                r.upper,
                r.lower
            );
            eprintln!(
                "{spec} seed {seed}: lower {:.5} dg {:.5} complex {cplx:.5}",
                r.lower, r.upper
            );
        }
    }
}

#[test]
fn mixed_bound_is_none_without_real_blocks() {
    let s = BlockStructure::parse("c1x1,f2x2").expect("spec");
    let m = pseudo_random(3, 3, 3);
    let ub = upper_bound(m.as_ref(), &s, None, 0.0, &UpperOptions::default()).expect("ub");
    assert!(mixed_upper_bound(m.as_ref(), &s, &ub.d, ub.value, 0.0, 1e-6)
        .expect("mixed")
        .is_none());
}

/// λ_max(Mᴴ P_L M + j(G M − Mᴴ G) − β² P_R) relative to the size of its terms, built here from the
/// returned D and G independently of the library's own check.
fn lmi_residual(
    m: MatRef<c64>,
    s: &BlockStructure,
    d_left: MatRef<c64>,
    d_right_inv: MatRef<c64>,
    g: &[Mat<c64>],
    beta: f64,
) -> f64 {
    let (nr, nc) = (m.nrows(), m.ncols());
    let d_r = d_right_inv.partial_piv_lu().solve(Mat::<c64>::identity(nc, nc));
    let p_l = d_left.adjoint() * d_left;
    let p_r = d_r.adjoint() * &d_r;
    let mut gc = Mat::<c64>::zeros(nc, nr);
    for (j, blk) in s.blocks().iter().enumerate() {
        if blk.is_real() {
            for (p, cp) in s.col_range(j).enumerate() {
                for (q, rq) in s.row_range(j).enumerate() {
                    gc[(cp, rq)] = g[j][(p, q)];
                }
            }
            assert!(
                (&g[j] - g[j].adjoint()).norm_l2() <= 1e-14 * g[j].norm_l2().max(1.0),
                "G not Hermitian"
            );
        } else {
            assert_eq!(g[j].nrows(), 0, "G on a complex block");
        }
    }
    let mpm = m.adjoint() * &p_l * m;
    let gm = &gc * m;
    let jj = c64::new(0.0, 1.0);
    let a = Mat::from_fn(nc, nc, |p, q| {
        mpm[(p, q)] + jj * (gm[(p, q)] - gm[(q, p)].conj()) - p_r[(p, q)] * beta * beta
    });
    let lam = a.self_adjoint_eigen(Side::Lower).expect("eig");
    let top = (0..nc)
        .map(|i| lam.S().column_vector()[i].re)
        .fold(f64::NEG_INFINITY, f64::max);
    top / (mpm.norm_l2() + 2.0 * gm.norm_l2() + beta * beta * p_r.norm_l2())
}

#[test]
fn returned_scalings_satisfy_the_dg_inequality() {
    for (spec, seeds) in [
        ("r1,c1x1", 1..=10u64),
        ("r2,f2x1,r1", 11..=16u64),
        ("r1,c2r,f1x2", 17..=22u64),
    ] {
        let s = BlockStructure::parse(spec).expect("spec");
        for seed in seeds {
            let m = pseudo_random(s.m_rows(), s.m_cols(), seed);
            let ub = upper_bound(m.as_ref(), &s, None, 0.0, &UpperOptions::default()).expect("ub");
            let Some(mx) = mixed_upper_bound(m.as_ref(), &s, &ub.d, ub.value, 0.0, 1e-6).expect("mixed") else {
                panic!("{spec} seed {seed}: no certified D-G bound");
            };
            assert!(mx.value <= ub.value * (1.0 + 1e-12), "{spec} seed {seed}");
            let res = lmi_residual(
                m.as_ref(),
                &s,
                mx.d.left.as_ref(),
                mx.d.right_inv.as_ref(),
                &mx.g,
                mx.value,
            );
            assert!(res <= 1e-12, "{spec} seed {seed}: LMI residual {res:e}");
            // A slightly smaller β must violate it at these scalings only if the bound is tight there:
            // check instead that β·(1 − 1e-3) is not certified by the same (D, G) whenever β > 0.
            if mx.value > 0.0 {
                let under = lmi_residual(
                    m.as_ref(),
                    &s,
                    mx.d.left.as_ref(),
                    mx.d.right_inv.as_ref(),
                    &mx.g,
                    mx.value * (1.0 - 1e-3),
                );
                assert!(
                    under > 0.0,
                    "{spec} seed {seed}: the returned β is not the best for its own (D, G)"
                );
            }
        }
    }
}

/// Test-only 2×2 transfer matrix M(s) = [[2/(s+1), 1/(s+2)], [3/(s²+0.4s+1), 1/(s+0.5)]].
fn test_system(w: f64) -> skyloop_lti::error::Result<Mat<c64>> {
    let s = c64::new(0.0, w);
    let one = c64::new(1.0, 0.0);
    Ok(Mat::from_fn(2, 2, |i, j| match (i, j) {
        (0, 0) => one * 2.0 / (s + 1.0),
        (0, 1) => one / (s + 2.0),
        (1, 0) => one * 3.0 / (s * s + s * 0.4 + 1.0),
        _ => one / (s + 0.5),
    }))
}

#[test]
fn sweep_with_a_real_block_stays_between_the_bounds() {
    let s = BlockStructure::parse("r1,c1x1").expect("spec");
    let w: Vec<f64> = (0..40).map(|k| 10f64.powf(-1.0 + 2.0 * k as f64 / 39.0)).collect();
    let sw = mu_frequency(test_system, &w, &s, &MuOptions::default()).expect("sweep");
    for (k, &wk) in w.iter().enumerate() {
        let m = test_system(wk).expect("M");
        let exact = exact_real_complex(m.as_ref());
        let cplx = complex_bound(m.as_ref(), &s);
        assert!(sw.lower[k] <= sw.upper[k], "w {wk}");
        assert!(
            sw.upper[k] >= exact * (1.0 - 1e-6),
            "w {wk}: {} < exact {exact}",
            sw.upper[k]
        );
        assert!(
            sw.upper[k] <= exact * (1.0 + 1e-4),
            "w {wk}: {} vs exact {exact} (complex {cplx})",
            sw.upper[k]
        );
    }
    assert!(sw.peak.upper >= sw.peak.lower);
}

#[test]
fn mixed_bound_rejects_bad_input() {
    let s = BlockStructure::parse("r1,c1x1").expect("spec");
    let m = pseudo_random(2, 2, 5);
    let ub = upper_bound(m.as_ref(), &s, None, 0.0, &UpperOptions::default()).expect("ub");
    // D-scales of another structure.
    let other = BlockStructure::parse("r1,f2x2").expect("spec");
    let m3 = pseudo_random(3, 3, 6);
    let ub3 = upper_bound(m3.as_ref(), &other, None, 0.0, &UpperOptions::default()).expect("ub");
    assert!(mixed_upper_bound(m.as_ref(), &s, &ub3.d, ub.value, 0.0, 1e-6).is_err());
    let mut nan = m.clone();
    nan[(0, 1)] = c64::new(f64::NAN, 0.0);
    assert!(mixed_upper_bound(nan.as_ref(), &s, &ub.d, ub.value, 0.0, 1e-6).is_err());
    assert!(mixed_upper_bound(m3.as_ref(), &s, &ub.d, ub.value, 0.0, 1e-6).is_err());
}
