//! Sylvester equations by the Bartels–Stewart method: reduce both coefficients to real Schur form,
//! then solve the quasi-triangular equation block by block (as LAPACK dtrsyl, with dlasy2-style
//! 1×1/2×2 kernels solved by complete pivoting and a scale factor that keeps the solution finite).
//!
//! The quasi-triangular kernels are public because Lyapunov solvers, Hammarling's method and the
//! stable/unstable splitting of models all work directly on Schur forms.

// Index loops mirror the published block algorithms (dtrsyl, Hammarling) and read better here.
#![allow(clippy::needless_range_loop)]

use crate::error::{LinalgError, Result};
use crate::schur::real_schur;
use faer::{Mat, MatRef};

/// Which quasi-triangular equation to solve: continuous `A·X + X·B = C` or discrete `A·X·B − X = C`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `A·X + X·B = C` (Sylvester, continuous Lyapunov).
    Continuous,
    /// `A·X·B − X = C` (Stein, discrete Lyapunov).
    Discrete,
}

/// Solves A·X + X·B = C for X (A m×m, B n×n, C m×n) by Bartels–Stewart.
///
/// Fails with `NoSolution` when A and −B share an eigenvalue to working precision.
pub fn sylvester(a: MatRef<f64>, b: MatRef<f64>, c: MatRef<f64>) -> Result<Mat<f64>> {
    check_square(a, "A")?;
    check_square(b, "B")?;
    if c.nrows() != a.nrows() || c.ncols() != b.nrows() {
        return Err(LinalgError::Dimension(format!(
            "C must be {}x{} for A {}x{} and B {}x{}, got {}x{}",
            a.nrows(),
            b.nrows(),
            a.nrows(),
            a.nrows(),
            b.nrows(),
            b.nrows(),
            c.nrows(),
            c.ncols()
        )));
    }
    check_finite(a, "A")?;
    check_finite(b, "B")?;
    check_finite(c, "C")?;
    let sa = real_schur(a)?;
    let sb = real_schur(b)?;
    // Qaᵀ·C·Qb is the right-hand side in Schur coordinates.
    let f = sa.q.transpose() * c * &sb.q;
    let y = solve_quasi_triangular(sa.t.as_ref(), sb.t.as_ref(), f.as_ref(), Kind::Continuous)?;
    Ok(&sa.q * &y * sb.q.transpose())
}

/// Solves the quasi-triangular equation `TA·X + X·TB = C` (continuous) or `TA·X·TB − X = C`
/// (discrete), where TA and TB are upper quasi-triangular (1×1 and 2×2 diagonal blocks, a 2×2 block
/// marked by a non-zero subdiagonal entry; the blocks need not be standardized).
///
/// Fails with `NoSolution` when the equation is singular to working precision (λ(TA) = −λ(TB),
/// respectively λ(TA)·λ(TB) = 1), or when the solution would overflow.
pub fn solve_quasi_triangular(ta: MatRef<f64>, tb: MatRef<f64>, c: MatRef<f64>, kind: Kind) -> Result<Mat<f64>> {
    let (m, n) = (ta.nrows(), tb.nrows());
    check_square(ta, "TA")?;
    check_square(tb, "TB")?;
    if c.nrows() != m || c.ncols() != n {
        return Err(LinalgError::Dimension(format!(
            "C must be {m}x{n}, got {}x{}",
            c.nrows(),
            c.ncols()
        )));
    }
    let ba = blocks(ta);
    let smin = smallest_pivot(ta, tb);
    solve_quasi_triangular_prepared(ta, tb, c, kind, &ba, smin)
}

