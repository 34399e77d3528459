//! Small-bulge multishift QR with aggressive early deflation (Braman, Byers & Mathias, "The
//! multishift QR algorithm. Part I: maintaining well-focused shifts and level 3 performance" and
//! "Part II: aggressive early deflation", SIAM J. Matrix Anal. Appl. 23(4), 2002), following the
//! method of LAPACK dlaqr0 (driver), dlaqr3 (deflation window) and dlaqr5 (the sweep).
//!
//! Why: the double-shift QR of [`crate::schur`] (dlahqr) applies one 3×3 reflector at a time to
//! whole rows and columns, which runs at memory speed. Here a chain of many small bulges is chased
//! through a short diagonal window; the reflectors are applied directly only inside the window and
//! accumulated into a small orthogonal `U`, and the rest of `H` (and `Z`) is updated by matrix
//! products afterwards (faer's GEMM). Aggressive early deflation finds converged eigenvalues in a
//! trailing window long before the subdiagonal is small, and supplies the next shifts.

use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};

use crate::dense::{clear_upper_simd, lanv2, larfg, Dm};
use crate::schur::{lahqr, trexc_up};
use crate::Result;

/// Below this order (of the whole matrix) the double-shift code is used. LAPACK's NMIN is 75 too;
/// here (callgrind instruction counts of `examples/time_schur.rs` on random matrices) the
/// multishift code needs 6 % fewer instructions at n = 80, 24 % at 100 and 34 % at 150.
pub(crate) const NMIN: usize = 75;
/// Iterations without deflation after which the deflation window grows (LAPACK KEXNW).
const KEXNW: usize = 5;
/// Iterations without deflation after which exceptional shifts are used (LAPACK KEXSH).
const KEXSH: usize = 6;
/// Percentage of the window that must deflate for the sweep to be skipped (LAPACK NIBBLE).
const NIBBLE: usize = 14;
/// Exceptional-shift constants (as dlaqr0).
const WILK1: f64 = 0.75;
const WILK2: f64 = -0.4375;

/// Number of simultaneous shifts for an active block of order `nh` (LAPACK iparmq, ISPEC = 15).
fn shift_count(nh: usize) -> usize {
    let ns = if nh < 30 {
        2
    } else if nh < 60 {
        4
    } else if nh < 150 {
        10
    } else if nh < 590 {
        10usize.max(nh / ((nh as f64).log2().round() as usize))
    } else if nh < 3000 {
        64
    } else if nh < 6000 {
        128
    } else {
        256
    };
    (ns - ns % 2).max(2)
}

/// Deflation-window size for an active block of order `nh` (iparmq, ISPEC = 13).
fn window_size(nh: usize) -> usize {
    let ns = shift_count(nh);
    if nh <= 500 {
        ns
    } else {
        3 * ns / 2
    }
}

/// Real Schur form of the upper Hessenberg `h` in place, accumulating into `z` unless `z` is empty
/// (order 0). Falls back to the double-shift [`lahqr`] below [`NMIN`].
pub(crate) fn laqr0(h: &mut Dm, z: &mut Dm) -> Result<()> {
    if h.n < NMIN {
        return lahqr(h, z);
    }
    clear_upper_simd();
    pulp::Arch::new().dispatch(Laqr0 { h, z })
}

struct Laqr0<'a> {
    h: &'a mut Dm,
    z: &'a mut Dm,
}

impl pulp::WithSimd for Laqr0<'_> {
    type Output = Result<()>;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> Result<()> {
        laqr0_body(self.h, self.z)
    }
}

