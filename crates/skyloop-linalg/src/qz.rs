//! Eigenvalues of a real matrix pencil `A − λ·B` by the QZ algorithm (Moler & Stewart, "An
//! algorithm for generalized matrix eigenvalue problems", SIAM J. Numer. Anal. 10, 1973; Golub &
//! Van Loan, "Matrix Computations", 4th ed., §7.7; the method of LAPACK dhgeqz without Schur
//! vectors).
//!
//! `B` is reduced to upper triangular form by Householder QR and `A` to upper Hessenberg form by
//! Givens rotations that keep `B` triangular (Hessenberg–triangular reduction). The implicit
//! double-shift QZ step then chases a bulge down the active block: Householder reflectors from the
//! left act on `A`, and reflectors and rotations from the right restore the triangular `B`. A
//! negligible subdiagonal entry of `A` splits the problem; a negligible diagonal entry of `B` (an
//! infinite eigenvalue) is chased to the bottom of the active block by rotations and deflated there
//! with `β = 0`. Only eigenvalues are computed, so each transformation touches the active diagonal
//! block only.

use faer::{c64, MatRef};

use crate::dense::{clear_upper_simd, larfg, lartg, Dm};
use crate::{LinalgError, Result};

/// Generalized eigenvalues of the square pencil `(A, B)` as pairs `(α, β)` with `λ = α/β`
/// (`β = 0`: an infinite eigenvalue, e.g. from a singular `B`). A complex-conjugate pair comes as
/// two consecutive entries `(α, β)`, `(ᾱ, β)` with `β > 0`. `β ≥ 0` always; the scale of `(α, β)`
/// follows that of the triangularized `B` (for a finite eigenvalue, `|β|` is of the order of the
/// corresponding diagonal entry of `B`).
///
/// # Errors
/// `A` and `B` not square of the same order, NaN or infinite entries, or an iteration that does
/// not converge (more than 30·n QZ steps per eigenvalue block).
pub fn generalized_eigenvalues(a: MatRef<f64>, b: MatRef<f64>) -> Result<(Vec<c64>, Vec<f64>)> {
    let n = a.nrows();
    if a.ncols() != n || b.nrows() != n || b.ncols() != n {
        return Err(LinalgError::Dimension(format!(
            "generalized_eigenvalues: A is {}x{}, B is {}x{}",
            a.nrows(),
            a.ncols(),
            b.nrows(),
            b.ncols()
        )));
    }
    let mut am = Dm::from_mat(a);
    let mut bm = Dm::from_mat(b);
    if am.d.iter().chain(bm.d.iter()).any(|v| !v.is_finite()) {
        return Err(LinalgError::InvalidArgument(
            "generalized_eigenvalues: A or B has NaN or infinite entries".into(),
        ));
    }
    hessenberg_triangular(&mut am, &mut bm);
    clear_upper_simd(); // scalar kernels follow (see `clear_upper_simd`)
    qz_eigenvalues(&mut am, &mut bm)
}

