//! Real Schur decomposition `A = Q·T·Qᵀ` and reordering of the Schur form.
//!
//! Householder reduction to Hessenberg form (faer's blocked `hessenberg_in_place`, or LAPACK
//! dgehd2/dorghr below order 32), then for order ≥ 75 the small-bulge multishift QR with aggressive
//! early deflation (`multishift.rs`, the method of LAPACK dlaqr0/3/5), and below that the Francis
//! double-shift QR iteration with small-subdiagonal deflation and exceptional shifts (dlahqr),
//! which is also the kernel of the multishift code's deflation window; `Q` is accumulated and 2×2
//! blocks are standardized (dlanv2). Reordering swaps adjacent 1×1/2×2
//! diagonal blocks by orthogonal similarities (dtrexc/dlaexc), solving the small Sylvester equation
//! of each swap with complete pivoting (as dlasy2), and rejects a swap whose result would not be
//! upper quasi-triangular to working accuracy.

use faer::{c64, Mat, MatRef};

use crate::dense::{clear_upper_simd, lanv2, larfg, lartg, Dm};
use crate::{LinalgError, Result};

/// Real Schur form `A = Q·T·Qᵀ`: `Q` orthogonal, `T` upper quasi-triangular with standardized 2×2
/// blocks (equal diagonal, off-diagonals of opposite sign) for complex-conjugate eigenvalue pairs.
#[derive(Debug, Clone)]
pub struct Schur {
    /// Quasi-upper-triangular factor `T`.
    pub t: Mat<f64>,
    /// Orthogonal factor `Q` (columns are Schur vectors).
    pub q: Mat<f64>,
}

impl Schur {
    /// Eigenvalues in the order of the diagonal blocks of `T` (a complex pair as `+im` then `−im`).
    pub fn eigenvalues(&self) -> Vec<c64> {
        block_eigenvalues(&Dm::from_mat(self.t.as_ref()))
    }

    /// Sizes (1 or 2) of the diagonal blocks of `T`, top to bottom.
    pub fn block_sizes(&self) -> Vec<usize> {
        let n = self.t.nrows();
        let mut out = Vec::new();
        let mut k = 0;
        while k < n {
            let nb = if k + 1 < n && self.t[(k + 1, k)] != 0.0 { 2 } else { 1 };
            out.push(nb);
            k += nb;
        }
        out
    }
}

pub(crate) fn block_eigenvalues(t: &Dm) -> Vec<c64> {
    let n = t.n;
    let mut out = Vec::with_capacity(n);
    let mut k = 0;
    while k < n {
        if k + 1 < n && t[(k + 1, k)] != 0.0 {
            let re = t[(k, k)];
            let im = t[(k, k + 1)].abs().sqrt() * t[(k + 1, k)].abs().sqrt();
            out.push(c64::new(re, im));
            out.push(c64::new(re, -im));
            k += 2;
        } else {
            out.push(c64::new(t[(k, k)], 0.0));
            k += 1;
        }
    }
    out
}

fn check_square_finite(a: MatRef<f64>, what: &str) -> Result<()> {
    if a.nrows() != a.ncols() {
        return Err(LinalgError::Dimension(format!(
            "{what}: matrix is {}x{}, not square",
            a.nrows(),
            a.ncols()
        )));
    }
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            if !a[(i, j)].is_finite() {
                return Err(LinalgError::InvalidArgument(format!(
                    "{what}: matrix has NaN or infinite entries"
                )));
            }
        }
    }
    Ok(())
}

/// Real Schur decomposition `A = Q·T·Qᵀ` of a square matrix (no balancing, so `Q` is orthogonal).
pub fn real_schur(a: MatRef<f64>) -> Result<Schur> {
    check_square_finite(a, "real_schur")?;
    let (t, q) = schur_dm(Dm::from_mat(a))?;
    Ok(Schur {
        t: t.to_mat(),
        q: q.to_mat(),
    })
}

/// Eigenvalues of a square matrix: balancing (permutation and scaling, [`crate::balance`]) followed
/// by the real Schur form of the balanced matrix. More accurate than `real_schur(a)?.eigenvalues()`
/// for badly scaled matrices; the order is that of the Schur form.
pub fn eigenvalues(a: MatRef<f64>) -> Result<Vec<c64>> {
    check_square_finite(a, "eigenvalues")?;
    eigenvalues_unbalanced(crate::balance::balance(a).a.as_ref())
}

/// Eigenvalues of a square matrix as given, without balancing: for a matrix that is already
/// balanced (the block `ilo..=ihi` of [`crate::balance::Balanced::a`]), where a second balancing
/// pass would only cost time. Hessenberg reduction, then the QR iteration without Schur vectors
/// (as [`eigenvalues`]); the order is that of the quasi-triangular form.
///
/// # Errors
/// A non-square matrix, NaN or infinite entries, or a QR iteration that does not converge.
pub fn eigenvalues_unbalanced(a: MatRef<f64>) -> Result<Vec<c64>> {
    check_square_finite(a, "eigenvalues_unbalanced")?;
    let mut h = Dm::from_mat(a);
    let mut z = Dm::zeros(0);
    hessenberg(&mut h, false);
    if h.n < crate::multishift::NMIN {
        // Same eigenvalues bit for bit (the active block never reads what lies outside it).
        lahqr_with(&mut h, &mut z, false)?;
    } else {
        crate::multishift::laqr0(&mut h, &mut z)?;
    }
    Ok(block_eigenvalues(&h))
}

/// Eigenvalues of an upper Hessenberg work matrix (destroyed) by the QR iteration without the
/// Schur factor outside the active block below the multishift order.
///
/// No balancing: the one caller, Van Loan's square-reduced Hamiltonian method, has already made
/// an error of order ε‖H‖² in forming H² and reducing it, and a diagonal scaling of the reduced
/// block cannot undo that; it only moved the QR's own error (ε‖W‖ ≤ ε‖H‖²) and cost 6 % of a
/// 40-state H∞ norm.
pub(crate) fn hessenberg_eigenvalues(h: &mut Dm) -> Result<Vec<c64>> {
    let n = h.n;
    if h.d.iter().any(|v| !v.is_finite()) {
        return Err(LinalgError::InvalidArgument(
            "eigenvalues: matrix has NaN or infinite entries".into(),
        ));
    }
    for j in 0..n {
        for i in j + 2..n {
            h[(i, j)] = 0.0;
        }
    }
    if n < crate::multishift::NMIN {
        lahqr_with(h, &mut Dm::zeros(0), false)?;
    } else {
        crate::multishift::laqr0(h, &mut Dm::zeros(0))?;
    }
    Ok(block_eigenvalues(h))
}