#[inline(always)]
fn laqr0_body(h: &mut Dm, z: &mut Dm) -> Result<()> {
    let n = h.n;
    let wantz = z.n == n;
    let ulp = f64::EPSILON;
    let smlnum = f64::MIN_POSITIVE * (n as f64 / ulp);
    for j in 0..n {
        for i in j + 2..n {
            h[(i, j)] = 0.0;
        }
    }
    let nwmax = (n - 1) / 3;
    let nsmax = {
        let m = (n - 3) / 6;
        (m - m % 2).max(2)
    };
    let nsr = shift_count(n).min(nsmax);
    let nwr = window_size(n).max(2).min(nwmax);
    let mut sr = vec![0.0; n];
    let mut si = vec![0.0; n];
    let mut kbot = n as isize - 1;
    let itmax = 30 * n.max(10);
    let mut ndfl = 1usize;
    let mut ndec: isize = -1;
    let mut nw = 0usize;
    for _it in 0..itmax {
        if kbot < 0 {
            return Ok(());
        }
        let kb = kbot as usize;
        // Active block: the first negligible subdiagonal above kbot (Ahues & Tisseur's criterion,
        // as in dlahqr), which also catches deflations the sweep leaves behind.
        let mut ktop = kb;
        while ktop > 0 {
            if negligible_subdiag(h, ktop, smlnum) {
                h[(ktop, ktop - 1)] = 0.0;
                break;
            }
            ktop -= 1;
        }
        let nh = kb - ktop + 1;
        if nh == 1 {
            kbot -= 1;
            ndfl = 1;
            continue;
        }
        if nh == 2 {
            standardize_2x2(h, z, wantz, kb - 1);
            kbot -= 2;
            ndfl = 1;
            continue;
        }

        // Deflation-window size (dlaqr0's heuristics: grow it while nothing deflates).
        let nwupbd = nh.min(nwmax);
        nw = if ndfl < KEXNW {
            nwupbd.min(nwr)
        } else {
            nwupbd.min(2 * nw)
        };
        if nw < nwmax {
            if nw + 1 >= nh {
                nw = nh;
            } else {
                let kwtop = kb + 1 - nw;
                if h[(kwtop, kwtop - 1)].abs() > h[(kwtop - 1, kwtop - 2)].abs() {
                    nw += 1;
                }
            }
        }
        if ndfl < KEXNW {
            ndec = -1;
        } else if ndec >= 0 || nw >= nwupbd {
            ndec += 1;
            if (nw as isize) - ndec < 2 {
                ndec = 0;
            }
            nw = (nw as isize - ndec) as usize;
        }

        let (ls, ld) = aed(h, z, wantz, ktop, kb, nw, &mut sr, &mut si)?;
        kbot -= ld as isize;
        let mut ks = kbot - ls as isize + 1;

        let active = kbot - ktop as isize + 1;
        if active >= 3 && (ld == 0 || (100 * ld <= nw * NIBBLE && active as usize > NMIN.min(nwmax))) {
            let kb = kbot as usize;
            let mut ns = nsmax.min(nsr).min(2.max(kb - ktop));
            ns -= ns % 2;
            if ndfl % KEXSH == 0 {
                // Exceptional shifts (dlaqr0), to break a cycle of non-converging sweeps.
                ks = (kb + 1 - ns) as isize;
                let lo = (ks as usize + 1).max(ktop + 2);
                let mut i = kb;
                while i >= lo {
                    let ss = h[(i, i - 1)].abs() + h[(i - 1, i - 2)].abs();
                    let aa = WILK1 * ss + h[(i, i)];
                    let ((r1, i1), (r2, i2)) = eig2(aa, ss, WILK2 * ss, aa);
                    sr[i - 1] = r1;
                    si[i - 1] = i1;
                    sr[i] = r2;
                    si[i] = i2;
                    if i < lo + 2 {
                        break;
                    }
                    i -= 2;
                }
                if ks as usize == ktop {
                    sr[ktop + 1] = h[(ktop + 1, ktop + 1)];
                    si[ktop + 1] = 0.0;
                    sr[ktop] = sr[ktop + 1];
                    si[ktop] = 0.0;
                }
            } else {
                if kbot - ks < (ns / 2) as isize {
                    // Too few shifts from the window: use the eigenvalues of the trailing block.
                    ks = (kb + 1 - ns) as isize;
                    let k0 = ks as usize;
                    let mut t = Dm::zeros(ns);
                    for j in 0..ns {
                        for i in 0..ns.min(j + 2) {
                            t[(i, j)] = h[(k0 + i, k0 + j)];
                        }
                    }
                    if lahqr(&mut t, &mut Dm::zeros(0)).is_ok() {
                        block_eigs(&t, &mut sr[k0..=kb], &mut si[k0..=kb]);
                    } else {
                        ks = kbot - 1;
                        let k = kb - 1;
                        let ((r1, i1), (r2, i2)) = eig2(h[(k, k)], h[(k, k + 1)], h[(k + 1, k)], h[(k + 1, k + 1)]);
                        sr[k] = r1;
                        si[k] = i1;
                        sr[k + 1] = r2;
                        si[k + 1] = i2;
                    }
                }
                let k0 = ks as usize;
                if kb + 1 - k0 > ns {
                    // Largest shifts first: only the smallest `ns` are used, from the bottom.
                    let mut sorted = false;
                    let mut k = kb;
                    while !sorted && k > k0 {
                        sorted = true;
                        for i in k0..k {
                            if sr[i].abs() + si[i].abs() < sr[i + 1].abs() + si[i + 1].abs() {
                                sorted = false;
                                sr.swap(i, i + 1);
                                si.swap(i, i + 1);
                            }
                        }
                        k -= 1;
                    }
                }
                // Pairs of real shifts or complex-conjugate pairs, from the bottom up.
                let mut i = kb;
                while i >= k0 + 2 {
                    if si[i] != -si[i - 1] {
                        let (r, m) = (sr[i], si[i]);
                        sr[i] = sr[i - 1];
                        si[i] = si[i - 1];
                        sr[i - 1] = sr[i - 2];
                        si[i - 1] = si[i - 2];
                        sr[i - 2] = r;
                        si[i - 2] = m;
                    }
                    i -= 2;
                }
            }
            // Two real shifts: use the one closer to H(kbot, kbot) twice (as dlahqr).
            if kbot - ks + 1 == 2 && si[kb] == 0.0 {
                let hk = h[(kb, kb)];
                if (sr[kb] - hk).abs() < (sr[kb - 1] - hk).abs() {
                    sr[kb - 1] = sr[kb];
                } else {
                    sr[kb] = sr[kb - 1];
                }
            }
            let avail = (kbot - ks + 1).max(0) as usize;
            let mut ns = ns.min(avail);
            ns -= ns % 2;
            if ns >= 2 {
                let k0 = kb + 1 - ns;
                sweep(h, z, wantz, ktop, kb, &sr[k0..=kb], &si[k0..=kb]);
            }
        }
        if ld > 0 {
            ndfl = 1;
        } else {
            ndfl += 1;
        }
    }
    Err(crate::LinalgError::NoConvergence(format!(
        "real_schur: multishift QR did not converge for eigenvalue {} of {} after {} iterations",
        kbot + 1,
        n,
        itmax
    )))
}

