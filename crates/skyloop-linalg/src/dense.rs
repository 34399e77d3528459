//! A small column-major square work matrix and the elementary transformations (Householder
//! reflectors, Givens rotations) the Schur and reordering kernels are built from. The kernels run
//! on a plain `Vec<f64>` so that their inner loops are contiguous and cheap.

use faer::{Mat, MatRef};
use std::ops::{Index, IndexMut, Range};

/// The product L·R (same units as the entries' product) as a triangular product where the
/// factors are triangular: L lower triangular and/or R upper triangular (exact zeros) skip the
/// zero halves (a third to a half of the flops of a full product), otherwise a full product.
///
/// Why: Cholesky-type factors (gramian factors, Hammarling's U) are upper triangular, and their
/// products were a tenth of a 1000-state Lyapunov factor or balanced truncation.
pub fn product_using_triangles(l: MatRef<f64>, r: MatRef<f64>) -> Mat<f64> {
    use faer::linalg::matmul::triangular::{matmul, BlockStructure};
    let lower = |m: MatRef<f64>| m.nrows() == m.ncols() && (0..m.ncols()).all(|j| (0..j).all(|i| m[(i, j)] == 0.0));
    let upper =
        |m: MatRef<f64>| m.nrows() == m.ncols() && (0..m.ncols()).all(|j| (j + 1..m.nrows()).all(|i| m[(i, j)] == 0.0));
    let (ls, rs) = (
        if lower(l) {
            BlockStructure::TriangularLower
        } else {
            BlockStructure::Rectangular
        },
        if upper(r) {
            BlockStructure::TriangularUpper
        } else {
            BlockStructure::Rectangular
        },
    );
    if matches!((ls, rs), (BlockStructure::Rectangular, BlockStructure::Rectangular)) || l.ncols() != r.nrows() {
        return l * r;
    }
    let mut out = Mat::<f64>::zeros(l.nrows(), r.ncols());
    matmul(
        out.as_mut(),
        BlockStructure::Rectangular,
        faer::Accum::Replace,
        l,
        ls,
        r,
        rs,
        1.0,
        faer::Par::Seq,
    );
    out
}

/// Frobenius norm `‖M‖_F` (no units: those of the entries): one pass of plain squares, falling
/// back to faer's scaled `norm_l2` only where that sum could have over- or underflowed.
///
/// Why: faer's `norm_l2` guards every entry against over/underflow with scaled accumulators; the
/// twenty-odd 50×50 norms of a CARE solve (residuals, scaling, the stability certificate) cost
/// about 8 % of it that way, the three 40×40 norms of each Hamiltonian of an H∞ norm as much. In the safe range the plain sum is accurate to `n·ε` (relative).
pub fn fro_norm(m: MatRef<f64>) -> f64 {
    let mut s = 0.0;
    for j in 0..m.ncols() {
        match m.col(j).try_as_col_major() {
            Some(c) => s += c.as_slice().iter().map(|v| v * v).sum::<f64>(),
            None => s += (0..m.nrows()).map(|i| m[(i, j)] * m[(i, j)]).sum::<f64>(),
        }
    }
    // Squares below MIN_POSITIVE lose digits or vanish; this bound keeps their total far below
    // ε·s. Above f64::MAX / 4 the sum may have overflowed (or nearly: NaN/inf entries land here).
    let tiny = (m.nrows() * m.ncols()) as f64 * f64::MIN_POSITIVE / f64::EPSILON;
    if s.is_finite() && s > tiny && s < f64::MAX / 4.0 {
        s.sqrt()
    } else {
        m.norm_l2()
    }
}

/// Square column-major work matrix.
#[derive(Debug, Clone)]
pub(crate) struct Dm {
    pub n: usize,
    pub d: Vec<f64>,
}

impl Index<(usize, usize)> for Dm {
    type Output = f64;
    #[inline(always)]
    fn index(&self, (i, j): (usize, usize)) -> &f64 {
        &self.d[i + j * self.n]
    }
}

impl IndexMut<(usize, usize)> for Dm {
    #[inline(always)]
    fn index_mut(&mut self, (i, j): (usize, usize)) -> &mut f64 {
        &mut self.d[i + j * self.n]
    }
}

impl Dm {
    pub fn zeros(n: usize) -> Dm {
        Dm { n, d: vec![0.0; n * n] }
    }

    pub fn identity(n: usize) -> Dm {
        let mut m = Dm::zeros(n);
        for i in 0..n {
            m[(i, i)] = 1.0;
        }
        m
    }

    pub fn from_mat(a: MatRef<f64>) -> Dm {
        let n = a.nrows();
        let mut m = Dm::zeros(n);
        for j in 0..n {
            for i in 0..n {
                m[(i, j)] = a[(i, j)];
            }
        }
        m
    }