/// Schur form on work matrices: returns `(T, Q)`.
pub(crate) fn schur_dm(mut h: Dm) -> Result<(Dm, Dm)> {
    let mut q = hessenberg(&mut h, true);
    crate::multishift::laqr0(&mut h, &mut q)?;
    Ok((h, q))
}

/// Below this order the unblocked reduction [`hessenberg_unblocked`] is used: faer's reduction
/// (blocked above its own 256 threshold, a fused two-sided unblocked kernel below) and its blocked
/// accumulation of `Q` pay for their setup only on larger matrices. Measured: the 40×40 pole
/// computation of a 40-state H∞ norm made the whole norm 5 % faster unblocked (0.66 → 0.625 ms,
/// same result), while at order 100 (Schur form, CARE) faer's was 10 % faster; 48 keeps n = 50.
const FAER_HESSENBERG_MIN: usize = 48;

/// Householder reduction `A = Q·H·Qᵀ` in place, returning `Q` when `want_q` (otherwise an empty
/// matrix). faer's public `hessenberg_in_place` (blocked, dgehrd-like) and its block-reflector
/// application form `Q` (as dorghr) for all but tiny orders.
fn hessenberg(h: &mut Dm, want_q: bool) -> Dm {
    let n = h.n;
    if n < FAER_HESSENBERG_MIN {
        clear_upper_simd();
        return hessenberg_unblocked(h, want_q);
    }
    use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
    use faer::linalg::{evd::hessenberg as fh, householder};
    use faer::{Conj, MatMut, Par};
    let bs = faer::linalg::qr::no_pivoting::factor::recommended_block_size::<f64>(n - 1, n - 1);
    let req = StackReq::any_of(&[
        fh::hessenberg_in_place_scratch::<f64>(n, bs, Par::Seq, Default::default()),
        householder::apply_block_householder_sequence_on_the_right_in_place_scratch::<f64>(n - 1, bs, n - 1),
    ]);
    let mut buf = MemBuffer::new(req);
    let stack = MemStack::new(&mut buf);
    let mut coeffs = Mat::<f64>::zeros(bs, n - 1);
    let mut a = MatMut::from_column_major_slice_mut(&mut h.d, n, n);
    fh::hessenberg_in_place(a.as_mut(), coeffs.as_mut(), Par::Seq, stack, Default::default());
    let mut q = if want_q { Dm::identity(n) } else { Dm::zeros(0) };
    if want_q {
        let qm = MatMut::from_column_major_slice_mut(&mut q.d, n, n);
        householder::apply_block_householder_sequence_on_the_right_in_place_with_conj(
            a.as_ref().submatrix(1, 0, n - 1, n - 1),
            coeffs.as_ref(),
            Conj::No,
            qm.submatrix_mut(1, 1, n - 1, n - 1),
            Par::Seq,
            stack,
        );
    }
    clear_upper_simd();
    for j in 0..n {
        for i in j + 2..n {
            h[(i, j)] = 0.0;
        }
    }
    q
}

/// Householder reduction `A = Q·H·Qᵀ` in place (dgehd2), returning the accumulated `Q` (dorghr)
/// when `want_q` (otherwise an empty matrix).
fn hessenberg_unblocked(h: &mut Dm, want_q: bool) -> Dm {
    let n = h.n;
    let mut q = if want_q { Dm::identity(n) } else { Dm::zeros(0) };
    if n < 3 {
        return q;
    }
    let mut v = vec![0.0; n];
    let mut w = vec![0.0; n];
    for k in 0..n - 2 {
        let m = n - k - 1; // length of the reflector, acting on rows/cols k+1..n
        v[0] = 1.0;
        for i in 1..m {
            v[i] = h[(k + 1 + i, k)];
        }
        let (beta, tau) = larfg(h[(k + 1, k)], &mut v[1..m]);
        h[(k + 1, k)] = beta;
        for i in k + 2..n {
            h[(i, k)] = 0.0;
        }
        if tau == 0.0 {
            continue;
        }
        let vk = &v[..m];
        h.refl_left(vk, tau, k + 1, k + 1..n);
        // Right application H ← H·(I − τvvᵀ) and Q ← Q·(I − τvvᵀ) column-wise (contiguous).
        for mat in [&mut *h, &mut q] {
            let nn = mat.n;
            if nn == 0 {
                continue;
            }
            w[..nn].iter_mut().for_each(|x| *x = 0.0);
            for (jj, vj) in vk.iter().enumerate() {
                let col = &mat.d[(k + 1 + jj) * nn..(k + 2 + jj) * nn];
                for (wi, ci) in w.iter_mut().zip(col) {
                    *wi += vj * ci;
                }
            }
            for (jj, vj) in vk.iter().enumerate() {
                let f = tau * vj;
                let col = &mut mat.d[(k + 1 + jj) * nn..(k + 2 + jj) * nn];
                for (ci, wi) in col.iter_mut().zip(w.iter()) {
                    *ci -= f * wi;
                }
            }
        }
    }
    q
}

/// Francis double-shift QR on an upper Hessenberg matrix (LAPACK dlahqr with WANTT = true),
/// accumulating the transformations into `z` unless `z` is empty (WANTZ = false).
pub(crate) fn lahqr(h: &mut Dm, z: &mut Dm) -> Result<()> {
    lahqr_with(h, z, true)
}