/// Whether `H(k, k−1)` is negligible (dlahqr's test, Ahues & Tisseur LAWN 122).
#[inline]
fn negligible_subdiag(h: &Dm, k: usize, smlnum: f64) -> bool {
    let ulp = f64::EPSILON;
    let hkk1 = h[(k, k - 1)].abs();
    if hkk1 <= smlnum {
        return true;
    }
    let mut tst = h[(k - 1, k - 1)].abs() + h[(k, k)].abs();
    if tst == 0.0 {
        if k >= 2 {
            tst += h[(k - 1, k - 2)].abs();
        }
        if k + 1 < h.n {
            tst += h[(k + 1, k)].abs();
        }
    }
    if hkk1 <= ulp * tst {
        let ab = hkk1.max(h[(k - 1, k)].abs());
        let ba = hkk1.min(h[(k - 1, k)].abs());
        let dkk = (h[(k - 1, k - 1)] - h[(k, k)]).abs();
        let aa = h[(k, k)].abs().max(dkk);
        let bb = h[(k, k)].abs().min(dkk);
        let s = aa + ab;
        return ba * (ab / s) <= smlnum.max(ulp * (bb * (aa / s)));
    }
    false
}

/// Eigenvalues `((re1, im1), (re2, im2))` of `[a b; c d]` through its standardized form.
fn eig2(a: f64, b: f64, c: f64, d: f64) -> ((f64, f64), (f64, f64)) {
    let r = lanv2(a, b, c, d);
    if r.c == 0.0 {
        ((r.a, 0.0), (r.d, 0.0))
    } else {
        let im = r.b.abs().sqrt() * r.c.abs().sqrt();
        ((r.a, im), (r.d, -im))
    }
}

