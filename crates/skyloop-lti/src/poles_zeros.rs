//! Poles, transmission zeros (system pencil, Emami-Naeini–Van Dooren reduction) and DC gain.

use crate::error::{LtiError, Result};
use crate::ss::StateSpace;
use faer::linalg::solvers::Solve;
use faer::{c64, Mat};

/// Poles: eigenvalues of A (rad/s in continuous time, z-plane points in discrete time).
///
/// # Errors
/// Eigenvalues that do not converge.
///
/// # Examples
/// ```
/// let g = skyloop_lti::expr::parse_model("(s+2)/((s+1)*(s+3))")?;
/// let mut p: Vec<f64> = skyloop_lti::poles_zeros::poles(&g)?.iter().map(|z| z.re).collect();
/// p.sort_by(f64::total_cmp);
/// assert!((p[0] + 3.0).abs() < 1e-12 && (p[1] + 1.0).abs() < 1e-12);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn poles(sys: &StateSpace) -> Result<Vec<c64>> {
    if sys.nx() == 0 {
        return Ok(Vec::new());
    }
    sys.a
        .eigenvalues()
        .map_err(|e| LtiError::Numerical(format!("eigenvalues of A: {e:?}")))
}

/// Steady-state gain (ny × nu): `D − C A⁻¹ B` in continuous time, `D + C (I − A)⁻¹ B` in discrete
/// time; entries are infinite when the model has a pole at s = 0 (z = 1), as in MATLAB `dcgain`.
pub fn dcgain(sys: &StateSpace) -> Result<Mat<f64>> {
    let n = sys.nx();
    let m = if sys.is_continuous() {
        Mat::<f64>::from_fn(n, n, |i, j| -sys.a[(i, j)])
    } else {
        Mat::<f64>::from_fn(n, n, |i, j| f64::from(u8::from(i == j)) - sys.a[(i, j)])
    };
    let lu = m.full_piv_lu();
    let u = lu.U();
    let big = (0..n).map(|i| u[(i, i)].abs()).fold(0.0, f64::max);
    let small = (0..n).map(|i| u[(i, i)].abs()).fold(f64::INFINITY, f64::min);
    if n > 0 && small <= 1e-14 * big.max(f64::MIN_POSITIVE) {
        return Ok(Mat::from_fn(sys.ny(), sys.nu(), |_, _| f64::INFINITY));
    }
    let x = lu.solve(&sys.b);
    Ok(&sys.d + &sys.c * &x)
}