/// Reduces `(A, B)` in place to `(H, T)`, `H` upper Hessenberg and `T` upper triangular, by
/// orthogonal equivalence (Golub & Van Loan, Algorithm 7.7.1): QR of `B` applied to `A`, then for
/// each column `j` of `A` from the bottom up a row rotation that zeroes one entry and a column
/// rotation that removes the fill it leaves below the diagonal of `B`.
///
/// Why it is organized this way: in column-major storage a row rotation touches one cache line per
/// column, and at n = 400 those strided passes were most of the reduction. Left and right
/// transformations commute, and a row rotation of column `j`'s sweep depends only on column `j`
/// of `A` and on the 2×2 diagonal block of `B` it passes, so each sweep applies its rotations to
/// those at once, its column rotations (contiguous) at once, and the rest of its row rotations
/// afterwards as one sequence per column, top to bottom in memory. The QR of `B` is faer's
/// blocked Householder QR, applied to `A` as a blocked reflector sequence.
fn hessenberg_triangular(a: &mut Dm, b: &mut Dm) {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::householder;
    use faer::{Conj, MatMut, Par};
    let n = a.n;
    if n < 2 {
        return;
    }
    {
        let qr = MatRef::from_column_major_slice(&b.d, n, n).qr();
        let (basis, coeff) = (qr.Q_basis(), qr.Q_coeff());
        let mut mem = MemBuffer::new(
            householder::apply_block_householder_sequence_transpose_on_the_left_in_place_scratch::<f64>(
                n,
                coeff.nrows(),
                n,
            ),
        );
        householder::apply_block_householder_sequence_transpose_on_the_left_in_place_with_conj(
            basis,
            coeff,
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut a.d, n, n),
            Par::Seq,
            MemStack::new(&mut mem),
        );
        let r = qr.R();
        for j in 0..n {
            for i in 0..n {
                b[(i, j)] = if i <= j { r[(i, j)] } else { 0.0 };
            }
        }
    }
    // faer's kernels above, scalar loops below.
    clear_upper_simd();
    // Row rotation of rows (i − 1, i), for i = n − 1 down to j + 2: (c, s); identity when skipped.
    let mut rot = vec![(1.0, 0.0); n];
    for j in 0..n.saturating_sub(2) {
        for i in (j + 2..n).rev() {
            let (c, s) = if a[(i, j)] != 0.0 {
                let (c, s, r) = lartg(a[(i - 1, j)], a[(i, j)]);
                a[(i - 1, j)] = r;
                a[(i, j)] = 0.0;
                (c, s)
            } else {
                (1.0, 0.0)
            };
            rot[i] = (c, s);
            // B's 2×2 diagonal block now (its other columns later); the fill B(i, i−1) it makes
            // is removed by a column rotation, applied to B's rows above and to all of A at once.
            b.rot_rows(i - 1, i, i - 1..i + 1, c, s);
            if b[(i, i - 1)] != 0.0 {
                let (c, s, r) = lartg(b[(i, i)], -b[(i, i - 1)]);
                b.rot_cols(i - 1, i, 0..i, c, s);
                b[(i, i)] = r;
                b[(i, i - 1)] = 0.0;
                a.rot_cols(i - 1, i, 0..n, c, s);
            }
        }
        // The deferred row rotations, in their order (i descending): on A's columns j + 1.. and
        // on B's columns from i + 1 on, a block of columns at a time (each rotation reads what the
        // previous one wrote in the same column; across columns they are independent, and
        // interleaving the columns keeps the floating-point units busy).
        const W: usize = 16;
        let mut c0 = j + 1;
        while c0 < n {
            let c1 = (c0 + W).min(n);
            for i in (j + 2..n).rev() {
                let (c, s) = rot[i];
                if s == 0.0 {
                    continue;
                }
                for col in c0..c1 {
                    let k = col * n + i;
                    let (x, y) = (a.d[k - 1], a.d[k]);
                    a.d[k - 1] = c * x + s * y;
                    a.d[k] = c * y - s * x;
                }
                for col in c0.max(i + 1)..c1 {
                    let k = col * n + i;
                    let (x, y) = (b.d[k - 1], b.d[k]);
                    b.d[k - 1] = c * x + s * y;
                    b.d[k] = c * y - s * x;
                }
            }
            c0 = c1;
        }
    }
}