/// Eigenvalues of a quasi-triangular `t` into `sr`, `si` (a pair as `+im` then `−im`).
fn block_eigs(t: &Dm, sr: &mut [f64], si: &mut [f64]) {
    let n = t.n;
    let mut i = 0;
    while i < n {
        if i + 1 < n && t[(i + 1, i)] != 0.0 {
            let re = t[(i, i)];
            let im = t[(i, i + 1)].abs().sqrt() * t[(i + 1, i)].abs().sqrt();
            sr[i] = re;
            si[i] = im;
            sr[i + 1] = re;
            si[i + 1] = -im;
            i += 2;
        } else {
            sr[i] = t[(i, i)];
            si[i] = 0.0;
            i += 1;
        }
    }
}

/// Standardize the 2×2 diagonal block at rows `k, k+1` (dlanv2) and apply its rotation to the
/// rest of `H` and to `Z`.
fn standardize_2x2(h: &mut Dm, z: &mut Dm, wantz: bool, k: usize) {
    let n = h.n;
    let r = lanv2(h[(k, k)], h[(k, k + 1)], h[(k + 1, k)], h[(k + 1, k + 1)]);
    h[(k, k)] = r.a;
    h[(k, k + 1)] = r.b;
    h[(k + 1, k)] = r.c;
    h[(k + 1, k + 1)] = r.d;
    if k + 2 < n {
        h.rot_rows(k, k + 1, k + 2..n, r.cs, r.sn);
    }
    h.rot_cols(k, k + 1, 0..k, r.cs, r.sn);
    if wantz {
        z.rot_cols(k, k + 1, 0..n, r.cs, r.sn);
    }
}

/// The block `M[r0..r0+nr, c0..c0+nc]` as a column-major vector, copied column by column.
///
/// Why: faer's `to_owned` of a submatrix fills the copy entry by entry through a closure, which
/// showed as 5 % of a 50-state CARE solve (the copies of these updates); slice copies are memcpy.
fn copy_block(m: &Dm, r0: usize, nr: usize, c0: usize, nc: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(nr * nc);
    for j in c0..c0 + nc {
        out.extend_from_slice(&m.d[j * m.n + r0..j * m.n + r0 + nr]);
    }
    out
}

/// `M[rows, c0..c0+w] ← M[rows, c0..c0+w]·U` by a matrix product.
pub(crate) fn update_right(m: &mut Dm, rows: std::ops::Range<usize>, c0: usize, u: &Dm) {
    let (nn, w) = (m.n, u.n);
    if rows.is_empty() || w == 0 {
        return;
    }
    let nr = rows.len();
    let tmp = copy_block(m, rows.start, nr, c0, w);
    let tmp = MatRef::from_column_major_slice(&tmp, nr, w);
    let mut view = MatMut::from_column_major_slice_mut(&mut m.d, nn, nn);
    let mut blk = view.as_mut().submatrix_mut(rows.start, c0, nr, w);
    let uref = MatRef::from_column_major_slice(&u.d, w, w);
    matmul(blk.as_mut(), Accum::Replace, tmp, uref, 1.0, Par::Seq);
    clear_upper_simd();
}

/// `M[r0..r0+w, cols] ← Uᵀ·M[r0..r0+w, cols]` by a matrix product.
pub(crate) fn update_left(m: &mut Dm, r0: usize, cols: std::ops::Range<usize>, u: &Dm) {
    let (nn, w) = (m.n, u.n);
    if cols.is_empty() || w == 0 {
        return;
    }
    let nc = cols.len();
    let tmp = copy_block(m, r0, w, cols.start, nc);
    let tmp = MatRef::from_column_major_slice(&tmp, w, nc);
    let mut view = MatMut::from_column_major_slice_mut(&mut m.d, nn, nn);
    let mut blk = view.as_mut().submatrix_mut(r0, cols.start, w, nc);
    let uref = MatRef::from_column_major_slice(&u.d, w, w);
    matmul(blk.as_mut(), Accum::Replace, uref.transpose(), tmp, 1.0, Par::Seq);
    clear_upper_simd();
}