/// [`lahqr`], with the Schur factor `T` outside the active block left unfinished unless `wantt`
/// (dlahqr's WANTT): the eigenvalues are the same, at about half the work.
pub(crate) fn lahqr_with(h: &mut Dm, z: &mut Dm, wantt: bool) -> Result<()> {
    let n = h.n;
    if n <= 1 {
        return Ok(());
    }
    clear_upper_simd();
    let wantz = z.n == n;
    const DAT1: f64 = 0.75;
    const DAT2: f64 = -0.4375;
    const KEXSH: usize = 10;
    for j in 0..n.saturating_sub(3) {
        h[(j + 2, j)] = 0.0;
        h[(j + 3, j)] = 0.0;
    }
    if n >= 3 {
        h[(n - 1, n - 3)] = 0.0;
    }
    let ilo = 0usize;
    let ihi = n - 1;
    let nh = ihi - ilo + 1;
    let safmin = f64::MIN_POSITIVE;
    let ulp = f64::EPSILON;
    let smlnum = safmin * (nh as f64 / ulp);
    let itmax = 30 * nh.max(10);
    let mut kdefl = 0usize;
    let (mut i1, mut i2) = (0usize, n - 1);

    let mut i = ihi as isize;
    while i >= ilo as isize {
        let iu = i as usize;
        let mut l = ilo;
        let mut converged = false;
        for _its in 0..=itmax {
            // Look for a single small subdiagonal element.
            let mut k = iu;
            while k > l {
                let hkk1 = h[(k, k - 1)].abs();
                if hkk1 <= smlnum {
                    break;
                }
                let mut tst = h[(k - 1, k - 1)].abs() + h[(k, k)].abs();
                if tst == 0.0 {
                    if k >= ilo + 2 {
                        tst += h[(k - 1, k - 2)].abs();
                    }
                    if k < ihi {
                        tst += h[(k + 1, k)].abs();
                    }
                }
                // Ahues & Tisseur's conservative deflation criterion (LAWN 122).
                if hkk1 <= ulp * tst {
                    let ab = hkk1.max(h[(k - 1, k)].abs());
                    let ba = hkk1.min(h[(k - 1, k)].abs());
                    let dkk = (h[(k - 1, k - 1)] - h[(k, k)]).abs();
                    let aa = h[(k, k)].abs().max(dkk);
                    let bb = h[(k, k)].abs().min(dkk);
                    let s = aa + ab;
                    if ba * (ab / s) <= smlnum.max(ulp * (bb * (aa / s))) {
                        break;
                    }
                }
                k -= 1;
            }
            l = k;
            if l > ilo {
                h[(l, l - 1)] = 0.0;
            }
            if l + 1 >= iu {
                converged = true;
                break;
            }
            kdefl += 1;
            if !wantt {
                i1 = l;
                i2 = iu;
            }

            let (h11, h12, h21, h22);
            if kdefl % (2 * KEXSH) == 0 {
                let s = h[(iu, iu - 1)].abs() + h[(iu - 1, iu - 2)].abs();
                h11 = DAT1 * s + h[(iu, iu)];
                h12 = DAT2 * s;
                h21 = s;
                h22 = h11;
            } else if kdefl % KEXSH == 0 {
                let s = h[(l + 1, l)].abs() + h[(l + 2, l + 1)].abs();
                h11 = DAT1 * s + h[(l, l)];
                h12 = DAT2 * s;
                h21 = s;
                h22 = h11;
            } else {
                h11 = h[(iu - 1, iu - 1)];
                h21 = h[(iu, iu - 1)];
                h12 = h[(iu - 1, iu)];
                h22 = h[(iu, iu)];
            }
            let s = h11.abs() + h12.abs() + h21.abs() + h22.abs();
            let (rt1r, rt1i, rt2r, rt2i);
            if s == 0.0 {
                rt1r = 0.0;
                rt1i = 0.0;
                rt2r = 0.0;
                rt2i = 0.0;
            } else {
                let (h11, h12, h21, h22) = (h11 / s, h12 / s, h21 / s, h22 / s);
                let tr = (h11 + h22) / 2.0;
                let det = (h11 - tr) * (h22 - tr) - h12 * h21;
                let rtdisc = det.abs().sqrt();
                if det >= 0.0 {
                    rt1r = tr * s;
                    rt2r = rt1r;
                    rt1i = rtdisc * s;
                    rt2i = -rt1i;
                } else {
                    // Real shifts: use the one closer to h22 twice.
                    let a = tr + rtdisc;
                    let b = tr - rtdisc;
                    let r = if (a - h22).abs() <= (b - h22).abs() {
                        a * s
                    } else {
                        b * s
                    };
                    rt1r = r;
                    rt2r = r;
                    rt1i = 0.0;
                    rt2i = 0.0;
                }
            }

            // Look for two consecutive small subdiagonal elements.
            let mut m = iu - 2;
            let mut v = [0.0f64; 3];
            loop {
                let h21s0 = h[(m + 1, m)];
                let s = (h[(m, m)] - rt2r).abs() + rt2i.abs() + h21s0.abs();
                let h21s = h21s0 / s;
                v[0] = h21s * h[(m, m + 1)] + (h[(m, m)] - rt1r) * ((h[(m, m)] - rt2r) / s) - rt1i * (rt2i / s);
                v[1] = h21s * (h[(m, m)] + h[(m + 1, m + 1)] - rt1r - rt2r);
                v[2] = h21s * h[(m + 2, m + 1)];
                let s = v[0].abs() + v[1].abs() + v[2].abs();
                v[0] /= s;
                v[1] /= s;
                v[2] /= s;
                if m == l {
                    break;
                }
                let h00 = h[(m, m - 1)].abs() * (v[1].abs() + v[2].abs());
                let h01 = v[0].abs() * (h[(m - 1, m - 1)].abs() + h[(m, m)].abs() + h[(m + 1, m + 1)].abs());
                if h00 <= ulp * h01 {
                    break;
                }
                m -= 1;
            }

            // Double-shift QR sweep (bulge chase) over rows/columns m..=i.
            for k in m..iu {
                let nr = 3.min(iu - k + 1);
                if k > m {
                    for r in 0..nr {
                        v[r] = h[(k + r, k - 1)];
                    }
                }
                let (beta, t1) = larfg(v[0], &mut v[1..nr]);
                v[0] = beta;
                if k > m {
                    h[(k, k - 1)] = v[0];
                    h[(k + 1, k - 1)] = 0.0;
                    if k + 1 < iu {
                        h[(k + 2, k - 1)] = 0.0;
                    }
                } else if m > l {
                    // Avoids a sign flip bug when v[1], v[2] underflow (dlahqr comment).
                    h[(k, k - 1)] *= 1.0 - t1;
                }
                let v2 = v[1];
                let t2 = t1 * v2;
                let nn = h.n;
                if nr == 3 {
                    let v3 = v[2];
                    let t3 = t1 * v3;
                    // Rows k..k+3, columns k..=i2 (strided).
                    for j in k..=i2 {
                        let col = &mut h.d[j * nn + k..j * nn + k + 3];
                        let sum = col[0] + v2 * col[1] + v3 * col[2];
                        col[0] -= sum * t1;
                        col[1] -= sum * t2;
                        col[2] -= sum * t3;
                    }
                    // Columns k..k+3, rows i1..=min(k+3, i) (contiguous).
                    let jmax = (k + 3).min(iu);
                    apply3_cols(&mut h.d, nn, k, i1..jmax + 1, v2, v3, t1, t2, t3);
                    if wantz {
                        apply3_cols(&mut z.d, nn, k, 0..nn, v2, v3, t1, t2, t3);
                    }
                } else if nr == 2 {
                    for j in k..=i2 {
                        let col = &mut h.d[j * nn + k..j * nn + k + 2];
                        let sum = col[0] + v2 * col[1];
                        col[0] -= sum * t1;
                        col[1] -= sum * t2;
                    }
                    apply2_cols(&mut h.d, nn, k, i1..iu + 1, v2, t1, t2);
                    if wantz {
                        apply2_cols(&mut z.d, nn, k, 0..nn, v2, t1, t2);
                    }
                }
            }
        }
        if !converged {
            return Err(LinalgError::NoConvergence(format!(
                "real_schur: QR iteration did not converge for eigenvalue {} of {} after {} iterations",
                iu + 1,
                n,
                itmax
            )));
        }
        if l + 1 == iu {
            // A 2×2 block converged: standardize it and apply the rotation to the rest.
            let r = lanv2(h[(iu - 1, iu - 1)], h[(iu - 1, iu)], h[(iu, iu - 1)], h[(iu, iu)]);
            h[(iu - 1, iu - 1)] = r.a;
            h[(iu - 1, iu)] = r.b;
            h[(iu, iu - 1)] = r.c;
            h[(iu, iu)] = r.d;
            if wantt {
                if i2 > iu {
                    h.rot_rows(iu - 1, iu, iu + 1..i2 + 1, r.cs, r.sn);
                }
                h.rot_cols(iu - 1, iu, i1..iu - 1, r.cs, r.sn);
            }
            if wantz {
                z.rot_cols(iu - 1, iu, 0..n, r.cs, r.sn);
            }
        }
        kdefl = 0;
        i = l as isize - 1;
    }
    Ok(())
}