/// QZ iteration on a Hessenberg–triangular pencil: the eigenvalues as `(α, β)` pairs.
fn qz_eigenvalues(a: &mut Dm, b: &mut Dm) -> Result<(Vec<c64>, Vec<f64>)> {
    let n = a.n;
    let mut alpha = vec![c64::new(0.0, 0.0); n];
    let mut beta = vec![0.0; n];
    let fro = |m: &Dm| {
        let mx = m.d.iter().fold(0.0f64, |acc, v| acc.max(v.abs()));
        if mx == 0.0 {
            0.0
        } else {
            mx * m.d.iter().map(|v| (v / mx) * (v / mx)).sum::<f64>().sqrt()
        }
    };
    let ulp = f64::EPSILON;
    let safmin = f64::MIN_POSITIVE;
    // Deflation thresholds of dhgeqz: ATOL = ulp·‖A‖_F, BTOL = ulp·‖B‖_F.
    let atol = (ulp * fro(a)).max(safmin);
    let btol = (ulp * fro(b)).max(safmin);
    let maxit = 30 * n.max(10);
    let mut its_since_deflation = 0usize;
    let mut total = 0usize;
    let mut ihi = n as isize - 1;
    while ihi >= 0 {
        let hi = ihi as usize;
        // Active block: the first negligible subdiagonal entry of A above `hi`.
        let mut lo = hi;
        while lo > 0 {
            if a[(lo, lo - 1)].abs() <= atol {
                a[(lo, lo - 1)] = 0.0;
                break;
            }
            lo -= 1;
        }
        // A negligible diagonal entry of B: chase it to the bottom and deflate an infinite eigenvalue.
        if let Some(j) = (lo..=hi).find(|&j| b[(j, j)].abs() <= btol) {
            b[(j, j)] = 0.0;
            for k in j..hi {
                let (c, s, r) = lartg(b[(k, k + 1)], b[(k + 1, k + 1)]);
                b[(k, k + 1)] = r;
                b[(k + 1, k + 1)] = 0.0;
                b.rot_rows(k, k + 1, k + 2..hi + 1, c, s);
                let c0 = if k > lo { k - 1 } else { lo };
                a.rot_rows(k, k + 1, c0..hi + 1, c, s);
                if k > lo {
                    // Remove the fill A(k+1, k−1); B keeps its triangle (its rows k have zeros there).
                    let (c, s, r) = lartg(a[(k + 1, k)], -a[(k + 1, k - 1)]);
                    a.rot_cols(k - 1, k, lo..k + 1, c, s);
                    a[(k + 1, k)] = r;
                    a[(k + 1, k - 1)] = 0.0;
                    if k + 2 <= hi {
                        a.rot_cols(k - 1, k, k + 2..hi + 1, c, s);
                    }
                    b.rot_cols(k - 1, k, lo..k, c, s);
                }
            }
            if hi > lo {
                let (c, s, r) = lartg(a[(hi, hi)], -a[(hi, hi - 1)]);
                a.rot_cols(hi - 1, hi, lo..hi, c, s);
                a[(hi, hi)] = r;
                a[(hi, hi - 1)] = 0.0;
                b.rot_cols(hi - 1, hi, lo..hi, c, s);
            }
            alpha[hi] = c64::new(a[(hi, hi)], 0.0);
            beta[hi] = 0.0;
            ihi -= 1;
            its_since_deflation = 0;
            continue;
        }
        if lo == hi {
            let (x, y) = (a[(hi, hi)], b[(hi, hi)]);
            let sgn = if y < 0.0 { -1.0 } else { 1.0 };
            alpha[hi] = c64::new(sgn * x, 0.0);
            beta[hi] = sgn * y;
            ihi -= 1;
            its_since_deflation = 0;
            continue;
        }
        if lo + 1 == hi {
            let (l1, l2, bs) = eig2(a, b, lo);
            alpha[lo] = l1 * bs;
            alpha[hi] = l2 * bs;
            beta[lo] = bs;
            beta[hi] = bs;
            ihi -= 2;
            its_since_deflation = 0;
            continue;
        }
        its_since_deflation += 1;
        total += 1;
        if total > maxit {
            return Err(LinalgError::NoConvergence(format!(
                "generalized_eigenvalues: QZ did not converge for eigenvalue {} of {n} after {maxit} steps",
                hi + 1
            )));
        }
        qz_step(a, b, lo, hi, its_since_deflation % 10 == 0);
    }
    Ok((alpha, beta))
}