/// Transmission zeros: finite generalized eigenvalues of the system pencil
/// `[[A − λI, B], [C, D]]` after the Emami-Naeini–Van Dooren (1982) reduction, which removes the
/// infinite and non-square structure so that the remaining pencil is square and regular.
///
/// Uses faer's QZ on the reduced pencil; models with more than 150 states are refused because
/// faer's QZ can be very slow there.
///
/// # Errors
/// A model with more than 150 states, or a pencil whose QZ does not converge.
///
/// # Examples
/// ```
/// let g = skyloop_lti::expr::parse_model("(s+2)/((s+1)*(s+3))")?;
/// let z = skyloop_lti::poles_zeros::zeros(&g)?;
/// assert_eq!(z.len(), 1);
/// assert!((z[0].re + 2.0).abs() < 1e-10);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn zeros(sys: &StateSpace) -> Result<Vec<c64>> {
    if sys.nx() > 150 {
        return Err(LtiError::Unsupported(format!(
            "zeros: {} states is above the supported 150 (faer QZ)",
            sys.nx()
        )));
    }
    let scale = frob(&sys.a) + frob(&sys.b) + frob(&sys.c) + frob(&sys.d);
    let tol = 1e-13 * scale.max(f64::MIN_POSITIVE) * (sys.nx() + sys.nu() + sys.ny()) as f64;
    let (a, b, c, d) = reduce(sys.a.clone(), sys.b.clone(), sys.c.clone(), sys.d.clone(), tol)?;
    // Dual pass on the pertransposed system makes D of full column rank too.
    let (at, ct, bt, dt) = reduce(
        a.transpose().to_owned(),
        c.transpose().to_owned(),
        b.transpose().to_owned(),
        d.transpose().to_owned(),
        tol,
    )?;
    let (a, b, c, d) = (
        at.transpose().to_owned(),
        bt.transpose().to_owned(),
        ct.transpose().to_owned(),
        dt.transpose().to_owned(),
    );
    let (n, m, p) = (a.nrows(), b.ncols(), c.nrows());
    if n == 0 {
        return Ok(Vec::new());
    }
    if m != p {
        return Err(LtiError::Numerical(format!(
            "zeros: the reduced pencil is not square ({p} outputs, {m} inputs)"
        )));
    }
    // Compress the columns of [C D] so that [C D]·W = [0, Df]; the zeros are the eigenvalues of
    // the n×n pencil formed by the first n columns of [A B]·W and [I 0]·W.
    let cd = Mat::<f64>::from_fn(p, n + m, |i, j| if j < n { c[(i, j)] } else { d[(i, j - n)] });
    let w = if p == 0 {
        Mat::<f64>::identity(n + m, n + m)
    } else {
        let svd = cd
            .svd()
            .map_err(|e| LtiError::Numerical(format!("zeros: SVD failed: {e:?}")))?;
        let v = svd.V();
        Mat::<f64>::from_fn(n + m, n + m, |i, j| v[(i, n + m - 1 - j)])
    };
    let af = Mat::<f64>::from_fn(n, n, |i, j| {
        (0..n).map(|k| a[(i, k)] * w[(k, j)]).sum::<f64>() + (0..m).map(|k| b[(i, k)] * w[(n + k, j)]).sum::<f64>()
    });
    let ef = Mat::<f64>::from_fn(n, n, |i, j| w[(i, j)]);
    let (sa, sb) = generalized_eigenvalues(af, ef)?;
    let mut out = Vec::new();
    for k in 0..n {
        let (alpha, beta) = (sa[k], c64::new(sb[k], 0.0));
        // Infinite eigenvalues of the reduced pencil (singular Ef) are not zeros.
        if beta.norm() > 1e-12 * alpha.norm() && beta.norm() > 0.0 {
            out.push(alpha / beta);
        }
    }
    Ok(out)
}

/// Eigenvalues α/β of the real pencil (A, E) by skyloop-linalg's QZ, without eigenvectors:
/// (α, β) pairs, complex pairs as conjugates with equal β, β = 0 for infinite eigenvalues.
/// (faer 0.24's `gevd_real` returned a wrong member of complex pairs, and non-finite eigenvalues
/// for every random pencil of order 60 to 300 with a well-conditioned E that was tried.)
pub(crate) fn generalized_eigenvalues(a: Mat<f64>, e: Mat<f64>) -> Result<(Vec<c64>, Vec<f64>)> {
    skyloop_linalg::qz::generalized_eigenvalues(a.as_ref(), e.as_ref())
        .map_err(|err| LtiError::Numerical(format!("QZ failed: {err}")))
}

fn frob(m: &Mat<f64>) -> f64 {
    m.norm_l2()
}

/// Full SVD (U, singular values, V) that also accepts empty matrices.
fn svd_full(m: &Mat<f64>) -> Result<(Mat<f64>, Vec<f64>, Mat<f64>)> {
    let (r, c) = (m.nrows(), m.ncols());
    if r == 0 || c == 0 {
        return Ok((Mat::identity(r, r), Vec::new(), Mat::identity(c, c)));
    }
    let s = m.svd().map_err(|e| LtiError::Numerical(format!("SVD failed: {e:?}")))?;
    let sv = (0..r.min(c)).map(|k| s.S().column_vector()[k]).collect();
    Ok((s.U().to_owned(), sv, s.V().to_owned()))
}

fn rank(sv: &[f64], tol: f64) -> usize {
    sv.iter().filter(|&&x| x > tol).count()
}

/// (A, B, C, D) of an intermediate system.
type Quad = (Mat<f64>, Mat<f64>, Mat<f64>, Mat<f64>);