/// Apply the 3-element reflector `I − t1·[1; v2; v3]·[1; v2; v3]ᵀ` from the right to columns
/// `k..k+3` of the column-major `d` (leading dimension `nn`) over `rows`.
#[allow(clippy::too_many_arguments)]
#[inline]
fn apply3_cols(
    d: &mut [f64],
    nn: usize,
    k: usize,
    rows: std::ops::Range<usize>,
    v2: f64,
    v3: f64,
    t1: f64,
    t2: f64,
    t3: f64,
) {
    let (left, right) = d.split_at_mut((k + 1) * nn);
    let (mid, rest) = right.split_at_mut(nn);
    let c0 = &mut left[k * nn + rows.start..k * nn + rows.end];
    let c1 = &mut mid[rows.start..rows.end];
    let c2 = &mut rest[rows.start..rows.end];
    for ((x0, x1), x2) in c0.iter_mut().zip(c1.iter_mut()).zip(c2.iter_mut()) {
        let sum = *x0 + v2 * *x1 + v3 * *x2;
        *x0 -= sum * t1;
        *x1 -= sum * t2;
        *x2 -= sum * t3;
    }
}

/// Two-element version of [`apply3_cols`] on columns `k`, `k+1`.
#[inline]
fn apply2_cols(d: &mut [f64], nn: usize, k: usize, rows: std::ops::Range<usize>, v2: f64, t1: f64, t2: f64) {
    let (left, right) = d.split_at_mut((k + 1) * nn);
    let c0 = &mut left[k * nn + rows.start..k * nn + rows.end];
    let c1 = &mut right[rows.start..rows.end];
    for (x0, x1) in c0.iter_mut().zip(c1.iter_mut()) {
        let sum = *x0 + v2 * *x1;
        *x0 -= sum * t1;
        *x1 -= sum * t2;
    }
}

/// Move the selected eigenvalues of a real Schur form to the leading diagonal block (as LAPACK
/// dtrsen without condition estimates). A complex pair is selected when `select` accepts either of
/// its eigenvalues. Returns the size of the leading block. Fails, leaving `s` a valid Schur form
/// of the same matrix, when a swap is rejected because it would lose accuracy (eigenvalues of the
/// two blocks too close for a stable swap).
pub fn reorder_schur(s: &mut Schur, select: impl Fn(c64) -> bool) -> Result<usize> {
    let n = s.t.nrows();
    if s.t.ncols() != n || s.q.nrows() != n || s.q.ncols() != n {
        return Err(LinalgError::Dimension(format!(
            "reorder_schur: T is {}x{}, Q is {}x{}",
            n,
            s.t.ncols(),
            s.q.nrows(),
            s.q.ncols()
        )));
    }
    let mut t = Dm::from_mat(s.t.as_ref());
    let mut q = Dm::from_mat(s.q.as_ref());
    let res = reorder_dm(&mut t, &mut q, &select);
    s.t = t.to_mat();
    s.q = q.to_mat();
    res
}

/// [`reorder_schur`] on work matrices: windowed ([`reorder_blocked`]) from order
/// [`REORDER_BLOCKED_MIN`] on, one swap at a time over whole rows below it.
pub(crate) fn reorder_dm(t: &mut Dm, q: &mut Dm, select: &dyn Fn(c64) -> bool) -> Result<usize> {
    clear_upper_simd();
    if t.n >= REORDER_BLOCKED_MIN {
        return reorder_blocked(t, q, select);
    }
    pulp::Arch::new().dispatch(Reorder { t, q, select })
}