/// Aggressive early deflation on the trailing `nw`×`nw` window of the active block
/// `ktop..=kbot` (the method of dlaqr3). Returns `(ns, nd)`: `nd` eigenvalues deflated at the
/// bottom, and `ns` unconverged eigenvalues of the window left in `sr`, `si` at
/// `kbot+1−nd−ns .. kbot+1−nd`, to be used as shifts.
#[allow(clippy::too_many_arguments)]
fn aed(
    h: &mut Dm,
    z: &mut Dm,
    wantz: bool,
    ktop: usize,
    kbot: usize,
    nw: usize,
    sr: &mut [f64],
    si: &mut [f64],
) -> Result<(usize, usize)> {
    let n = h.n;
    let ulp = f64::EPSILON;
    let smlnum = f64::MIN_POSITIVE * (n as f64 / ulp);
    let jw = nw.min(kbot - ktop + 1);
    let kwtop = kbot + 1 - jw;
    let mut s = if kwtop == ktop { 0.0 } else { h[(kwtop, kwtop - 1)] };
    if jw == 1 {
        sr[kwtop] = h[(kwtop, kwtop)];
        si[kwtop] = 0.0;
        if s.abs() <= smlnum.max(ulp * h[(kwtop, kwtop)].abs()) {
            if kwtop > ktop {
                h[(kwtop, kwtop - 1)] = 0.0;
            }
            return Ok((0, 1));
        }
        return Ok((1, 0));
    }
    // Schur form of the window T = Vᵀ·H_w·V by the double-shift code.
    let mut t = Dm::zeros(jw);
    for j in 0..jw {
        for i in 0..jw.min(j + 2) {
            t[(i, j)] = h[(kwtop + i, kwtop + j)];
        }
    }
    let mut v = Dm::identity(jw);
    if lahqr(&mut t, &mut v).is_err() {
        // Nothing learned: no deflation and no shifts (the caller computes its own).
        return Ok((0, 0));
    }
    // Deflation test on the spike s·V(0, :), bottom block first; undeflatable blocks are moved to
    // the top of the window so that the next candidate is always at the bottom.
    let mut ns = jw;
    let mut ilst = 0usize;
    while ilst < ns {
        let pair = ns >= 2 && t[(ns - 1, ns - 2)] != 0.0;
        if !pair {
            let mut scale = t[(ns - 1, ns - 1)].abs();
            if scale == 0.0 {
                scale = s.abs();
            }
            if (s * v[(0, ns - 1)]).abs() <= smlnum.max(ulp * scale) {
                ns -= 1;
            } else {
                let ifst = ns - 1;
                if ifst > ilst {
                    // A rejected swap leaves a valid Schur form; the block is then kept undeflated.
                    let _ = trexc_up(&mut t, &mut v, ifst, ilst);
                }
                ilst += 1;
            }
        } else {
            let mut scale =
                t[(ns - 1, ns - 1)].abs() + t[(ns - 1, ns - 2)].abs().sqrt() * t[(ns - 2, ns - 1)].abs().sqrt();
            if scale == 0.0 {
                scale = s.abs();
            }
            let spike = (s * v[(0, ns - 1)]).abs().max((s * v[(0, ns - 2)]).abs());
            if spike <= smlnum.max(ulp * scale) {
                ns -= 2;
            } else {
                let ifst = ns - 2;
                if ifst > ilst {
                    let _ = trexc_up(&mut t, &mut v, ifst, ilst);
                }
                ilst += 2;
            }
        }
    }
    if ns == 0 {
        s = 0.0;
    }
    block_eigs(&t, &mut sr[kwtop..=kbot], &mut si[kwtop..=kbot]);

    if ns < jw || s == 0.0 {
        if ns > 1 && s != 0.0 {
            // Reflect the remaining spike back to a multiple of e1, then restore Hessenberg form
            // of the undeflated leading ns×ns part of T.
            let mut w: Vec<f64> = (0..ns).map(|j| s * v[(0, j)]).collect();
            let (_beta, tau) = larfg(w[0], &mut w[1..]);
            w[0] = 1.0;
            for j in 0..jw {
                for i in j + 2..jw {
                    t[(i, j)] = 0.0;
                }
            }
            t.refl_left(&w, tau, 0, 0..jw);
            t.refl_right(&w, tau, 0, 0..ns);
            v.refl_right(&w, tau, 0, 0..jw);
            hessenberg_leading(&mut t, &mut v, ns);
        }
        if kwtop > 0 {
            h[(kwtop, kwtop - 1)] = s * v[(0, 0)];
        }
        for j in 0..jw {
            for i in 0..jw {
                h[(kwtop + i, kwtop + j)] = if i <= j + 1 { t[(i, j)] } else { 0.0 };
            }
        }
        // The rest of H and Z by matrix products (all of H: the full Schur form is wanted).
        update_right(h, 0..kwtop, kwtop, &v);
        update_left(h, kwtop, kbot + 1..n, &v);
        if wantz {
            update_right(z, 0..n, kwtop, &v);
        }
    }
    Ok((ns, jw - ns))
}