/// [`solve_quasi_triangular`] with TA's diagonal blocks `ba` ([`blocks`]`(ta)`) and the pivot
/// floor `smin` ([`pivot_floor`] of TA's and TB's largest entry) supplied by the caller (checked sizes).
///
/// Why: Hammarling's recursion solves one such equation per diagonal block on a leading part of
/// the same T; scanning that part for its blocks and its largest entry read as much memory as the
/// solve itself.
pub(crate) fn solve_quasi_triangular_prepared(
    ta: MatRef<f64>,
    tb: MatRef<f64>,
    c: MatRef<f64>,
    kind: Kind,
    ba: &[(usize, usize)],
    smin: f64,
) -> Result<Mat<f64>> {
    let (m, n) = (ta.nrows(), tb.nrows());
    // Scalar block recurrences follow, often right after faer products (see `clear_upper_simd`).
    crate::dense::clear_upper_simd();
    let bb = blocks(tb);
    let mut x = c.to_owned();
    let mut scale = 1.0;
    // Work buffer for the discrete case: R = X[:, :l]·TB[:l, l] and the product TA·R.
    let mut r = Mat::<f64>::zeros(m, 2);
    for &(l0, ql) in &bb {
        match kind {
            Kind::Continuous => {
                // Column block l of X·TB brings in the already solved columns j < l.
                for jj in 0..ql {
                    let j = l0 + jj;
                    for p in 0..l0 {
                        let t = tb[(p, j)];
                        if t != 0.0 {
                            for i in 0..m {
                                x[(i, j)] -= x[(i, p)] * t;
                            }
                        }
                    }
                }
            }
            Kind::Discrete => {
                for jj in 0..ql {
                    let j = l0 + jj;
                    for i in 0..m {
                        r[(i, jj)] = 0.0;
                    }
                    for p in 0..l0 {
                        let t = tb[(p, j)];
                        if t != 0.0 {
                            for i in 0..m {
                                r[(i, jj)] += x[(i, p)] * t;
                            }
                        }
                    }
                    // rhs −= TA·R (TA upper Hessenberg at most, so row i needs columns ≥ i−1).
                    for p in 0..m {
                        let rp = r[(p, jj)];
                        if rp != 0.0 {
                            let top = (p + 2).min(m);
                            for i in 0..top {
                                x[(i, j)] -= ta[(i, p)] * rp;
                            }
                        }
                    }
                }
            }
        }
        for &(k0, pk) in ba.iter().rev() {
            let mut rhs = [[0.0; 2]; 2];
            for (ii, row) in rhs.iter_mut().enumerate().take(pk) {
                for (jj, v) in row.iter_mut().enumerate().take(ql) {
                    *v = x[(k0 + ii, l0 + jj)];
                }
            }
            let a11 = small(ta, k0, pk);
            let b11 = small(tb, l0, ql);
            let (sol, s) = solve_small(&a11, pk, &b11, ql, &rhs, kind, smin)?;
            if s != 1.0 {
                // Rescale everything solved and still to solve so the equation stays consistent.
                for j in 0..n {
                    for i in 0..m {
                        x[(i, j)] *= s;
                    }
                }
                for j in 0..ql {
                    for i in 0..m {
                        r[(i, j)] *= s;
                    }
                }
                scale *= s;
            }
            for (ii, row) in sol.iter().enumerate().take(pk) {
                for (jj, &v) in row.iter().enumerate().take(ql) {
                    x[(k0 + ii, l0 + jj)] = v;
                }
            }
            if k0 == 0 {
                continue;
            }
            // Propagate the solved block to the rows above it.
            let mut w = [[0.0; 2]; 2];
            for ii in 0..pk {
                for jj in 0..ql {
                    w[ii][jj] = match kind {
                        Kind::Continuous => sol[ii][jj],
                        Kind::Discrete => (0..ql).map(|q| sol[ii][q] * b11[q][jj]).sum(),
                    };
                }
            }
            for jj in 0..ql {
                for (ii, wrow) in w.iter().enumerate().take(pk) {
                    let v = wrow[jj];
                    if v != 0.0 {
                        sub_scaled_column(&mut x, l0 + jj, ta, k0 + ii, k0, v);
                    }
                }
            }
            if kind == Kind::Discrete {
                // TA_kk's own coupling to R_k is part of the rhs already; rows above also see R_k.
            }
        }
    }
    if scale != 1.0 {
        let inv = 1.0 / scale;
        for j in 0..n {
            for i in 0..m {
                x[(i, j)] *= inv;
            }
        }
        if !is_finite(x.as_ref()) {
            return Err(LinalgError::NoSolution(
                "Sylvester solution overflows (nearly singular equation)".into(),
            ));
        }
    }
    Ok(x)
}

/// x[..len, j] −= v·a[..len, col], on contiguous slices when both columns are (they are for owned
/// matrices and column-major views), so that the loop vectorizes.
fn sub_scaled_column(x: &mut Mat<f64>, j: usize, a: MatRef<f64>, col: usize, len: usize, v: f64) {
    if let Some(src) = a.col(col).try_as_col_major() {
        let src = &src.as_slice()[..len];
        if let Some(dst) = x.col_mut(j).try_as_col_major_mut() {
            for (d, s) in dst.as_slice_mut()[..len].iter_mut().zip(src) {
                *d -= s * v;
            }
            return;
        }
    }
    for i in 0..len {
        x[(i, j)] -= a[(i, col)] * v;
    }
}

/// Diagonal blocks of an upper quasi-triangular matrix as (start, size 1 or 2).
pub(crate) fn blocks(t: MatRef<f64>) -> Vec<(usize, usize)> {
    let n = t.nrows();
    let mut out = Vec::with_capacity(n);
    let mut k = 0;
    while k < n {
        if k + 1 < n && t[(k + 1, k)] != 0.0 {
            out.push((k, 2));
            k += 2;
        } else {
            out.push((k, 1));
            k += 1;
        }
    }
    out
}