/// [`reorder_unblocked`] compiled for AVX2 where the CPU has it (pulp's run-time dispatch): the
/// rotations and reflectors of the swaps then update `Q` and the columns of `T` with 256-bit
/// vectors. The order of every floating-point operation is that of the baseline build.
struct Reorder<'a> {
    t: &'a mut Dm,
    q: &'a mut Dm,
    select: &'a dyn Fn(c64) -> bool,
}

impl pulp::WithSimd for Reorder<'_> {
    type Output = Result<usize>;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> Result<usize> {
        reorder_unblocked(self.t, self.q, self.select)
    }
}

/// The unblocked reordering (dtrsen's loop over dtrexc).
#[inline(always)]
pub(crate) fn reorder_unblocked(t: &mut Dm, q: &mut Dm, select: &dyn Fn(c64) -> bool) -> Result<usize> {
    let n = t.n;
    let mut ks = 0usize;
    let mut k = 0usize;
    while k < n {
        let nb = if k + 1 < n && t[(k + 1, k)] != 0.0 { 2 } else { 1 };
        let selected = if nb == 1 {
            select(c64::new(t[(k, k)], 0.0))
        } else {
            let re = t[(k, k)];
            let im = t[(k, k + 1)].abs().sqrt() * t[(k + 1, k)].abs().sqrt();
            select(c64::new(re, im)) || select(c64::new(re, -im))
        };
        if selected {
            if k != ks {
                trexc_up(t, q, k, ks)?;
            }
            ks += nb;
        }
        k += nb;
    }
    Ok(ks)
}

/// From this order on, [`reorder_dm`] moves the selected eigenvalues in windows
/// ([`reorder_blocked`]); below it, one swap at a time over whole rows and columns. Measured with
/// `examples/time_schur.rs` (left half-plane first, random matrices, on a busy 2-core machine):
/// about even at n = 100, blocked 1.2–1.4× faster at 200, 1.6–2.5× at 400 and 2.5× at 1000
/// (213 → 85 ms).
pub(crate) const REORDER_BLOCKED_MIN: usize = 128;
/// Order of the diagonal window of the blocked reordering (Kressner's `nw`; 32, 48 and 64 were
/// within the timing noise of each other, 96 and 128 slower).
const REORDER_WINDOW: usize = 48;
/// Eigenvalues moved together through the windows (at most half the window, so that each window
/// step makes progress).
const REORDER_BATCH: usize = REORDER_WINDOW / 2;

/// Per-row selection flags of a Schur form: `true` on the rows of each block that `select` accepts
/// (a complex pair when either of its eigenvalues is accepted).
fn selected_rows(t: &Dm, select: &dyn Fn(c64) -> bool) -> Vec<bool> {
    let n = t.n;
    let mut sel = vec![false; n];
    let mut k = 0;
    while k < n {
        let nb = if k + 1 < n && t[(k + 1, k)] != 0.0 { 2 } else { 1 };
        let s = if nb == 1 {
            select(c64::new(t[(k, k)], 0.0))
        } else {
            let re = t[(k, k)];
            let im = t[(k, k + 1)].abs().sqrt() * t[(k + 1, k)].abs().sqrt();
            select(c64::new(re, im)) || select(c64::new(re, -im))
        };
        sel[k..k + nb].iter_mut().for_each(|x| *x = s);
        k += nb;
    }
    sel
}

/// Blocked reordering (Kressner, "Block algorithms for reordering standard and generalized Schur
/// forms", ACM TOMS 32(4), 2006): the selected eigenvalues are moved up in batches of at most
/// [`REORDER_BATCH`] through a chain of overlapping diagonal windows of order [`REORDER_WINDOW`],
/// bottom window first. Inside a window the swaps (the same [`laexc`] as the unblocked code) act
/// on a copy of the window only, and their product is accumulated in a small orthogonal `U`; the
/// rows to the right, the columns above and `Q` are then updated by three matrix products. The
/// swaps are the same as those of the unblocked code, so the result agrees with it to rounding.
fn reorder_blocked(t: &mut Dm, q: &mut Dm, select: &dyn Fn(c64) -> bool) -> Result<usize> {
    let n = t.n;
    let mut sel = selected_rows(t, select);
    let mut ilst = 0usize;
    loop {
        while ilst < n && sel[ilst] {
            ilst += 1;
        }
        // The batch: the first selected eigenvalues below `ilst`, up to REORDER_BATCH of them,
        // whole blocks only; `we` is the end of its last block.
        let (mut count, mut we, mut k) = (0usize, 0usize, ilst);
        while k < n {
            let nb = if k + 1 < n && t[(k + 1, k)] != 0.0 { 2 } else { 1 };
            if sel[k] {
                if count + nb > REORDER_BATCH && count > 0 {
                    break;
                }
                count += nb;
                we = k + nb;
            }
            k += nb;
        }
        if count == 0 {
            return Ok(ilst);
        }
        loop {
            let mut ws = we.saturating_sub(REORDER_WINDOW).max(ilst);
            if ws > ilst && t[(ws, ws - 1)] != 0.0 {
                ws -= 1; // do not split a 2×2 block
            }
            let (moved, res) = reorder_window(t, q, &sel, ws, we);
            sel[ws..ws + moved].iter_mut().for_each(|x| *x = true);
            sel[ws + moved..we].iter_mut().for_each(|x| *x = false);
            res?;
            if ws == ilst {
                ilst += moved;
                break;
            }
            we = ws + moved;
        }
    }
}

