//! Balancing of a square matrix before eigenvalue work, as LAPACK dgebal: isolate eigenvalues by
//! symmetric permutations, then scale rows and columns by powers of 2 so that each row and column
//! of the remaining block have comparable 2-norms (exact in floating point, so no rounding error).
//!
//! The balanced matrix is `B = D⁻¹·Pᵀ·A·P·D = T⁻¹·A·T` with `T = P·D`, where `P` is the permutation
//! with `(Pᵀ·A·P)[i][j] = A[perm[i]][perm[j]]` and `D = diag(scale)`.

use faer::{Mat, MatRef};

use crate::{LinalgError, Result};

/// A balanced matrix `B = T⁻¹·A·T` (`T = P·D`) and the transformation that produced it.
#[derive(Debug, Clone)]
pub struct Balanced {
    /// The balanced matrix `B`.
    pub a: Mat<f64>,
    /// Permutation: row/column `i` of `B` is row/column `perm[i]` of `A`.
    pub perm: Vec<usize>,
    /// Diagonal scaling `D` (powers of 2), indexed like the rows of `B`.
    pub scale: Vec<f64>,
    /// First row/column (0-based) of the block that was not isolated by permutation.
    pub ilo: usize,
    /// Last row/column (0-based, inclusive) of that block; `B` is upper triangular outside `ilo..=ihi`.
    pub ihi: usize,
}

/// Which parts of the balancing to perform (dgebal's JOB = 'N', 'P', 'S', 'B').
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BalanceJob {
    /// Isolate eigenvalues by permutation.
    pub permute: bool,
    /// Scale by powers of 2.
    pub scale: bool,
}

/// Balance `a` by permutation and scaling (dgebal JOB='B'). A non-square or non-finite input is
/// returned unbalanced (identity transformation); use [`try_balance`] to get an error instead.
pub fn balance(a: MatRef<f64>) -> Balanced {
    let job = BalanceJob {
        permute: true,
        scale: true,
    };
    try_balance_with(a, job).unwrap_or_else(|_| identity_balanced(a))
}

/// Balance `a` by permutation and scaling, rejecting non-square or non-finite input.
pub fn try_balance(a: MatRef<f64>) -> Result<Balanced> {
    try_balance_with(
        a,
        BalanceJob {
            permute: true,
            scale: true,
        },
    )
}

fn identity_balanced(a: MatRef<f64>) -> Balanced {
    let n = a.nrows();
    Balanced {
        a: a.to_owned(),
        perm: (0..n).collect(),
        scale: vec![1.0; n],
        ilo: 0,
        ihi: n.saturating_sub(1),
    }
}

/// Balance `a` doing only the parts selected in `job`.
pub fn try_balance_with(a: MatRef<f64>, job: BalanceJob) -> Result<Balanced> {
    crate::dense::clear_upper_simd(); // scalar sweeps, often right after faer products
    let n = a.nrows();
    if a.ncols() != n {
        return Err(LinalgError::Dimension(format!(
            "balance: matrix is {}x{}, not square",
            n,
            a.ncols()
        )));
    }
    for j in 0..n {
        for i in 0..n {
            if !a[(i, j)].is_finite() {
                return Err(LinalgError::InvalidArgument(
                    "balance: matrix has NaN or infinite entries".into(),
                ));
            }
        }
    }
    let mut b = a.to_owned();
    let mut perm: Vec<usize> = (0..n).collect();
    let mut scale = vec![1.0; n];
    if n == 0 {
        return Ok(Balanced {
            a: b,
            perm,
            scale,
            ilo: 0,
            ihi: 0,
        });
    }
    let mut ilo = 0usize;
    let mut ihi = n - 1;

    if job.permute {
        // Rows whose off-diagonal part (within columns ilo..=ihi) is zero hold an isolated
        // eigenvalue: move them to the bottom.
        while ilo < ihi {
            let found = (ilo..=ihi)
                .rev()
                .find(|&i| (ilo..=ihi).all(|j| j == i || b[(i, j)] == 0.0));
            match found {
                Some(i) => {
                    swap_sym(&mut b, &mut perm, i, ihi);
                    ihi -= 1;
                }
                None => break,
            }
        }
        // Columns whose off-diagonal part (within rows ilo..=ihi) is zero: move them to the left.
        while ilo < ihi {
            let found = (ilo..=ihi).find(|&j| (ilo..=ihi).all(|i| i == j || b[(i, j)] == 0.0));
            match found {
                Some(j) => {
                    swap_sym(&mut b, &mut perm, j, ilo);
                    ilo += 1;
                }
                None => break,
            }
        }
    }

    if job.scale && ilo < ihi {
        scale_block(&mut b, &mut scale, ilo, ihi);
    }
    Ok(Balanced {
        a: b,
        perm,
        scale,
        ilo,
        ihi,
    })
}