/// One Emami-Naeini–Van Dooren reduction: returns a system with the same finite zeros whose D has
/// full row rank, by repeatedly compressing the rows of D and the columns of the remaining C rows.
fn reduce(mut a: Mat<f64>, mut b: Mat<f64>, mut c: Mat<f64>, mut d: Mat<f64>, tol: f64) -> Result<Quad> {
    loop {
        let (n, m, p) = (a.nrows(), b.ncols(), c.nrows());
        // Row compression of D: Uᵣᵀ·D has its ρ non-zero rows last.
        let (u, sv, _) = svd_full(&d)?;
        let rho = rank(&sv, tol);
        if rho == p {
            return Ok((a, b, c, d));
        }
        let ur = Mat::<f64>::from_fn(p, p, |i, j| u[(i, p - 1 - j)]);
        let cb = ur.transpose() * &c;
        let db = ur.transpose() * &d;
        let cbar = Mat::<f64>::from_fn(p - rho, n, |i, j| cb[(i, j)]);
        let ctil = Mat::<f64>::from_fn(rho, n, |i, j| cb[(p - rho + i, j)]);
        let dtil = Mat::<f64>::from_fn(rho, m, |i, j| db[(p - rho + i, j)]);
        // Column compression of C̄: C̄·V has its μ non-zero columns last.
        let (_, sv2, v2) = svd_full(&cbar)?;
        let mu = rank(&sv2, tol);
        if mu == 0 {
            // The C̄ rows are identically zero in the pencil: drop them.
            return Ok((a, b, ctil, dtil));
        }
        let v = Mat::<f64>::from_fn(n, n, |i, j| v2[(i, n - 1 - j)]);
        let at = v.transpose() * &a * &v;
        let bt = v.transpose() * &b;
        let ct = &ctil * &v;
        let nk = n - mu;
        let a_new = Mat::<f64>::from_fn(nk, nk, |i, j| at[(i, j)]);
        let b_new = Mat::<f64>::from_fn(nk, m, |i, j| bt[(i, j)]);
        let c_new = Mat::<f64>::from_fn(
            mu + rho,
            nk,
            |i, j| if i < mu { at[(nk + i, j)] } else { ct[(i - mu, j)] },
        );
        let d_new = Mat::<f64>::from_fn(
            mu + rho,
            m,
            |i, j| if i < mu { bt[(nk + i, j)] } else { dtil[(i - mu, j)] },
        );
        (a, b, c, d) = (a_new, b_new, c_new, d_new);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::parse_model;

    fn sorted(mut v: Vec<c64>) -> Vec<c64> {
        v.sort_by(|x, y| x.re.total_cmp(&y.re).then(x.im.total_cmp(&y.im)));
        v
    }

    #[test]
    fn siso_zeros_and_poles_from_factors() {
        // Zeros ±42 and poles 0, -1/0.0256, roots of s^2+666.4 s+2.221e5 (bicopter eq. (8) factors).
        let g = parse_model("(42^2 - s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5)/(0.0256*s+1)").unwrap();
        let z = sorted(zeros(&g).unwrap());
        assert_eq!(z.len(), 2);
        assert!(
            (z[0] - c64::new(-42.0, 0.0)).norm() < 1e-9 && (z[1] - c64::new(42.0, 0.0)).norm() < 1e-9,
            "{z:?}"
        );
        let p = sorted(poles(&g).unwrap());
        assert_eq!(p.len(), 4);
        assert!((p[2] - c64::new(-1.0 / 0.0256, 0.0)).norm() < 1e-9);
        assert!(p[3].norm() < 1e-12);
    }

    #[test]
    fn non_square_and_degenerate() {
        // Two outputs of the same first-order state with zeros at -2 and -3 separately: no common zero.
        let g = StateSpace::from_rows(
            &[vec![-1.0]],
            &[vec![1.0]],
            &[vec![1.0], vec![1.0]],
            &[vec![1.0], vec![1.0]],
            0.0,
        )
        .unwrap();
        // Both outputs are (s+2)/(s+1): the common zero -2 is a transmission zero of the column.
        let z = zeros(&g).unwrap();
        assert_eq!(z.len(), 1);
        assert!((z[0] - c64::new(-2.0, 0.0)).norm() < 1e-12, "{z:?}");
        let g2 = StateSpace::from_rows(
            &[vec![-1.0]],
            &[vec![1.0]],
            &[vec![1.0], vec![2.0]],
            &[vec![1.0], vec![1.0]],
            0.0,
        )
        .unwrap();
        assert!(zeros(&g2).unwrap().is_empty());
        // Strictly proper 1/(s+1)^2: no finite zeros.
        let g3 = parse_model("1/(s+1)^2").unwrap();
        assert!(zeros(&g3).unwrap().is_empty());
    }

    #[test]
    fn dc_gain() {
        let g = parse_model("3*(s+2)/((s+1)*(s+4))").unwrap();
        // 3·2/(1·4) = 1.5 by hand.
        assert!((dcgain(&g).unwrap()[(0, 0)] - 1.5).abs() < 1e-13);
        let i = parse_model("1/s").unwrap();
        assert!(dcgain(&i).unwrap()[(0, 0)].is_infinite());
    }
}

#[cfg(test)]
mod qz_tests {
    use super::*;

    #[test]
    fn random_pencils_match_dense() {
        // Orders where faer 0.24's QZ returned non-finite eigenvalues (60) and a small one.
        let mut state = 5u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for n in [7, 60] {
            let a = Mat::from_fn(n, n, |_, _| next());
            let e = Mat::from_fn(n, n, |i, j| next() + if i == j { 3.0 } else { 0.0 });
            let (al, be) = generalized_eigenvalues(a.clone(), e.clone()).unwrap();
            let mut want = e.partial_piv_lu().solve(&a).eigenvalues().unwrap();
            for (x, y) in al.iter().zip(&be) {
                let z = x / y;
                let pos = want.iter().position(|w| (w - z).norm() < 1e-9 * (1.0 + w.norm()));
                assert!(pos.is_some(), "n={n}: {z} not among {want:?}");
                want.remove(pos.unwrap_or(0));
            }
        }
    }

    #[test]
    fn zeros_of_a_large_model_with_invertible_d() {
        // With D = I the zeros are the eigenvalues of A − B·C, all n of them. (With faer's QZ
        // this returned 4 zeros instead of 80 for an 80-state random 2×2 model.)
        let mut state = 17u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let n = 70;
        let a = Mat::from_fn(n, n, |i, j| next() - if i == j { 9.0 } else { 0.0 });
        let b = Mat::from_fn(n, 2, |_, _| next());
        let c = Mat::from_fn(2, n, |_, _| next());
        let sys = StateSpace::new(a.clone(), b.clone(), c.clone(), Mat::identity(2, 2), 0.0).unwrap();
        let z = zeros(&sys).unwrap();
        assert_eq!(z.len(), n);
        let mut want = (&a - &b * &c).eigenvalues().unwrap();
        for v in z {
            let pos = want.iter().position(|w| (w - v).norm() < 1e-8 * (1.0 + w.norm()));
            assert!(pos.is_some(), "{v} not an eigenvalue of A − BC");
            want.remove(pos.unwrap_or(0));
        }
    }

    #[test]
    fn pencil_eigenvalues_match_dense() {
        let a = Mat::from_fn(3, 3, |i, j| {
            [[-1.0, 2.0, 0.5], [-4.0, -2.0, 1.0], [0.3, 0.1, -3.0]][i][j]
        });
        let e = Mat::from_fn(3, 3, |i, j| [[1.0, 0.2, 0.0], [0.1, 0.7, 0.3], [0.0, 0.4, 1.5]][i][j]);
        let (al, be) = generalized_eigenvalues(a.clone(), e.clone()).unwrap();
        let mut want = e.partial_piv_lu().solve(&a).eigenvalues().unwrap();
        for k in 0..3 {
            let z = al[k] / be[k];
            let pos = want.iter().position(|w| (w - z).norm() < 1e-12 * (1.0 + w.norm()));
            assert!(pos.is_some(), "{z} not among {want:?}");
            want.remove(pos.unwrap_or(0));
        }
    }
}