/// Moves the selected blocks of the window `ws..we` of `T` to its top (in their order), updating
/// the rest of `T` and `Q` by matrix products. Returns the number of rows moved, and the error of a
/// rejected swap (the window is then left as far as it got, still a valid Schur form).
fn reorder_window(t: &mut Dm, q: &mut Dm, sel: &[bool], ws: usize, we: usize) -> (usize, Result<()>) {
    let n = t.n;
    let w = we - ws;
    let mut tw = Dm::zeros(w);
    for j in 0..w {
        for i in 0..w {
            tw[(i, j)] = t[(ws + i, ws + j)];
        }
    }
    let mut u = Dm::identity(w);
    let mut ks = 0usize;
    let mut k = 0usize;
    let mut res = Ok(());
    let mut touched = false;
    while k < w {
        let nb = if k + 1 < w && tw[(k + 1, k)] != 0.0 { 2 } else { 1 };
        if sel[ws + k] {
            if k != ks {
                touched = true;
                if let Err(e) = trexc_up(&mut tw, &mut u, k, ks) {
                    res = Err(e);
                    break;
                }
            }
            ks += nb;
        }
        k += nb;
    }
    if !touched {
        return (ks, res);
    }
    for j in 0..w {
        for i in 0..w {
            t[(ws + i, ws + j)] = tw[(i, j)];
        }
    }
    crate::multishift::update_right(t, 0..ws, ws, &u);
    crate::multishift::update_left(t, ws, we..n, &u);
    crate::multishift::update_right(q, 0..n, ws, &u);
    (ks, res)
}

/// Move the diagonal block starting at `ifst` up to start at `ilst` (`ilst < ifst`) by adjacent
/// swaps (the upward branch of LAPACK dtrexc).
#[inline(always)]
pub(crate) fn trexc_up(t: &mut Dm, q: &mut Dm, ifst: usize, ilst: usize) -> Result<()> {
    let n = t.n;
    let mut nbf = if ifst + 1 < n && t[(ifst + 1, ifst)] != 0.0 {
        2
    } else {
        1
    };
    let mut here = ifst;
    let block_above = |t: &Dm, here: usize| {
        if here >= 2 && t[(here - 1, here - 2)] != 0.0 {
            2
        } else {
            1
        }
    };
    while here > ilst {
        if nbf == 1 || nbf == 2 {
            let nbnext = block_above(t, here);
            laexc(t, q, here - nbnext, nbnext, nbf)?;
            here -= nbnext;
            if nbf == 2 && t[(here + 1, here)] == 0.0 {
                // The 2×2 block split into two 1×1 blocks during the swap.
                nbf = 3;
            }
        } else {
            // Two 1×1 blocks that must be moved one at a time.
            let mut nbnext = block_above(t, here);
            laexc(t, q, here - nbnext, nbnext, 1)?;
            if nbnext == 1 {
                laexc(t, q, here, 1, 1)?;
                here -= 1;
            } else {
                if t[(here, here - 1)] == 0.0 {
                    nbnext = 1;
                }
                if nbnext == 2 {
                    laexc(t, q, here - 1, 2, 1)?;
                } else {
                    laexc(t, q, here, 1, 1)?;
                    laexc(t, q, here - 1, 1, 1)?;
                }
                here -= 2;
            }
        }
    }
    Ok(())
}