/// Swap rows and columns `i` and `j` of `b` (a symmetric permutation) and record it in `perm`.
fn swap_sym(b: &mut Mat<f64>, perm: &mut [usize], i: usize, j: usize) {
    if i == j {
        return;
    }
    let n = b.nrows();
    for k in 0..n {
        let t = b[(i, k)];
        b[(i, k)] = b[(j, k)];
        b[(j, k)] = t;
    }
    for k in 0..n {
        let t = b[(k, i)];
        b[(k, i)] = b[(k, j)];
        b[(k, j)] = t;
    }
    perm.swap(i, j);
}

/// Iterative power-of-2 scaling of the block `ilo..=ihi` (the dgebal loop of LAPACK ≥ 3.5, 2-norms).
///
/// The sweeps run on a column-major copy (faer's indexed access is bounds-checked at every entry,
/// which made balancing a twentieth of an H∞ norm computation); the arithmetic is unchanged.
fn scale_block(b: &mut Mat<f64>, scale: &mut [f64], ilo: usize, ihi: usize) {
    const RADIX: f64 = 2.0;
    const FACTOR: f64 = 0.95;
    let n = b.nrows();
    let sfmin1 = f64::MIN_POSITIVE / (f64::EPSILON * 0.5 * RADIX);
    let sfmax1 = 1.0 / sfmin1;
    let sfmin2 = sfmin1 * RADIX;
    let sfmax2 = 1.0 / sfmin2;
    // Column by column (an index split k % n, k / n per entry costs two integer divisions).
    let mut d: Vec<f64> = Vec::with_capacity(n * n);
    for j in 0..n {
        d.extend((0..n).map(|i| b[(i, j)]));
    }
    let mut any = false;
    // Bounded number of sweeps: each accepted change reduces the row+column norm sum by ≥ 5 %.
    for _sweep in 0..200 {
        let mut noconv = false;
        for i in ilo..=ihi {
            let col = &d[i * n..(i + 1) * n];
            let row = |k: usize| d[i + k * n];
            // Plain sums of squares: entries are finite and balancing only needs 2-norms to a factor of 2
            // (hypot per entry would dominate the cost). One pass over the column and one over the
            // row give both the sums (over the block) and the largest magnitudes (dgebal's ranges),
            // each in four independent lanes: a single running sum or maximum is a chain of
            // dependent additions, which made these sweeps a sixth of a Hamiltonian eigenvalue solve.
            let ca0 = col[..ilo].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let (c2, ca1) = sum_sq_max_strided(&col[ilo..=ihi], 1, ihi + 1 - ilo);
            let mut ca = ca0.max(ca1);
            let (r2, ra0) = sum_sq_max_strided(&d[i + ilo * n..], n, ihi + 1 - ilo);
            let mut ra = ra0.max((ihi + 1..n).map(row).fold(0.0f64, |m, v| m.max(v.abs())));
            let (mut c, mut r) = (c2.sqrt(), r2.sqrt());
            let tiny = f64::MIN_POSITIVE / f64::EPSILON;
            if !c.is_finite() || !r.is_finite() || c2 < tiny || r2 < tiny {
                // Overflow/underflow of the squares: recompute with scaling.
                c = col[ilo..=ihi].iter().fold(0.0f64, |acc, v| acc.hypot(*v));
                r = (ilo..=ihi).fold(0.0f64, |acc, k| acc.hypot(row(k)));
            }
            if c == 0.0 || r == 0.0 {
                continue;
            }
            let mut g = r / RADIX;
            let mut f: f64 = 1.0;
            let s = c + r;
            while c < g && f.max(c).max(ca) < sfmax2 && r.min(g).min(ra) > sfmin2 {
                f *= RADIX;
                c *= RADIX;
                ca *= RADIX;
                r /= RADIX;
                g /= RADIX;
                ra /= RADIX;
            }
            g = c / RADIX;
            while g >= r && r.max(ra) < sfmax2 && f.min(c).min(g).min(ca) > sfmin2 {
                f /= RADIX;
                c /= RADIX;
                g /= RADIX;
                ca /= RADIX;
                r *= RADIX;
                ra *= RADIX;
            }
            if c + r >= FACTOR * s {
                continue;
            }
            if f < 1.0 && scale[i] < 1.0 && f * scale[i] <= sfmin1 {
                continue;
            }
            if f > 1.0 && scale[i] > 1.0 && scale[i] >= sfmax1 / f {
                continue;
            }
            let g = 1.0 / f;
            scale[i] *= f;
            noconv = true;
            any = true;
            for k in 0..n {
                d[i + k * n] *= g;
            }
            for v in &mut d[i * n..(i + 1) * n] {
                *v *= f;
            }
        }
        if !noconv {
            break;
        }
    }
    if any {
        *b = Mat::from_fn(n, n, |i, j| d[i + j * n]);
    }
}