    pub fn to_mat(&self) -> Mat<f64> {
        Mat::from_fn(self.n, self.n, |i, j| self[(i, j)])
    }

    /// Rows `r1`, `r2` over columns `cols`: `x ← c·x + s·y`, `y ← c·y − s·x` (BLAS drot).
    #[inline]
    pub fn rot_rows(&mut self, r1: usize, r2: usize, cols: Range<usize>, c: f64, s: f64) {
        let n = self.n;
        for j in cols {
            let x = self.d[r1 + j * n];
            let y = self.d[r2 + j * n];
            self.d[r1 + j * n] = c * x + s * y;
            self.d[r2 + j * n] = c * y - s * x;
        }
    }

    /// Columns `c1`, `c2` over rows `rows`, same rotation as [`Dm::rot_rows`].
    #[inline]
    pub fn rot_cols(&mut self, c1: usize, c2: usize, rows: Range<usize>, c: f64, s: f64) {
        let n = self.n;
        if rows.is_empty() || c1 == c2 {
            return;
        }
        // Two disjoint column segments as slices: no per-entry index arithmetic or bounds checks,
        // so the loop vectorizes (indexed, it was a fifth of a 400-order QZ).
        let (lo, hi, swap) = if c1 < c2 { (c1, c2, false) } else { (c2, c1, true) };
        let (head, tail) = self.d.split_at_mut(hi * n);
        let p = &mut head[lo * n + rows.start..lo * n + rows.end];
        let q = &mut tail[rows.start..rows.end];
        let (x, y) = if swap { (q, p) } else { (p, q) };
        for (xi, yi) in x.iter_mut().zip(y.iter_mut()) {
            let (u, v) = (*xi, *yi);
            *xi = c * u + s * v;
            *yi = c * v - s * u;
        }
    }

    /// `C ← (I − τ·u·uᵀ)·C` on rows `r0..r0+u.len()` and columns `cols` (dlarfx side 'L').
    #[inline]
    pub fn refl_left(&mut self, u: &[f64], tau: f64, r0: usize, cols: Range<usize>) {
        if tau == 0.0 {
            return;
        }
        let n = self.n;
        for j in cols {
            let col = &mut self.d[r0 + j * n..r0 + j * n + u.len()];
            let s: f64 = col.iter().zip(u).map(|(x, v)| x * v).sum();
            let ts = tau * s;
            for (x, v) in col.iter_mut().zip(u) {
                *x -= ts * v;
            }
        }
    }

    /// [`Dm::refl_left`] for a reflector of length 3 (the QZ bulge), unrolled: the generic loop over
    /// a 3-element slice compiled to a per-column loop with its own bounds and sum.
    #[inline]
    pub fn refl3_left(&mut self, u: [f64; 3], tau: f64, r0: usize, cols: Range<usize>) {
        if tau == 0.0 {
            return;
        }
        let n = self.n;
        for j in cols {
            let k = r0 + j * n;
            let p = &mut self.d[k..k + 3];
            let t = tau * (u[0] * p[0] + u[1] * p[1] + u[2] * p[2]);
            p[0] -= t * u[0];
            p[1] -= t * u[1];
            p[2] -= t * u[2];
        }
    }

    /// [`Dm::refl_right`] for a reflector of length 3, on three contiguous column segments (which
    /// the compiler vectorizes across rows).
    #[inline]
    pub fn refl3_right(&mut self, u: [f64; 3], tau: f64, c0: usize, rows: Range<usize>) {
        if tau == 0.0 || rows.is_empty() {
            return;
        }
        let n = self.n;
        let (r0, len) = (rows.start, rows.end - rows.start);
        let (first, rest) = self.d[c0 * n..].split_at_mut(n);
        let (second, third) = rest.split_at_mut(n);
        let x = &mut first[r0..r0 + len];
        let y = &mut second[r0..r0 + len];
        let z = &mut third[r0..r0 + len];
        for ((a, b), c) in x.iter_mut().zip(y.iter_mut()).zip(z.iter_mut()) {
            let t = tau * (u[0] * *a + u[1] * *b + u[2] * *c);
            *a -= t * u[0];
            *b -= t * u[1];
            *c -= t * u[2];
        }
    }