fn small(t: MatRef<f64>, k0: usize, p: usize) -> [[f64; 2]; 2] {
    let mut s = [[0.0; 2]; 2];
    for (i, row) in s.iter_mut().enumerate().take(p) {
        for (j, v) in row.iter_mut().enumerate().take(p) {
            *v = t[(k0 + i, k0 + j)];
        }
    }
    s
}

/// Pivots below this are treated as singular: eps times the size of the data (dtrsyl's SMIN).
fn smallest_pivot(ta: MatRef<f64>, tb: MatRef<f64>) -> f64 {
    let mut mx: f64 = 0.0;
    for t in [ta, tb] {
        for j in 0..t.ncols() {
            for i in 0..t.nrows() {
                mx = mx.max(t[(i, j)].abs());
            }
        }
    }
    pivot_floor(mx)
}

/// [`smallest_pivot`] of data whose largest entry is `max_abs`.
pub(crate) fn pivot_floor(max_abs: f64) -> f64 {
    (f64::EPSILON * max_abs).max(f64::MIN_POSITIVE / f64::EPSILON)
}

/// Solves the p×q block equation `A·X + X·B = R` or `A·X·B − X = R` (p, q ≤ 2) through its
/// Kronecker form with complete pivoting, returning (X, scale) where the true rhs was scale·R.
#[allow(clippy::too_many_arguments)]
fn solve_small(
    a: &[[f64; 2]; 2],
    p: usize,
    b: &[[f64; 2]; 2],
    q: usize,
    r: &[[f64; 2]; 2],
    kind: Kind,
    smin: f64,
) -> Result<([[f64; 2]; 2], f64)> {
    let nk = p * q;
    // Unknown index of X[i][j] is i + p·j (column-major vec).
    let mut k = [[0.0; 4]; 4];
    let mut rhs = [0.0; 4];
    for j in 0..q {
        for i in 0..p {
            let row = i + p * j;
            rhs[row] = r[i][j];
            for jj in 0..q {
                for ii in 0..p {
                    let col = ii + p * jj;
                    k[row][col] = match kind {
                        // (A·X)[i][j] = Σ A[i][ii] X[ii][j]; (X·B)[i][j] = Σ X[i][jj] B[jj][j].
                        Kind::Continuous => {
                            (if jj == j { a[i][ii] } else { 0.0 }) + (if ii == i { b[jj][j] } else { 0.0 })
                        }
                        Kind::Discrete => a[i][ii] * b[jj][j] - if ii == i && jj == j { 1.0 } else { 0.0 },
                    };
                }
            }
        }
    }
    let mut colperm = [0usize, 1, 2, 3];
    let mut singular = false;
    for s in 0..nk {
        // Complete pivoting: the largest remaining entry.
        let (mut pi, mut pj, mut pv) = (s, s, -1.0);
        for (i, krow) in k.iter().enumerate().take(nk).skip(s) {
            for (j, &v) in krow.iter().enumerate().take(nk).skip(s) {
                if v.abs() > pv {
                    (pi, pj, pv) = (i, j, v.abs());
                }
            }
        }
        k.swap(s, pi);
        rhs.swap(s, pi);
        if pj != s {
            for row in k.iter_mut() {
                row.swap(s, pj);
            }
            colperm.swap(s, pj);
        }
        if k[s][s].abs() < smin {
            singular = true;
            break;
        }
        for i in s + 1..nk {
            let f = k[i][s] / k[s][s];
            if f != 0.0 {
                for j in s..nk {
                    k[i][j] -= f * k[s][j];
                }
                rhs[i] -= f * rhs[s];
            }
        }
    }
    if singular {
        return Err(LinalgError::NoSolution(match kind {
            Kind::Continuous => "the equation is singular: A and -B have a common eigenvalue".into(),
            Kind::Discrete => "the equation is singular: an eigenvalue product λ(A)·λ(B) equals 1".into(),
        }));
    }
    // Scale the rhs so that back substitution cannot overflow (dlasy2's BIGNUM test).
    let bignum = f64::EPSILON / f64::MIN_POSITIVE;
    let mut scale = 1.0;
    let bmax = rhs.iter().take(nk).fold(0.0f64, |m, v| m.max(v.abs()));
    let pmin = (0..nk).fold(f64::INFINITY, |m, s| m.min(k[s][s].abs()));
    if pmin < 1.0 && bmax > 1.0 && bmax > bignum * pmin {
        scale = (bignum * pmin / bmax).min(1.0) / 8.0;
        for v in rhs.iter_mut() {
            *v *= scale;
        }
    }
    let mut y = [0.0; 4];
    for s in (0..nk).rev() {
        let mut v = rhs[s];
        for j in s + 1..nk {
            v -= k[s][j] * y[j];
        }
        y[s] = v / k[s][s];
    }
    let mut x = [[0.0; 2]; 2];
    for s in 0..nk {
        let idx = colperm[s];
        x[idx % p][idx / p] = y[s];
    }
    Ok((x, scale))
}

