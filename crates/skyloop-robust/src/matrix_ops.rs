//! Small dense helpers shared by the synthesis modules (block assembly, checked inverses, spectra).

use crate::error::Result;
use crate::error::RobustError;
use faer::linalg::solvers::DenseSolveCore;
use faer::{Mat, MatRef, Side};

/// Stacks blocks side by side; every block must have the same number of rows (`rows` is used when all are empty).
pub(crate) fn hcat(blocks: &[MatRef<f64>], rows: usize) -> Mat<f64> {
    let ncols: usize = blocks.iter().map(|b| b.ncols()).sum();
    let mut m = Mat::zeros(rows, ncols);
    let mut j = 0;
    for b in blocks {
        m.get_mut(.., j..j + b.ncols()).copy_from(b);
        j += b.ncols();
    }
    m
}

/// Stacks blocks on top of each other; every block must have the same number of columns.
pub(crate) fn vcat(blocks: &[MatRef<f64>], cols: usize) -> Mat<f64> {
    let nrows: usize = blocks.iter().map(|b| b.nrows()).sum();
    let mut m = Mat::zeros(nrows, cols);
    let mut i = 0;
    for b in blocks {
        m.get_mut(i..i + b.nrows(), ..).copy_from(b);
        i += b.nrows();
    }
    m
}

/// Singular values in non-increasing order (empty for an empty matrix).
pub(crate) fn singular_values(m: MatRef<f64>) -> Result<Vec<f64>> {
    if m.nrows() == 0 || m.ncols() == 0 {
        return Ok(Vec::new());
    }
    m.singular_values()
        .map_err(|_| RobustError::Numerical("SVD did not converge".into()))
}

/// Largest singular value (0 for an empty matrix).
pub(crate) fn sigma_max(m: MatRef<f64>) -> Result<f64> {
    Ok(singular_values(m)?.first().copied().unwrap_or(0.0))
}

/// Inverse of a square matrix, or an error naming `what` when it is singular to working precision.
pub(crate) fn inv(m: MatRef<f64>, what: &str) -> Result<Mat<f64>> {
    let n = m.nrows();
    if n == 0 {
        return Ok(Mat::zeros(0, 0));
    }
    let s = singular_values(m)?;
    let (smax, smin) = (s[0], s[n - 1]);
    if !(smin > 1e-13 * smax.max(f64::MIN_POSITIVE)) {
        return Err(RobustError::Numerical(format!(
            "{what} is singular (condition number {:.3e})",
            smax / smin
        )));
    }
    Ok(m.full_piv_lu().inverse())
}

/// Smallest eigenvalue of the symmetric part of a square matrix (+inf for an empty one).
pub(crate) fn sym_min_eig(m: MatRef<f64>) -> Result<f64> {
    let n = m.nrows();
    if n == 0 {
        return Ok(f64::INFINITY);
    }
    let s = Mat::from_fn(n, n, |i, j| 0.5 * (m[(i, j)] + m[(j, i)]));
    let ev = s
        .self_adjoint_eigenvalues(Side::Lower)
        .map_err(|_| RobustError::Numerical("symmetric eigenvalues did not converge".into()))?;
    Ok(ev[0])
}

/// Spectral radius of a square matrix (0 for an empty one).
pub(crate) fn spectral_radius(m: MatRef<f64>) -> Result<f64> {
    if m.nrows() == 0 {
        return Ok(0.0);
    }
    let ev = m
        .eigenvalues()
        .map_err(|_| RobustError::Numerical("eigenvalues did not converge".into()))?;
    Ok(ev.iter().map(|l| l.norm()).fold(0.0, f64::max))
}

/// Largest real part of the eigenvalues of a square matrix (−inf for an empty one).
pub(crate) fn max_real_eig(m: MatRef<f64>) -> Result<f64> {
    if m.nrows() == 0 {
        return Ok(f64::NEG_INFINITY);
    }
    let ev = m
        .eigenvalues()
        .map_err(|_| RobustError::Numerical("eigenvalues did not converge".into()))?;
    Ok(ev.iter().map(|l| l.re).fold(f64::NEG_INFINITY, f64::max))
}

/// PBH test: the first eigenvalue of A with real part ≥ −tol at which [A − λI, B] loses row rank.
///
/// Used to tell the user that (A, B) is not stabilizable (or, with transposes, (C, A) not detectable).
pub(crate) fn uncontrollable_unstable_mode(a: MatRef<f64>, b: MatRef<f64>) -> Result<Option<faer::c64>> {
    use faer::c64;
    let n = a.nrows();
    if n == 0 {
        return Ok(None);
    }
    let scale = a.norm_max().max(b.norm_max()).max(1.0);
    let ev = a
        .eigenvalues()
        .map_err(|_| RobustError::Numerical("eigenvalues did not converge".into()))?;
    for lam in ev {
        if lam.re < -1e-8 * scale {
            continue;
        }
        let m = Mat::<c64>::from_fn(n, n + b.ncols(), |i, j| {
            if j < n {
                c64::new(a[(i, j)], 0.0) - if i == j { lam } else { c64::new(0.0, 0.0) }
            } else {
                c64::new(b[(i, j - n)], 0.0)
            }
        });
        let s = m
            .singular_values()
            .map_err(|_| RobustError::Numerical("SVD did not converge".into()))?;
        if s[n - 1] <= 1e-9 * scale {
            return Ok(Some(lam));
        }
    }
    Ok(None)
}

/// The same model in balanced state coordinates (see `StateSpace::balance_states`).
pub(crate) fn balance_states(sys: &skyloop_lti::StateSpace) -> Result<skyloop_lti::StateSpace> {
    Ok(sys.balance_states()?)
}