/// Householder reduction of the leading `ns`×`ns` block of `t` to Hessenberg form; the left
/// reflectors also act on the trailing columns of those rows, the right ones are accumulated in
/// `v` (dgehrd with ILO = 1, IHI = ns, then dormhr, on the deflation window).
fn hessenberg_leading(t: &mut Dm, v: &mut Dm, ns: usize) {
    let jw = t.n;
    if ns < 3 {
        return;
    }
    let mut u = vec![0.0; ns];
    for k in 0..ns - 2 {
        let m = ns - k - 1;
        for i in 1..m {
            u[i] = t[(k + 1 + i, k)];
        }
        let (beta, tau) = larfg(t[(k + 1, k)], &mut u[1..m]);
        u[0] = 1.0;
        t[(k + 1, k)] = beta;
        for i in k + 2..ns {
            t[(i, k)] = 0.0;
        }
        if tau == 0.0 {
            continue;
        }
        t.refl_left(&u[..m], tau, k + 1, k + 1..jw);
        t.refl_right(&u[..m], tau, k + 1, 0..ns);
        v.refl_right(&u[..m], tau, k + 1, 0..jw);
    }
}

/// First column of `(H − s1)(H − s2)` for the leading 3×3 block at `(k, k)`, scaled (dlaqr1).
fn shift_vector(h: &Dm, k: usize, sr1: f64, si1: f64, sr2: f64, si2: f64) -> [f64; 3] {
    let (h11, h21, h31) = (h[(k, k)], h[(k + 1, k)], h[(k + 2, k)]);
    let (h12, h22, h32) = (h[(k, k + 1)], h[(k + 1, k + 1)], h[(k + 2, k + 1)]);
    let (h13, h23, h33) = (h[(k, k + 2)], h[(k + 1, k + 2)], h[(k + 2, k + 2)]);
    let s = (h11 - sr2).abs() + si2.abs() + h21.abs() + h31.abs();
    if s == 0.0 {
        return [0.0; 3];
    }
    let h21s = h21 / s;
    let h31s = h31 / s;
    [
        (h11 - sr1) * ((h11 - sr2) / s) - si1 * (si2 / s) + h12 * h21s + h13 * h31s,
        h21s * (h11 + h22 - sr1 - sr2) + h23 * h31s,
        h31s * (h11 + h33 - sr1 - sr2) + h21s * h32,
    ]
}

/// One reflector of the chain: `I − τ·u·uᵀ` on rows/columns `p..p+len`, `u = [1, u1, u2]`.
#[derive(Clone, Copy)]
struct Refl {
    p: usize,
    len: usize,
    u1: f64,
    u2: f64,
    tau: f64,
}