/// Swap adjacent diagonal blocks `T11` (order `n1`, starting at `j1`) and `T22` (order `n2`) by an
/// orthogonal similarity, updating `Q` (LAPACK dlaexc).
#[inline(always)]
fn laexc(t: &mut Dm, q: &mut Dm, j1: usize, n1: usize, n2: usize) -> Result<()> {
    let n = t.n;
    let (j2, j3, j4) = (j1 + 1, j1 + 2, j1 + 3);
    if n1 == 1 && n2 == 1 {
        let t11 = t[(j1, j1)];
        let t22 = t[(j2, j2)];
        let (cs, sn, _) = lartg(t[(j1, j2)], t22 - t11);
        if j3 < n {
            t.rot_rows(j1, j2, j3..n, cs, sn);
        }
        t.rot_cols(j1, j2, 0..j1, cs, sn);
        t[(j1, j1)] = t22;
        t[(j2, j2)] = t11;
        q.rot_cols(j1, j2, 0..n, cs, sn);
        return Ok(());
    }

    let nd = n1 + n2;
    let mut d = Dm::zeros(nd);
    let mut dnorm = 0.0f64;
    for jj in 0..nd {
        for ii in 0..nd {
            d[(ii, jj)] = t[(j1 + ii, j1 + jj)];
            dnorm = dnorm.max(d[(ii, jj)].abs());
        }
    }
    let eps = f64::EPSILON;
    let smlnum = f64::MIN_POSITIVE / eps;
    let thresh = (10.0 * eps * dnorm).max(smlnum);
    // Solve T11·X − X·T22 = scale·T12.
    // Fixed-size arrays: a swap is called thousands of times per reordering, heap work shows.
    let (mut tl, mut tr, mut b) = ([0.0; 4], [0.0; 4], [0.0; 4]);
    (0..n1 * n1).for_each(|e| tl[e] = d[(e % n1, e / n1)]);
    (0..n2 * n2).for_each(|e| tr[e] = d[(n1 + e % n2, n1 + e / n2)]);
    (0..n1 * n2).for_each(|e| b[e] = d[(e % n1, n1 + e / n1)]);
    let (x, scale) = small_sylvester(&tl[..n1 * n1], n1, &tr[..n2 * n2], n2, &b[..n1 * n2]);
    let xm = |i: usize, j: usize| x[i + j * n1];

    let reject = |what: f64| -> Result<()> {
        if what > thresh {
            Err(LinalgError::NoSolution(format!(
                "reorder_schur: swapping the diagonal blocks at rows {} and {} would lose accuracy \
                 (error {:.2e} > {:.2e}); their eigenvalues are too close to reorder stably",
                j1 + 1,
                j1 + n1 + 1,
                what,
                thresh
            )))
        } else {
            Ok(())
        }
    };

    match (n1, n2) {
        (1, 2) => {
            let mut u = [scale, xm(0, 0), xm(0, 1)];
            let (beta, tau) = {
                let (head, tail) = u.split_at_mut(2);
                let r = larfg(tail[0], head);
                tail[0] = r.0;
                r
            };
            let _ = beta;
            u[2] = 1.0;
            let t11 = t[(j1, j1)];
            d.refl_left(&u, tau, 0, 0..3);
            d.refl_right(&u, tau, 0, 0..3);
            reject(d[(2, 0)].abs().max(d[(2, 1)].abs()).max((d[(2, 2)] - t11).abs()))?;
            t.refl_left(&u, tau, j1, j1..n);
            t.refl_right(&u, tau, j1, 0..j2 + 1);
            t[(j3, j1)] = 0.0;
            t[(j3, j2)] = 0.0;
            t[(j3, j3)] = t11;
            q.refl_right(&u, tau, j1, 0..n);
        }
        (2, 1) => {
            let mut u = [-xm(0, 0), -xm(1, 0), scale];
            let (_, tau) = larfg(u[0], &mut u[1..3]);
            u[0] = 1.0;
            let t33 = t[(j3, j3)];
            d.refl_left(&u, tau, 0, 0..3);
            d.refl_right(&u, tau, 0, 0..3);
            reject(d[(1, 0)].abs().max(d[(2, 0)].abs()).max((d[(0, 0)] - t33).abs()))?;
            t.refl_right(&u, tau, j1, 0..j3 + 1);
            t.refl_left(&u, tau, j1, j2..n);
            t[(j1, j1)] = t33;
            t[(j2, j1)] = 0.0;
            t[(j3, j1)] = 0.0;
            q.refl_right(&u, tau, j1, 0..n);
        }
        _ => {
            let mut u1 = [-xm(0, 0), -xm(1, 0), scale];
            let (_, tau1) = larfg(u1[0], &mut u1[1..3]);
            u1[0] = 1.0;
            let temp = -tau1 * (xm(0, 1) + u1[1] * xm(1, 1));
            let mut u2 = [-temp * u1[1] - xm(1, 1), -temp * u1[2], scale];
            let (_, tau2) = larfg(u2[0], &mut u2[1..3]);
            u2[0] = 1.0;
            d.refl_left(&u1, tau1, 0, 0..4);
            d.refl_right(&u1, tau1, 0, 0..4);
            d.refl_left(&u2, tau2, 1, 0..4);
            d.refl_right(&u2, tau2, 1, 0..4);
            reject(
                d[(2, 0)]
                    .abs()
                    .max(d[(2, 1)].abs())
                    .max(d[(3, 0)].abs())
                    .max(d[(3, 1)].abs()),
            )?;
            t.refl_left(&u1, tau1, j1, j1..n);
            t.refl_right(&u1, tau1, j1, 0..j4 + 1);
            t.refl_left(&u2, tau2, j2, j1..n);
            t.refl_right(&u2, tau2, j2, 0..j4 + 1);
            t[(j3, j1)] = 0.0;
            t[(j3, j2)] = 0.0;
            t[(j4, j1)] = 0.0;
            t[(j4, j2)] = 0.0;
            q.refl_right(&u1, tau1, j1, 0..n);
            q.refl_right(&u2, tau2, j2, 0..n);
        }
    }

    // Standardize the new 2×2 blocks.
    let standardize = |t: &mut Dm, q: &mut Dm, p: usize| {
        let r = lanv2(t[(p, p)], t[(p, p + 1)], t[(p + 1, p)], t[(p + 1, p + 1)]);
        t[(p, p)] = r.a;
        t[(p, p + 1)] = r.b;
        t[(p + 1, p)] = r.c;
        t[(p + 1, p + 1)] = r.d;
        if p + 2 < n {
            t.rot_rows(p, p + 1, p + 2..n, r.cs, r.sn);
        }
        t.rot_cols(p, p + 1, 0..p, r.cs, r.sn);
        q.rot_cols(p, p + 1, 0..n, r.cs, r.sn);
    };
    if n2 == 2 {
        standardize(t, q, j1);
    }
    if n1 == 2 {
        standardize(t, q, j1 + n2);
    }
    Ok(())
}

