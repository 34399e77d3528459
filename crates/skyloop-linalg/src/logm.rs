//! Principal matrix logarithm by inverse scaling and squaring (Kenney–Laub; Higham, "Functions of
//! Matrices", 2008, §11.5): square roots (Denman–Beavers iteration) until ‖X − I‖₁ ≤ 1/4, then
//! log(I + Y) = ∫₀¹ Y (I + tY)⁻¹ dt by 8-point Gauss–Legendre quadrature (the [8/8] Padé approximant).

use crate::error::{LinalgError, Result};
use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef};

fn norm1(a: MatRef<f64>) -> f64 {
    (0..a.ncols())
        .map(|j| (0..a.nrows()).map(|i| a[(i, j)].abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// Gauss–Legendre nodes and weights on [0, 1] by Newton's method on the Legendre polynomial.
fn gauss_legendre_01(m: usize) -> Vec<(f64, f64)> {
    (1..=m)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 - 0.25) / (m as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                // Three-term recurrence for P_m(x) and its derivative.
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=m {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = m as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            ((x + 1.0) / 2.0, w / 2.0)
        })
        .collect()
}

/// Whether an eigenvalue `z` lies on the closed negative real axis (zero included, to a relative
/// 1e-14 in its imaginary part), where no real principal logarithm exists: [`logm`] refuses such a
/// matrix, and callers that can name the cause better (d2c: a discrete pole with no ZOH preimage)
/// test their own eigenvalues with the same rule.
pub fn has_no_real_logarithm(z: faer::c64) -> bool {
    z.re <= 0.0 && z.im.abs() <= 1e-14 * z.re.abs().max(1e-300)
}

/// Principal logarithm of a real square matrix with no eigenvalues on the closed negative real axis.
pub fn logm(a: MatRef<f64>) -> Result<Mat<f64>> {
    let n = a.nrows();
    if a.ncols() != n {
        return Err(LinalgError::Dimension(format!(
            "logm needs a square matrix, got {}x{}",
            n,
            a.ncols()
        )));
    }
    if !norm1(a).is_finite() {
        return Err(LinalgError::InvalidArgument(
            "logm: matrix has non-finite entries".into(),
        ));
    }
    if n == 0 {
        return Ok(Mat::zeros(0, 0));
    }
    if let Ok(ev) = a.to_owned().eigenvalues() {
        if ev.iter().any(|&z| has_no_real_logarithm(z)) {
            return Err(LinalgError::InvalidArgument(
                "logm: the matrix has an eigenvalue on the closed negative real axis (no real principal logarithm)"
                    .into(),
            ));
        }
    }
    let eye = Mat::<f64>::identity(n, n);
    let mut x = a.to_owned();
    let mut k = 0;
    while norm1((&x - &eye).as_ref()) > 0.25 {
        if k > 60 {
            return Err(LinalgError::NoConvergence("logm: too many square roots".into()));
        }
        x = sqrtm_db(&x)?;
        k += 1;
    }
    let y = &x - &eye;
    let mut l = Mat::<f64>::zeros(n, n);
    for (t, w) in gauss_legendre_01(8) {
        let m = &eye + &y * faer::Scale(t);
        l += m.partial_piv_lu().solve(&y) * faer::Scale(w);
    }
    Ok(l * faer::Scale(2f64.powi(k)))
}

/// Principal square root by the Denman–Beavers iteration with determinant scaling (Higham,
/// *Functions of Matrices*, 2008, §6.3): Y ← ½(μY + μ⁻¹Z⁻¹), Z ← ½(μZ + μ⁻¹Y⁻¹), μ = |det Y·det Z|^(−1/(2n)).
/// Unscaled, the iteration only halves the spread of eigenvalues per step: on a discrete pole at
/// z = 1e-30 it stopped, 100 steps later, at a square root whose logarithm was 2 % off (d2c gave a
/// pole at −6773 rad/s for −6908), and at z ≤ 1e-100 at −6793 whatever z. Scaled, it takes a few steps.
fn sqrtm_db(a: &Mat<f64>) -> Result<Mat<f64>> {
    let n = a.nrows();
    let mut y = a.clone();
    let mut z = Mat::<f64>::identity(n, n);
    // ln|det| from the LU's U diagonal, so the scaling neither overflows nor underflows.
    let log_abs_det = |lu: &faer::linalg::solvers::PartialPivLu<f64>| -> f64 {
        let u = lu.U();
        (0..u.nrows()).map(|i| u[(i, i)].abs().ln()).sum()
    };
    let eye = Mat::<f64>::identity(n, n);
    for it in 0..100 {
        let (ylu, zlu) = (y.partial_piv_lu(), z.partial_piv_lu());
        let yi = ylu.solve(&eye);
        let zi = zlu.solve(&eye);
        // Scaling only while far from convergence (it would slow the final quadratic steps).
        let mu = if it < 30 {
            let l = -(log_abs_det(&ylu) + log_abs_det(&zlu)) / (2.0 * n as f64);
            if l.is_finite() {
                l.exp()
            } else {
                1.0
            }
        } else {
            1.0
        };
        let yn = (&y * faer::Scale(mu) + &zi * faer::Scale(1.0 / mu)) * faer::Scale(0.5);
        let zn = (&z * faer::Scale(mu) + &yi * faer::Scale(1.0 / mu)) * faer::Scale(0.5);
        let diff = norm1((&yn - &y).as_ref());
        y = yn;
        z = zn;
        if !diff.is_finite() {
            return Err(LinalgError::Singular("logm: square-root iteration broke down".into()));
        }
        if diff <= 1e-15 * norm1(y.as_ref()) {
            return Ok(y);
        }
    }
    Err(LinalgError::NoConvergence(
        "logm: square-root iteration did not converge".into(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expm::expm;

    #[test]
    fn inverts_expm() {
        // log(exp(A)) = A when the eigenvalues of A have |Im| < π.
        let a = Mat::from_fn(3, 3, |i, j| {
            [[-1.0, 2.0, 0.5], [-0.5, -0.3, 1.0], [0.2, 0.0, -2.0]][i][j]
        });
        let e = expm(a.as_ref()).unwrap();
        let l = logm(e.as_ref()).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                assert!((l[(i, j)] - a[(i, j)]).abs() < 1e-12, "({i},{j})");
            }
        }
        // Jordan block: log([[1, 1], [0, 1]]) = [[0, 1], [0, 0]].
        let j = Mat::from_fn(2, 2, |i, k| if k >= i { 1.0 } else { 0.0 });
        let l = logm(j.as_ref()).unwrap();
        assert!((l[(0, 1)] - 1.0).abs() < 1e-14 && l[(0, 0)].abs() < 1e-14);
    }

    /// Eigenvalues from 1e-300 to 1: the unscaled square-root iteration gave ln(1e-100) = −67.9
    /// (true −230.3), which made d2c place a discrete pole at z = 1e-100 at −6793 rad/s.
    #[test]
    fn widely_spread_eigenvalues_have_exact_logarithms() {
        for v in [1e-30, 1e-100, 1e-300, 3e7] {
            let l = logm(Mat::from_fn(1, 1, |_, _| v).as_ref()).unwrap();
            assert!(
                (l[(0, 0)] - v.ln()).abs() < 1e-12 * v.ln().abs(),
                "ln({v}) = {}",
                l[(0, 0)]
            );
        }
        // Upper triangular, non-normal: log of [[a, c], [0, b]] is [[ln a, c(ln a − ln b)/(a − b)], [0, ln b]].
        let (av, bv, cv) = (1e-40, 0.9, 2.0);
        let m = Mat::from_fn(2, 2, |i, j| [[av, cv], [0.0, bv]][i][j]);
        let l = logm(m.as_ref()).unwrap();
        let off = cv * (av.ln() - bv.ln()) / (av - bv);
        assert!((l[(0, 0)] - av.ln()).abs() < 1e-12 * av.ln().abs(), "{:?}", l);
        assert!((l[(1, 1)] - bv.ln()).abs() < 1e-12, "{:?}", l);
        assert!((l[(0, 1)] - off).abs() < 1e-10 * off.abs(), "{} vs {off}", l[(0, 1)]);
        assert!(l[(1, 0)].abs() < 1e-14);
    }

    #[test]
    fn negative_eigenvalue_is_error() {
        let a = Mat::from_fn(1, 1, |_, _| -2.0);
        assert!(logm(a.as_ref()).is_err());
    }
}