/// One small-bulge multishift QR sweep on the active block `ktop..=kbot` with the shifts `sr`,
/// `si` (even count, pairs real or complex conjugate): a chain of 3×3 bulges, three rows apart,
/// chased down together (the method of dlaqr5). The chase runs in chunks of steps; each chunk's
/// reflectors are applied directly only inside its diagonal window and accumulated in `U`, and
/// the rest of `H` and `Z` is updated by three matrix products per chunk.
#[inline(always)]
fn sweep(h: &mut Dm, z: &mut Dm, wantz: bool, ktop: usize, kbot: usize, sr: &[f64], si: &[f64]) {
    let n = h.n;
    let ulp = f64::EPSILON;
    let nb = sr.len() / 2;
    if nb == 0 || kbot < ktop + 2 {
        return;
    }
    // Bulge b (0 = the first introduced, deepest) acts at step s on rows p = ktop + s − 3b ...
    // while p ≤ kbot − 1.
    let total = (kbot - 1 - ktop) + 3 * (nb - 1) + 1;
    let pos = |b: usize, s: usize| -> Option<usize> {
        if s < 3 * b {
            return None;
        }
        let p = ktop + s - 3 * b;
        (p < kbot).then_some(p)
    };
    let chunk = (3 * nb).max(6);
    let mut refl: Vec<Refl> = Vec::with_capacity(nb);
    let mut s0 = 0;
    while s0 < total {
        let s1 = (s0 + chunk).min(total);
        let (mut lo, mut hi) = (usize::MAX, 0usize);
        for s in s0..s1 {
            for b in 0..nb {
                if let Some(p) = pos(b, s) {
                    lo = lo.min(p);
                    hi = hi.max((p + 3).min(kbot));
                }
            }
        }
        let w = hi - lo + 1;
        let mut u = Dm::identity(w);
        // Row range of the possibly nonzero entries of each column of U: a reflector mixes three
        // columns, so their ranges merge; applying it only there halves the accumulation work.
        let mut urows: Vec<(usize, usize)> = (0..w).map(|c| (c, c)).collect();
        for s in s0..s1 {
            refl.clear();
            for b in 0..nb {
                let Some(p) = pos(b, s) else { continue };
                let len = 3.min(kbot - p + 1);
                let (sr1, si1, sr2, si2) = (sr[2 * b], si[2 * b], sr[2 * b + 1], si[2 * b + 1]);
                let r = if p == ktop {
                    // Introduce the bulge: the first column of the shift polynomial.
                    let vv = shift_vector(h, ktop, sr1, si1, sr2, si2);
                    let mut x = [vv[1], vv[2]];
                    let (_, tau) = larfg(vv[0], &mut x);
                    Refl {
                        p,
                        len: 3,
                        u1: x[0],
                        u2: x[1],
                        tau,
                    }
                } else if len == 3 {
                    let k = p - 1;
                    let mut x = [h[(k + 2, k)], h[(k + 3, k)]];
                    let (beta, tau) = larfg(h[(k + 1, k)], &mut x);
                    let mut r = Refl {
                        p,
                        len,
                        u1: x[0],
                        u2: x[1],
                        tau,
                    };
                    if h[(k + 3, k)] != 0.0 || h[(k + 3, k + 1)] != 0.0 || h[(k + 3, k + 2)] == 0.0 {
                        h[(k + 1, k)] = beta;
                    } else {
                        // The bulge has collapsed: try a fresh one from the shifts, if it does not
                        // disturb the Hessenberg form beyond rounding (dlaqr5's safeguard).
                        let vt = shift_vector(h, k + 1, sr1, si1, sr2, si2);
                        let mut xt = [vt[1], vt[2]];
                        let (_, taut) = larfg(vt[0], &mut xt);
                        let refsum = taut * (h[(k + 1, k)] + xt[0] * h[(k + 2, k)]);
                        if (h[(k + 2, k)] - refsum * xt[0]).abs() + (refsum * xt[1]).abs()
                            > ulp * (h[(k, k)].abs() + h[(k + 1, k + 1)].abs() + h[(k + 2, k + 2)].abs())
                        {
                            h[(k + 1, k)] = beta;
                        } else {
                            h[(k + 1, k)] -= refsum;
                            r = Refl {
                                p,
                                len,
                                u1: xt[0],
                                u2: xt[1],
                                tau: taut,
                            };
                        }
                    }
                    h[(k + 2, k)] = 0.0;
                    h[(k + 3, k)] = 0.0;
                    r
                } else {
                    // The last bulge leaves through a 2×2 reflector.
                    let k = p - 1;
                    let mut x = [h[(k + 2, k)]];
                    let (beta, tau) = larfg(h[(k + 1, k)], &mut x);
                    h[(k + 1, k)] = beta;
                    h[(k + 2, k)] = 0.0;
                    Refl {
                        p,
                        len,
                        u1: x[0],
                        u2: 0.0,
                        tau,
                    }
                };
                refl.push(r);
            }
            // All left applications, then all right ones: the reflectors of one step act on
            // disjoint index sets, so this equals applying them one at a time, deepest first.
            for r in &refl {
                if r.tau == 0.0 {
                    continue;
                }
                let (p, nn) = (r.p, n);
                let (t1, t2, t3) = (r.tau, r.tau * r.u1, r.tau * r.u2);
                for j in p..=hi {
                    let col = &mut h.d[j * nn + p..j * nn + p + r.len];
                    if r.len == 3 {
                        let sum = col[0] + r.u1 * col[1] + r.u2 * col[2];
                        col[0] -= sum * t1;
                        col[1] -= sum * t2;
                        col[2] -= sum * t3;
                    } else {
                        let sum = col[0] + r.u1 * col[1];
                        col[0] -= sum * t1;
                        col[1] -= sum * t2;
                    }
                }
            }
            for r in &refl {
                if r.tau == 0.0 {
                    continue;
                }
                let rmax = (r.p + 3).min(kbot);
                cols_reflect(&mut h.d, n, r, lo..rmax + 1, r.p);
                let c = r.p - lo;
                let span = urows[c..c + r.len]
                    .iter()
                    .fold((usize::MAX, 0), |(a, b), &(x, y)| (a.min(x), b.max(y)));
                urows[c..c + r.len].iter_mut().for_each(|e| *e = span);
                cols_reflect(&mut u.d, w, r, span.0..span.1 + 1, c);
            }
        }
        // Off-window parts: rows above (all of them: the full Schur form is wanted), columns to
        // the right, and Z.
        update_right(h, 0..lo, lo, &u);
        update_left(h, lo, hi + 1..n, &u);
        if wantz {
            update_right(z, 0..n, lo, &u);
        }
        s0 = s1;
    }
}