    /// `C ← C·(I − τ·u·uᵀ)` on columns `c0..c0+u.len()` and rows `rows` (dlarfx side 'R').
    #[inline]
    pub fn refl_right(&mut self, u: &[f64], tau: f64, c0: usize, rows: Range<usize>) {
        if tau == 0.0 {
            return;
        }
        let n = self.n;
        for i in rows {
            let mut s = 0.0;
            for (k, v) in u.iter().enumerate() {
                s += self.d[i + (c0 + k) * n] * v;
            }
            let ts = tau * s;
            for (k, v) in u.iter().enumerate() {
                self.d[i + (c0 + k) * n] -= ts * v;
            }
        }
    }
}

/// Clears the upper halves of the AVX vector registers (`vzeroupper`) when the CPU has AVX.
///
/// Why: faer's matrix products run hand-written AVX-512/AVX2 kernels that can return with the
/// upper register halves still in use. The scalar kernels of this crate are compiled for the
/// baseline x86-64 target (legacy SSE encoding), and on such a CPU every SSE instruction that
/// follows then pays for merging with the dirty upper state: measured on the 45×45 deflation
/// windows of an order-400 Schur form, the double-shift QR ran 2.5–3× slower right after a faer
/// product than after this call. It is cheap (one instruction and a cached feature test), so the
/// kernels call it on entry and after each faer call inside their loops.
#[inline]
pub(crate) fn clear_upper_simd() {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the instruction exists (AVX was detected at run time); it only zeroes bits
        // 128 and up of the vector registers, which the compiler treats as clobbered by it.
        #[allow(unsafe_code)]
        unsafe {
            std::arch::x86_64::_mm256_zeroupper()
        };
    }
}

/// Householder reflector (LAPACK dlarfg): returns `(β, τ)` and overwrites `x` with `v[1..]` so that
/// `(I − τ·[1;v]·[1;v]ᵀ)·[α; x] = [β; 0]`.
#[inline]
pub(crate) fn larfg(alpha: f64, x: &mut [f64]) -> (f64, f64) {
    // Plain sum of squares when it can neither overflow nor lose the tiny entries (the common
    // case, and libm's hypot is a measurable part of the QR sweeps); scaled hypot otherwise.
    let ssq: f64 = x.iter().map(|v| v * v).sum();
    let (xnorm, anorm) = if ssq > 1e-280 && ssq < 1e280 && alpha.abs() < 1e140 {
        (ssq.sqrt(), (alpha * alpha + ssq).sqrt())
    } else {
        let xn = x.iter().fold(0.0f64, |acc, v| acc.hypot(*v));
        (xn, alpha.hypot(xn))
    };
    if xnorm == 0.0 {
        return (alpha, 0.0);
    }
    let beta = -anorm.copysign(alpha);
    let tau = (beta - alpha) / beta;
    let inv = 1.0 / (alpha - beta);
    for v in x.iter_mut() {
        *v *= inv;
    }
    (beta, tau)
}

/// Plane rotation (LAPACK dlartg): `(c, s, r)` with `[c s; −s c]·[f; g] = [r; 0]`.
#[inline]
pub(crate) fn lartg(f: f64, g: f64) -> (f64, f64, f64) {
    if g == 0.0 {
        (1.0, 0.0, f)
    } else if f == 0.0 {
        (0.0, 1.0, g)
    } else {
        // sqrt of the sum of squares where it cannot overflow or underflow (hypot is slow).
        let ss = f * f + g * g;
        let r = if ss > 1e-280 && ss < 1e280 {
            ss.sqrt()
        } else {
            f.hypot(g)
        }
        .copysign(f);
        (f / r, g / r, r)
    }
}

/// Fortran `SIGN(a, b)`: |a| with the sign of b.
#[inline]
pub(crate) fn sign(a: f64, b: f64) -> f64 {
    if b >= 0.0 {
        a.abs()
    } else {
        -a.abs()
    }
}

/// Standardized 2×2 block (LAPACK dlanv2).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lanv2 {
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub d: f64,
    pub cs: f64,
    pub sn: f64,
}