/// Eigenvalues of the 2×2 pencil at rows/columns `k, k+1` (B upper triangular with nonzero
/// diagonal), with the scale `√|b₁₁·b₂₂|` used as their common β.
fn eig2(a: &Dm, b: &Dm, k: usize) -> (c64, c64, f64) {
    let (a11, a12, a21, a22) = (a[(k, k)], a[(k, k + 1)], a[(k + 1, k)], a[(k + 1, k + 1)]);
    let (b11, b12, b22) = (b[(k, k)], b[(k, k + 1)], b[(k + 1, k + 1)]);
    // M = A·B⁻¹ = [[m11, m12], [m21, m22]]; its eigenvalues are those of the pencil.
    let s1 = a11 / b11;
    let m12 = (a12 - s1 * b12) / b22;
    let m21 = a21 / b11;
    let m22 = a22 / b22 - m21 * b12 / b22;
    let half = 0.5 * (s1 - m22);
    let d = half * half + m12 * m21;
    let mid = 0.5 * (s1 + m22);
    let bs = (b11 * b22).abs().sqrt();
    if d < 0.0 {
        let im = (-d).sqrt();
        (c64::new(mid, im), c64::new(mid, -im), bs)
    } else {
        let r = d.sqrt();
        let l1 = mid + if mid >= 0.0 { r } else { -r };
        let det = s1 * m22 - m12 * m21;
        let l2 = if l1 != 0.0 { det / l1 } else { mid - r };
        (c64::new(l1, 0.0), c64::new(l2, 0.0), bs)
    }
}