/// Solve `TL·X − X·TR = scale·B` for `X` (`n1×n2`, column-major), `n1, n2 ∈ {1, 2}`, by Gaussian
/// elimination with complete pivoting on the Kronecker form; tiny pivots are raised to `smin` and
/// `scale ≤ 1` guards against overflow (the method of LAPACK dlasy2).
fn small_sylvester(tl: &[f64], n1: usize, tr: &[f64], n2: usize, b: &[f64]) -> ([f64; 4], f64) {
    let eps = f64::EPSILON;
    let smlnum = f64::MIN_POSITIVE / eps;
    let m = n1 * n2;
    let tmax = tl.iter().chain(tr.iter()).fold(0.0f64, |a, v| a.max(v.abs()));
    let smin = (eps * tmax).max(smlnum);
    // Kronecker matrix K = I⊗TL − TRᵀ⊗I acting on vec(X) (column-major).
    let mut k = [[0.0f64; 4]; 4];
    for j in 0..n2 {
        for i in 0..n1 {
            let row = i + j * n1;
            for p in 0..n1 {
                k[row][p + j * n1] += tl[i + p * n1];
            }
            for p in 0..n2 {
                k[row][i + p * n1] -= tr[p + j * n2];
            }
        }
    }
    let mut rhs = [0.0f64; 4];
    rhs[..m].copy_from_slice(&b[..m]);
    let mut colperm = [0usize, 1, 2, 3];
    for step in 0..m {
        // Complete pivoting.
        let (mut pr, mut pc, mut pv) = (step, step, -1.0);
        for (r, krow) in k.iter().enumerate().take(m).skip(step) {
            for (c, kv) in krow.iter().enumerate().take(m).skip(step) {
                if kv.abs() > pv {
                    pv = kv.abs();
                    pr = r;
                    pc = c;
                }
            }
        }
        k.swap(step, pr);
        rhs.swap(step, pr);
        if pc != step {
            for row in k.iter_mut() {
                row.swap(step, pc);
            }
            colperm.swap(step, pc);
        }
        if k[step][step].abs() < smin {
            k[step][step] = smin;
        }
        for r in step + 1..m {
            let f = k[r][step] / k[step][step];
            if f != 0.0 {
                let prow = k[step];
                for (x, p) in k[r][step..m].iter_mut().zip(&prow[step..m]) {
                    *x -= f * p;
                }
                rhs[r] -= f * rhs[step];
            }
        }
    }
    // Scale the right-hand side if the solution might overflow.
    let mut scale = 1.0;
    let bmax = rhs[..m].iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let umin = (0..m).fold(f64::INFINITY, |a, i| a.min(k[i][i].abs()));
    if bmax > 0.0 && 8.0 * smlnum * bmax > umin * (1.0 / smlnum).min(1.0 / eps) {
        scale = (1.0 / 8.0) / bmax;
        for v in rhs[..m].iter_mut() {
            *v *= scale;
        }
    }
    let mut y = [0.0f64; 4];
    for r in (0..m).rev() {
        let mut s = rhs[r];
        for c in r + 1..m {
            s -= k[r][c] * y[c];
        }
        y[r] = s / k[r][r];
    }
    let mut x = [0.0; 4];
    for p in 0..m {
        x[colperm[p]] = y[p];
    }
    (x, scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n`×`n` with entries uniform in [−1, 1) times 10^(−decades·j/n) in column j (graded).
    fn lcg_matrix(n: usize, seed: u64, decades: f64) -> Dm {
        let mut state = seed;
        let mut m = Dm::zeros(n);
        for j in 0..n {
            let g = 10f64.powf(-decades * j as f64 / n as f64);
            for i in 0..n {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                m[(i, j)] = (((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0) * g;
            }
        }
        m
    }

    /// (‖A − Q·T·Qᵀ‖_F/‖A‖_F, ‖QᵀQ − I‖_F, largest entry below the quasi-triangle of T).
    fn schur_errors(a: &Dm, t: &Dm, q: &Dm) -> (f64, f64, f64) {
        let (a, t, q) = (a.to_mat(), t.to_mat(), q.to_mat());
        let n = a.nrows();
        let berr = (&q * &t * q.transpose() - &a).norm_l2() / a.norm_l2();
        let orth = (q.transpose() * &q - Mat::<f64>::identity(n, n)).norm_l2();
        let mut below = 0.0f64;
        for j in 0..n {
            for i in j + 2..n {
                below = below.max(t[(i, j)].abs());
            }
            // No two consecutive nonzero subdiagonal entries.
            if j + 2 < n && t[(j + 1, j)] != 0.0 && t[(j + 2, j + 1)] != 0.0 {
                below = f64::INFINITY;
            }
        }
        (berr, orth, below)
    }

    fn sorted(mut v: Vec<c64>) -> Vec<c64> {
        v.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
        v
    }

    #[test]
    fn blocked_reordering_matches_unblocked() {
        let selections: [(&str, &dyn Fn(c64) -> bool); 3] = [
            ("left half-plane", &|z: c64| z.re < 0.0),
            ("right half-plane", &|z: c64| z.re > 0.0),
            ("every other band", &|z: c64| {
                (z.re * 3.0).floor().rem_euclid(2.0) == 0.0
            }),
        ];
        for (n, seed, decades) in [(40, 1, 0.0), (150, 2, 0.0), (150, 3, 8.0), (400, 4, 0.0), (400, 5, 6.0)] {
            let a = lcg_matrix(n, seed, decades);
            let (t0, q0) = schur_dm(a.clone()).unwrap();
            let (base_berr, base_orth, _) = schur_errors(&a, &t0, &q0);
            for (name, select) in selections {
                let (mut t1, mut q1) = (t0.clone(), q0.clone());
                let k1 = reorder_unblocked(&mut t1, &mut q1, select).unwrap();
                let (mut t2, mut q2) = (t0.clone(), q0.clone());
                let k2 = reorder_blocked(&mut t2, &mut q2, select).unwrap();
                assert_eq!(k1, k2, "n={n} {name}: selected counts differ");
                let lead = |t: &Dm| {
                    let mut lt = Dm::zeros(k1);
                    for j in 0..k1 {
                        for i in 0..k1 {
                            lt[(i, j)] = t[(i, j)];
                        }
                    }
                    sorted(block_eigenvalues(&lt))
                };
                let all = sorted(block_eigenvalues(&t0));
                let scale = all.iter().fold(0.0f64, |m, z| m.max(z.norm()));
                for (x, y) in lead(&t1).iter().zip(lead(&t2).iter()) {
                    assert!((x - y).norm() <= 1e-10 * scale, "n={n} {name}: {x} vs {y}");
                }
                assert!(lead(&t2).iter().all(|z| select(*z)), "n={n} {name}: unselected on top");
                let (b1, o1, _) = schur_errors(&a, &t1, &q1);
                let (b2, o2, below) = schur_errors(&a, &t2, &q2);
                assert!(below == 0.0, "n={n} {name}: T not quasi-triangular ({below:e})");
                assert!(
                    b2 <= 4.0 * b1.max(base_berr) + 1e-15 && o2 <= 4.0 * o1.max(base_orth) + 1e-14,
                    "n={n} {name}: blocked backward error {b2:.1e} / orthogonality {o2:.1e}, \
                     unblocked {b1:.1e} / {o1:.1e}"
                );
            }
        }
    }

    #[test]
    fn small_sylvester_all_sizes() {
        // Random-looking but fixed blocks; checks TL·X − X·TR = scale·B directly.
        let tl2 = [1.0, -3.0, 2.0, 1.0]; // column-major [[1, 2], [-3, 1]]
        let tr2 = [-4.0, 1.0, -5.0, -4.0];
        let tl1 = [2.5];
        let tr1 = [-0.5];
        for (tl, n1) in [(&tl1[..], 1), (&tl2[..], 2)] {
            for (tr, n2) in [(&tr1[..], 1), (&tr2[..], 2)] {
                let b: Vec<f64> = (0..n1 * n2).map(|e| 1.0 + e as f64).collect();
                let (x, scale) = small_sylvester(tl, n1, tr, n2, &b);
                for i in 0..n1 {
                    for j in 0..n2 {
                        let mut r = -scale * b[i + j * n1];
                        for p in 0..n1 {
                            r += tl[i + p * n1] * x[p + j * n1];
                        }
                        for p in 0..n2 {
                            r -= x[i + p * n1] * tr[p + j * n2];
                        }
                        assert!(r.abs() < 1e-14, "n1={n1} n2={n2} r={r}");
                    }
                }
            }
        }
    }
}