pub(crate) fn check_square(a: MatRef<f64>, name: &str) -> Result<()> {
    if a.nrows() != a.ncols() {
        return Err(LinalgError::Dimension(format!(
            "{name} must be square, got {}x{}",
            a.nrows(),
            a.ncols()
        )));
    }
    Ok(())
}

pub(crate) fn is_finite(a: MatRef<f64>) -> bool {
    (0..a.ncols()).all(|j| (0..a.nrows()).all(|i| a[(i, j)].is_finite()))
}

pub(crate) fn check_finite(a: MatRef<f64>, name: &str) -> Result<()> {
    if is_finite(a) {
        Ok(())
    } else {
        Err(LinalgError::InvalidArgument(format!(
            "{name} has NaN or infinite entries"
        )))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::{rngs::StdRng, Rng, SeedableRng};

    /// A random upper quasi-triangular matrix with 2×2 blocks (complex pairs) at `pairs` positions,
    /// eigenvalue real parts shifted by `shift`.
    pub(crate) fn quasi_tri(n: usize, pairs: &[usize], shift: f64, rng: &mut StdRng) -> Mat<f64> {
        let mut t = Mat::from_fn(n, n, |i, j| if j >= i { rng.gen_range(-1.0..1.0) } else { 0.0 });
        for i in 0..n {
            t[(i, i)] += shift;
        }
        for &k in pairs {
            // [a b; c a] with b·c < 0 has eigenvalues a ± i·sqrt(−bc).
            let a = shift + rng.gen_range(-0.5..0.5);
            t[(k, k)] = a;
            t[(k + 1, k + 1)] = a;
            t[(k, k + 1)] = rng.gen_range(0.5..2.0);
            t[(k + 1, k)] = -rng.gen_range(0.5..2.0);
        }
        t
    }

    fn fro(m: MatRef<f64>) -> f64 {
        m.norm_l2()
    }

    #[test]
    fn continuous_kernel_residual() {
        let mut rng = StdRng::seed_from_u64(1);
        let ta = quasi_tri(9, &[0, 4, 7], -1.0, &mut rng);
        let tb = quasi_tri(6, &[1, 4], 0.7, &mut rng);
        let c = Mat::from_fn(9, 6, |_, _| rng.gen_range(-1.0..1.0));
        let x = solve_quasi_triangular(ta.as_ref(), tb.as_ref(), c.as_ref(), Kind::Continuous).unwrap();
        let res = &ta * &x + &x * &tb - &c;
        let scale = fro(ta.as_ref()) * fro(x.as_ref()) + fro(x.as_ref()) * fro(tb.as_ref()) + fro(c.as_ref());
        assert!(
            fro(res.as_ref()) <= 1e-13 * scale,
            "residual {}",
            fro(res.as_ref()) / scale
        );
    }

    #[test]
    fn discrete_kernel_residual() {
        let mut rng = StdRng::seed_from_u64(2);
        let ta = quasi_tri(8, &[2, 5], 0.1, &mut rng);
        let tb = quasi_tri(7, &[0, 3], -0.2, &mut rng);
        let c = Mat::from_fn(8, 7, |_, _| rng.gen_range(-1.0..1.0));
        let x = solve_quasi_triangular(ta.as_ref(), tb.as_ref(), c.as_ref(), Kind::Discrete).unwrap();
        let res = &ta * &x * &tb - &x - &c;
        let scale = fro(ta.as_ref()) * fro(x.as_ref()) * fro(tb.as_ref()) + fro(x.as_ref()) + fro(c.as_ref());
        assert!(
            fro(res.as_ref()) <= 1e-13 * scale,
            "residual {}",
            fro(res.as_ref()) / scale
        );
    }

    #[test]
    fn singular_equation_is_an_error() {
        // A = diag(1, 2) and B = −1: λ(A) = −λ(B) = 1, so A·X + X·B = C is singular.
        let ta = Mat::from_fn(2, 2, |i, j| if i == j { (i + 1) as f64 } else { 0.0 });
        let tb = Mat::from_fn(1, 1, |_, _| -1.0);
        let c = Mat::from_fn(2, 1, |_, _| 1.0);
        let e = solve_quasi_triangular(ta.as_ref(), tb.as_ref(), c.as_ref(), Kind::Continuous);
        assert!(matches!(e, Err(LinalgError::NoSolution(_))));
    }

    #[test]
    fn dimension_mismatch_is_an_error() {
        let ta = Mat::<f64>::identity(2, 2);
        let c = Mat::<f64>::zeros(3, 2);
        let e = solve_quasi_triangular(ta.as_ref(), ta.as_ref(), c.as_ref(), Kind::Continuous);
        assert!(matches!(e, Err(LinalgError::Dimension(_))));
    }
}