/// One implicit double-shift QZ step on the active block `lo..=hi` (at least 3×3, `B` with
/// nonzero diagonal there): the shifts are the eigenvalues of the trailing 2×2 block of
/// `M = A·B⁻¹` (or ad hoc ones when `exceptional`), and the bulge of `(M − σ₁)(M − σ₂)·e₁` is
/// chased to the bottom (Golub & Van Loan, Algorithm 7.7.2).
fn qz_step(a: &mut Dm, b: &mut Dm, lo: usize, hi: usize, exceptional: bool) {
    let (p, q) = (hi - 1, hi);
    // Trailing 3×3 of B⁻¹ (upper triangular) on rows/columns p−1, p, q.
    let (u00, u01, u02) = (b[(p - 1, p - 1)], b[(p - 1, p)], b[(p - 1, q)]);
    let (u11, u12, u22) = (b[(p, p)], b[(p, q)], b[(q, q)]);
    let (i00, i11, i22) = (1.0 / u00, 1.0 / u11, 1.0 / u22);
    let i01 = -u01 * i00 * i11;
    let i12 = -u12 * i11 * i22;
    let i02 = (u01 * u12 * i11 - u02) * i22 * i00;
    let mpp = a[(p, p - 1)] * i01 + a[(p, p)] * i11;
    let mpq = a[(p, p - 1)] * i02 + a[(p, p)] * i12 + a[(p, q)] * i22;
    let mqp = a[(q, p)] * i11;
    let mqq = a[(q, p)] * i12 + a[(q, q)] * i22;
    let (s, t) = if exceptional {
        // dlahqr's exceptional shift on M: a double shift that breaks a stagnating cycle.
        let w = mqp.abs() + (a[(p, p - 1)] * i00).abs();
        let h11 = 0.75 * w + mqq;
        (2.0 * h11, h11 * h11 + 0.4375 * w * w)
    } else {
        (mpp + mqq, mpp * mqq - mpq * mqp)
    };
    // First column of (M − σ₁)(M − σ₂) at the top of the block.
    let (b00, b01, b11) = (b[(lo, lo)], b[(lo, lo + 1)], b[(lo + 1, lo + 1)]);
    let (j00, j11) = (1.0 / b00, 1.0 / b11);
    let j01 = -b01 * j00 * j11;
    let m11 = a[(lo, lo)] * j00;
    let m21 = a[(lo + 1, lo)] * j00;
    let m12 = a[(lo, lo)] * j01 + a[(lo, lo + 1)] * j11;
    let m22 = a[(lo + 1, lo)] * j01 + a[(lo + 1, lo + 1)] * j11;
    let m32 = a[(lo + 2, lo + 1)] * j11;
    let mut x = [m11 * m11 + m12 * m21 - s * m11 + t, m21 * (m11 + m22 - s), m21 * m32];
    let xs = x[0].abs().max(x[1].abs()).max(x[2].abs());
    if xs > 0.0 && xs.is_finite() {
        x.iter_mut().for_each(|v| *v /= xs);
    }
    for k in lo..hi - 1 {
        if k > lo {
            x = [a[(k, k - 1)], a[(k + 1, k - 1)], a[(k + 2, k - 1)]];
        }
        let mut v = [x[1], x[2]];
        let (beta, tau) = larfg(x[0], &mut v);
        let u = [1.0, v[0], v[1]];
        let c0 = if k > lo { k - 1 } else { lo };
        a.refl3_left(u, tau, k, c0..hi + 1);
        if k > lo {
            a[(k, k - 1)] = beta;
            a[(k + 1, k - 1)] = 0.0;
            a[(k + 2, k - 1)] = 0.0;
        }
        b.refl3_left(u, tau, k, k..hi + 1);
        // Restore B: a reflector on columns k..k+2 that zeroes B(k+2, k) and B(k+2, k+1) ...
        let mut w = [b[(k + 2, k)], b[(k + 2, k + 1)]];
        let (bb, tau2) = larfg(b[(k + 2, k + 2)], &mut w);
        let u2 = [w[0], w[1], 1.0];
        let rmax = (k + 3).min(hi);
        a.refl3_right(u2, tau2, k, lo..rmax + 1);
        b.refl3_right(u2, tau2, k, lo..k + 2);
        b[(k + 2, k)] = 0.0;
        b[(k + 2, k + 1)] = 0.0;
        b[(k + 2, k + 2)] = bb;
        // ... then a rotation on columns k, k+1 that zeroes B(k+1, k).
        let (c, s, r) = lartg(b[(k + 1, k + 1)], -b[(k + 1, k)]);
        a.rot_cols(k, k + 1, lo..rmax + 1, c, s);
        b.rot_cols(k, k + 1, lo..k + 1, c, s);
        b[(k + 1, k + 1)] = r;
        b[(k + 1, k)] = 0.0;
    }
    // The bulge leaves through a rotation on the last two rows.
    let k = hi - 1;
    let (c, s, r) = lartg(a[(k, k - 1)], a[(k + 1, k - 1)]);
    a[(k, k - 1)] = r;
    a[(k + 1, k - 1)] = 0.0;
    a.rot_rows(k, k + 1, k..hi + 1, c, s);
    b.rot_rows(k, k + 1, k..hi + 1, c, s);
    let (c, s, r) = lartg(b[(k + 1, k + 1)], -b[(k + 1, k)]);
    a.rot_cols(k, k + 1, lo..hi + 1, c, s);
    b.rot_cols(k, k + 1, lo..k + 1, c, s);
    b[(k + 1, k + 1)] = r;
    b[(k + 1, k)] = 0.0;
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::linalg::solvers::Solve;
    use faer::Mat;

    fn lcg(n: usize, seed: u64) -> Mat<f64> {
        let mut next = skyloop_fixtures::lcg(seed);
        Mat::from_fn(n, n, |_, _| 2.0 * next() - 1.0)
    }

    /// Matches every finite eigenvalue of (A, B) with one of `want` (removing it), to `tol`
    /// relative to 1 + |λ|; returns the number of infinite ones.
    fn check(a: &Mat<f64>, b: &Mat<f64>, mut want: Vec<c64>, tol: f64) -> usize {
        let (al, be) = generalized_eigenvalues(a.as_ref(), b.as_ref()).unwrap();
        let mut inf = 0;
        for (x, y) in al.iter().zip(&be) {
            assert!(*y >= 0.0);
            if *y <= 1e-13 * x.norm() || *y == 0.0 {
                inf += 1;
                continue;
            }
            let z = x / y;
            let pos = want.iter().position(|w| (w - z).norm() <= tol * (1.0 + w.norm()));
            assert!(pos.is_some(), "{z} not among {want:?}");
            want.remove(pos.unwrap_or(0));
        }
        inf
    }

    #[test]
    fn hessenberg_triangular_form_is_an_orthogonal_equivalence() {
        // Orders around the column-block width of the deferred rotations, and a larger one: the
        // form is exact (zeros below the subdiagonal of H and the diagonal of T), and orthogonal
        // equivalence keeps both Frobenius norms and the generalized eigenvalues (checked against
        // B⁻¹A's by `random_pencils_match_inverse_times_a`).
        for (n, seed) in [
            (2usize, 1u64),
            (3, 2),
            (15, 3),
            (16, 4),
            (17, 5),
            (18, 6),
            (33, 7),
            (70, 8),
        ] {
            let (a0, b0) = (lcg(n, seed), lcg(n, seed + 50));
            let (mut a, mut b) = (Dm::from_mat(a0.as_ref()), Dm::from_mat(b0.as_ref()));
            hessenberg_triangular(&mut a, &mut b);
            for j in 0..n {
                for i in j + 2..n {
                    assert_eq!(a[(i, j)], 0.0, "n={n}: H({i},{j})");
                }
                for i in j + 1..n {
                    assert_eq!(b[(i, j)], 0.0, "n={n}: T({i},{j})");
                }
            }
            let fro = |m: &Dm| m.d.iter().map(|v| v * v).sum::<f64>().sqrt();
            let (fa, fb) = (a0.norm_l2(), b0.norm_l2());
            assert!(
                (fro(&a) - fa).abs() < 1e-13 * fa * n as f64,
                "n={n}: ‖H‖ {} vs ‖A‖ {fa}",
                fro(&a)
            );
            assert!(
                (fro(&b) - fb).abs() < 1e-13 * fb * n as f64,
                "n={n}: ‖T‖ {} vs ‖B‖ {fb}",
                fro(&b)
            );
        }
    }

    #[test]
    fn random_pencils_match_inverse_times_a() {
        for (n, seed) in [(1, 1), (2, 2), (3, 3), (5, 4), (12, 5), (40, 6), (90, 7), (130, 8)] {
            let a = lcg(n, seed);
            let mut b = lcg(n, seed + 100);
            for i in 0..n {
                b[(i, i)] += 3.0; // well-conditioned B
            }
            let want = b.partial_piv_lu().solve(&a).eigenvalues().unwrap();
            assert_eq!(check(&a, &b, want, 1e-9), 0, "n={n}");
        }
    }

    #[test]
    fn identity_b_gives_the_standard_eigenvalues() {
        let a = lcg(30, 9);
        let want = crate::schur::eigenvalues(a.as_ref()).unwrap();
        assert_eq!(check(&a, &Mat::identity(30, 30), want, 1e-11), 0);
    }

    #[test]
    fn singular_b_gives_infinite_eigenvalues() {
        // B = diag(1, .., 1, 0, 0) in a random orthogonal basis pair: 2 infinite eigenvalues, and
        // the finite ones are those of the leading block of the transformed pencil.
        for (n, seed) in [(4, 11), (10, 12), (25, 13)] {
            let k = n - 2;
            let a0 = lcg(n, seed);
            let b0 = Mat::from_fn(n, n, |i, j| if i == j && i < k { 1.0 } else { 0.0 });
            let u = lcg(n, seed + 1).qr().compute_Q();
            let v = lcg(n, seed + 2).qr().compute_Q();
            let a = &u * &a0 * v.transpose();
            let b = &u * &b0 * v.transpose();
            // Finite eigenvalues of [A11 A12; A21 A22] − λ[I 0; 0 0]: those of A11 − A12·A22⁻¹·A21.
            let a11 = a0.as_ref().submatrix(0, 0, k, k);
            let a12 = a0.as_ref().submatrix(0, k, k, 2);
            let a21 = a0.as_ref().submatrix(k, 0, 2, k);
            let a22 = a0.as_ref().submatrix(k, k, 2, 2).to_owned();
            let schur_c = a11 - a12 * a22.partial_piv_lu().solve(a21);
            let want = schur_c.eigenvalues().unwrap();
            assert_eq!(check(&a, &b, want, 1e-8), 2, "n={n}");
        }
    }

    #[test]
    fn zero_b_and_bad_input() {
        let a = lcg(3, 21);
        let (_, be) = generalized_eigenvalues(a.as_ref(), Mat::<f64>::zeros(3, 3).as_ref()).unwrap();
        assert!(be.iter().all(|b| *b == 0.0));
        assert!(generalized_eigenvalues(a.as_ref(), Mat::<f64>::zeros(2, 2).as_ref()).is_err());
        let mut nan = a.clone();
        nan[(0, 0)] = f64::NAN;
        assert!(generalized_eigenvalues(nan.as_ref(), a.as_ref()).is_err());
    }
}