/// `M[rows, c..c+len] ← M[rows, c..c+len]·(I − τ·u·uᵀ)` on column-major `d` (leading dimension
/// `ld`), columns contiguous.
#[inline(always)]
fn cols_reflect(d: &mut [f64], ld: usize, r: &Refl, rows: std::ops::Range<usize>, c: usize) {
    let (t1, t2, t3) = (r.tau, r.tau * r.u1, r.tau * r.u2);
    let (a, rest) = d.split_at_mut((c + 1) * ld);
    let c0 = &mut a[c * ld + rows.start..c * ld + rows.end];
    let (b, rest) = rest.split_at_mut(ld);
    let c1 = &mut b[rows.start..rows.end];
    if r.len == 3 {
        let c2 = &mut rest[rows.start..rows.end];
        for ((x0, x1), x2) in c0.iter_mut().zip(c1.iter_mut()).zip(c2.iter_mut()) {
            let sum = *x0 + r.u1 * *x1 + r.u2 * *x2;
            *x0 -= sum * t1;
            *x1 -= sum * t2;
            *x2 -= sum * t3;
        }
    } else {
        for (x0, x1) in c0.iter_mut().zip(c1.iter_mut()) {
            let sum = *x0 + r.u1 * *x1;
            *x0 -= sum * t1;
            *x1 -= sum * t2;
        }
    }
}