/// Sum of squares and largest magnitude of the `count` entries `x[0]`, `x[stride]`, …, accumulated
/// in four lanes (entry k in lane k mod 4).
#[inline]
fn sum_sq_max_strided(x: &[f64], stride: usize, count: usize) -> (f64, f64) {
    let (mut s, mut m) = ([0.0f64; 4], [0.0f64; 4]);
    let full = count / 4 * 4;
    let mut k = 0;
    while k < full {
        for l in 0..4 {
            let v = x[(k + l) * stride];
            s[l] += v * v;
            m[l] = m[l].max(v.abs());
        }
        k += 4;
    }
    for l in 0..count - full {
        let v = x[(full + l) * stride];
        s[l] += v * v;
        m[l] = m[l].max(v.abs());
    }
    ((s[0] + s[1]) + (s[2] + s[3]), m[0].max(m[1]).max(m[2]).max(m[3]))
}

impl Balanced {
    /// `T·X` with `T = P·D`: maps (invariant-subspace or eigen-) vectors of `B` back to `A`.
    pub fn back_transform(&self, x: MatRef<f64>) -> Mat<f64> {
        let mut y = Mat::zeros(x.nrows(), x.ncols());
        for j in 0..x.ncols() {
            for i in 0..self.perm.len().min(x.nrows()) {
                y[(self.perm[i], j)] = self.scale[i] * x[(i, j)];
            }
        }
        y
    }

    /// `T⁻¹·Y`: maps vectors of `A` to the coordinates of `B` (inverse of [`Balanced::back_transform`]).
    pub fn forward_transform(&self, y: MatRef<f64>) -> Mat<f64> {
        let mut x = Mat::zeros(y.nrows(), y.ncols());
        for j in 0..y.ncols() {
            for i in 0..self.perm.len().min(y.nrows()) {
                x[(i, j)] = y[(self.perm[i], j)] / self.scale[i];
            }
        }
        x
    }

    /// `T·M·T⁻¹`: undoes the balancing of a matrix (`A = T·B·T⁻¹`).
    pub fn unbalance(&self, m: MatRef<f64>) -> Mat<f64> {
        let n = self.perm.len();
        let mut out = Mat::zeros(n, n);
        for q in 0..n {
            for p in 0..n {
                out[(self.perm[p], self.perm[q])] = self.scale[p] * m[(p, q)] / self.scale[q];
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel_err(x: MatRef<f64>, y: MatRef<f64>) -> f64 {
        (x - y).norm_l2() / y.norm_l2().max(1e-300)
    }

    #[test]
    fn balanced_is_similar_and_exact() {
        // Badly scaled matrix: entries spanning 1e-6 .. 1e6 (a classic balancing demonstration).
        let a = Mat::from_fn(4, 4, |i, j| {
            let base = [
                [1.0, 1e6, 2e6, 3.0],
                [1e-6, 2.0, 5.0, 1e-4],
                [2e-7, 4e-6, 3.0, 1.0],
                [1.0, 1e4, 2e5, 4.0],
            ];
            base[i][j]
        });
        let bal = balance(a.as_ref());
        let back = bal.unbalance(bal.a.as_ref());
        // Powers of 2 and permutations are exact in floating point.
        assert_eq!(rel_err(back.as_ref(), a.as_ref()), 0.0);
        assert!(
            bal.a.norm_l2() < a.norm_l2() / 100.0,
            "balancing did not reduce the norm"
        );
        // T·(T⁻¹·Y) = Y
        let y = Mat::from_fn(4, 2, |i, j| (i + 3 * j) as f64 + 0.5);
        let z = bal.back_transform(bal.forward_transform(y.as_ref()).as_ref());
        assert!(rel_err(z.as_ref(), y.as_ref()) < 1e-15);
    }

    #[test]
    fn permutation_isolates_triangular_part() {
        // Upper triangular matrix: every eigenvalue is isolated by permutation alone.
        let a = Mat::from_fn(3, 3, |i, j| if j >= i { (1 + i + 2 * j) as f64 } else { 0.0 });
        let bal = balance(a.as_ref());
        assert!(bal.ilo >= bal.ihi);
        for j in 0..3 {
            for i in j + 1..3 {
                assert_eq!(bal.a[(i, j)], 0.0);
            }
        }
        assert_eq!(bal.unbalance(bal.a.as_ref()), a);
    }

    #[test]
    fn rejects_bad_input() {
        assert!(matches!(
            try_balance(Mat::<f64>::zeros(2, 3).as_ref()),
            Err(LinalgError::Dimension(_))
        ));
        let mut a = Mat::<f64>::identity(2, 2);
        a[(0, 1)] = f64::NAN;
        assert!(matches!(try_balance(a.as_ref()), Err(LinalgError::InvalidArgument(_))));
        // The infallible entry point returns the input unchanged instead of panicking.
        let b = balance(a.as_ref());
        assert_eq!(b.perm, vec![0, 1]);
    }
}