/// Schur factorization of a real 2×2 matrix in standardized form (LAPACK dlanv2):
/// `[a b; c d] = [cs −sn; sn cs]·[aa bb; cc dd]·[cs sn; −sn cs]` with either `cc = 0` (real
/// eigenvalues) or `aa = dd` and `bb·cc < 0` (complex pair).
pub(crate) fn lanv2(mut a: f64, mut b: f64, mut c: f64, mut d: f64) -> Lanv2 {
    const MULTPL: f64 = 4.0;
    let eps = f64::EPSILON;
    // 2^-485: the square root of safmin/eps, rounded to a power of 2 (dlanv2's SAFMN2).
    let safmn2 = 2f64.powi(-485);
    let safmx2 = 1.0 / safmn2;
    let (mut cs, mut sn);
    if c == 0.0 {
        cs = 1.0;
        sn = 0.0;
    } else if b == 0.0 {
        // Swap rows and columns.
        cs = 0.0;
        sn = 1.0;
        std::mem::swap(&mut a, &mut d);
        b = -c;
        c = 0.0;
    } else if a - d == 0.0 && sign(1.0, b) != sign(1.0, c) {
        cs = 1.0;
        sn = 0.0;
    } else {
        let mut temp = a - d;
        let mut p = 0.5 * temp;
        let bcmax = b.abs().max(c.abs());
        let bcmis = b.abs().min(c.abs()) * sign(1.0, b) * sign(1.0, c);
        let mut scale = p.abs().max(bcmax);
        let mut z = (p / scale) * p + (bcmax / scale) * bcmis;
        if z >= MULTPL * eps {
            // Real eigenvalues: compute a and d.
            z = p + sign(scale.sqrt() * z.sqrt(), p);
            a = d + z;
            d -= (bcmax / z) * bcmis;
            let tau = c.hypot(z);
            cs = z / tau;
            sn = c / tau;
            b -= c;
            c = 0.0;
        } else {
            // Complex or nearly equal real eigenvalues: make the diagonal elements equal.
            let mut count = 0;
            let mut sigma = b + c;
            loop {
                count += 1;
                scale = temp.abs().max(sigma.abs());
                if scale >= safmx2 {
                    sigma *= safmn2;
                    temp *= safmn2;
                    if count <= 20 {
                        continue;
                    }
                }
                if scale <= safmn2 {
                    sigma *= safmx2;
                    temp *= safmx2;
                    if count <= 20 {
                        continue;
                    }
                }
                break;
            }
            p = 0.5 * temp;
            let mut tau = sigma.hypot(temp);
            cs = (0.5 * (1.0 + sigma.abs() / tau)).sqrt();
            sn = -(p / (tau * cs)) * sign(1.0, sigma);
            let aa = a * cs + b * sn;
            let bb = -a * sn + b * cs;
            let cc = c * cs + d * sn;
            let dd = -c * sn + d * cs;
            a = aa * cs + cc * sn;
            b = bb * cs + dd * sn;
            c = -aa * sn + cc * cs;
            d = -bb * sn + dd * cs;
            temp = 0.5 * (a + d);
            a = temp;
            d = temp;
            if c != 0.0 {
                if b != 0.0 {
                    if sign(1.0, b) == sign(1.0, c) {
                        // Real eigenvalues: reduce to upper triangular form.
                        let sab = b.abs().sqrt();
                        let sac = c.abs().sqrt();
                        p = sign(sab * sac, c);
                        tau = 1.0 / (b + c).abs().sqrt();
                        a = temp + p;
                        d = temp - p;
                        b -= c;
                        c = 0.0;
                        let cs1 = sab * tau;
                        let sn1 = sac * tau;
                        let t = cs * cs1 - sn * sn1;
                        sn = cs * sn1 + sn * cs1;
                        cs = t;
                    }
                } else {
                    b = -c;
                    c = 0.0;
                    let t = cs;
                    cs = -sn;
                    sn = t;
                }
            }
        }
    }
    Lanv2 { a, b, c, d, cs, sn }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanv2_reconstructs_and_standardizes() {
        // Hand-picked 2×2 matrices covering every branch: triangular, b = 0, complex pair,
        // real pair, nearly equal real eigenvalues.
        let cases = [
            [1.0, 2.0, 0.0, 3.0],
            [1.0, 0.0, 5.0, 3.0],
            [1.0, -4.0, 2.0, 1.5],
            [4.0, 1.0, 2.0, -3.0],
            [1.0, 1e-9, 1e-9, 1.0],
            [0.0, 1.0, -1.0, 0.0],
            [2.0, 3.0, 3.0, 2.0],
        ];
        for m in cases {
            let r = lanv2(m[0], m[1], m[2], m[3]);
            let (cs, sn) = (r.cs, r.sn);
            assert!((cs * cs + sn * sn - 1.0).abs() < 1e-15);
            // [a b; c d] = G·S·Gᵀ with G = [cs −sn; sn cs]
            let g = [[cs, -sn], [sn, cs]];
            let s = [[r.a, r.b], [r.c, r.d]];
            for i in 0..2 {
                for j in 0..2 {
                    let mut v = 0.0;
                    for k in 0..2 {
                        for l in 0..2 {
                            v += g[i][k] * s[k][l] * g[j][l];
                        }
                    }
                    assert!((v - m[2 * i + j]).abs() < 1e-14, "{m:?}");
                }
            }
            assert!(r.c == 0.0 || (r.a == r.d && r.b * r.c < 0.0), "{m:?} -> {r:?}");
        }
    }
}
