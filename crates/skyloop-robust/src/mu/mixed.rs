//! Mixed-μ upper bound with D–G scalings for structures with real scalar blocks
//! (Fan, Tits & Doyle, IEEE TAC 36(1), 1991; Young, Newlin & Doyle, 1995).
//!
//! μ(M) ≤ β if there are P = DᴴD > 0 commuting with Δ and a Hermitian G, block diagonal and nonzero
//! only on the real scalar blocks, with Mᴴ P_L M + j(G M − Mᴴ G) − β² P_R ≤ 0. With B = D_L M D_R⁻¹
//! and Ĝ = D_R⁻ᴴ G D_L⁻¹ (same block pattern, still Hermitian per block) the inequality is
//! λ_max(BᴴB + j(ĜB − BᴴĜ)) ≤ β², so the best β for given D is √λ_max of a matrix affine in Ĝ: no
//! bisection on β is needed. λ_max is minimized jointly over the log-D generators (multiplicative
//! steps, as in the complex bound) and Ĝ, through the smoothed maximum
//! f_t = λ₁ + ln Σ e^{t(λᵢ−λ₁)} / t (bias ≤ ln n / t) sharpened in stages, by BFGS, from the complex
//! bound's optimal D and Ĝ = 0 (where λ_max = the complex bound squared). A rectangular M is handled
//! as if zero-padded to square: G lives only on the (square) scalar blocks, so the padding never
//! meets it. The final (D, G) is mapped back to M's coordinates and the inequality is checked there
//! with a dense eigen-decomposition; only a bound that passes is returned.

use super::bfgs::{bfgs_update, descent, identity, scale};
use super::upper::DScales;
use crate::error::Result;
use crate::error::RobustError;
use crate::uncertainty::blocks::{BlockKind, BlockStructure};
use faer::linalg::solvers::DenseSolveCore;
use faer::{c64, Mat, MatRef, Side};
use skyloop_linalg::hermitian::{top_eigen, Workspace};

/// A certified mixed-μ upper bound with the scalings that prove it.
#[derive(Debug, Clone)]
pub struct MixedUpper {
    /// The bound β (dimensionless): Mᴴ P_L M + j(G M − Mᴴ G) − β² P_R ≤ 0 holds for `d` and `g`.
    pub value: f64,
    /// The D-scales (P = DᴴD per block).
    pub d: DScales,
    /// G in M's coordinates: per block, an r×r Hermitian matrix on real scalar blocks, empty otherwise.
    pub g: Vec<Mat<c64>>,
}

const ZERO: c64 = c64 { re: 0.0, im: 0.0 };

/// Parameters of one block: log-D generator (1 for a full block, r² for a scalar block) then, for a
/// real scalar block, r² more for Ĝ.
fn n_d(b: &BlockKind) -> usize {
    match b {
        BlockKind::Full { .. } => 1,
        _ => b.rows() * b.rows(),
    }
}

fn n_g(b: &BlockKind) -> usize {
    if b.is_real() {
        b.rows() * b.rows()
    } else {
        0
    }
}

/// Hermitian r×r matrix from r² parameters (diagonal, then real/imaginary parts above it).
fn hermitian(r: usize, p: &[f64]) -> Mat<c64> {
    let mut e = Mat::<c64>::zeros(r, r);
    let mut off = 0;
    for i in 0..r {
        e[(i, i)] = c64::new(p[off], 0.0);
        off += 1;
    }
    for i in 0..r {
        for k in i + 1..r {
            let z = c64::new(p[off], p[off + 1]);
            e[(i, k)] = z;
            e[(k, i)] = z.conj();
            off += 2;
        }
    }
    e
}

/// exp of a Hermitian matrix by its eigen-decomposition.
fn expm_hermitian(e: &Mat<c64>) -> Result<Mat<c64>> {
    let r = e.nrows();
    if r == 1 {
        return Ok(Mat::from_fn(1, 1, |_, _| c64::new(e[(0, 0)].re.exp(), 0.0)));
    }
    let evd = e
        .self_adjoint_eigen(Side::Lower)
        .map_err(|err| RobustError::Numerical(format!("eigen-decomposition of a D-scale generator failed: {err:?}")))?;
    let lam: Vec<f64> = (0..r).map(|k| evd.S().column_vector()[k].re).collect();
    let u = evd.U();
    Ok(Mat::from_fn(r, r, |p, q| {
        (0..r).fold(ZERO, |acc, k| acc + u[(p, k)] * lam[k].exp() * u[(q, k)].conj())
    }))
}

/// Current iterate: D-scales (on M) and Ĝ per real block (in the normalized scaled coordinates).
#[derive(Clone)]
struct Point {
    d: DScales,
    g: Vec<Mat<c64>>,
}

struct Eval {
    f: f64,
    lam_max: f64,
    grad: Vec<f64>,
}

/// G·X for the block-diagonal G (M cols × M rows) holding G_j at (column range, row range) of each
/// real block and zero elsewhere.
fn g_times(s: &BlockStructure, g: &[Mat<c64>], x: MatRef<c64>) -> Mat<c64> {
    let nc = x.ncols();
    let mut gx = Mat::<c64>::zeros(s.m_cols(), nc);
    for (j, blk) in s.blocks().iter().enumerate() {
        if !blk.is_real() {
            continue;
        }
        let (rr, cr) = (s.row_range(j), s.col_range(j));
        for (p, cp) in cr.clone().enumerate() {
            for (q, rq) in rr.clone().enumerate() {
                let gpq = g[j][(p, q)];
                if gpq != ZERO {
                    for c in 0..nc {
                        gx[(cp, c)] += gpq * x[(rq, c)];
                    }
                }
            }
        }
    }
    gx
}

/// H = BᴴB + j(ĜB − BᴴĜᴴ) with Ĝ placed at (column range, row range) of each real block.
fn h_matrix(b: MatRef<c64>, s: &BlockStructure, g: &[Mat<c64>]) -> Mat<c64> {
    let nc = b.ncols();
    let gb = g_times(s, g, b);
    let bhb = b.adjoint() * b;
    let jj = c64::new(0.0, 1.0);
    Mat::from_fn(nc, nc, |p, q| bhb[(p, q)] + jj * (gb[(p, q)] - gb[(q, p)].conj()))
}

fn eigen(h: &Mat<c64>) -> Result<(Vec<f64>, Mat<c64>)> {
    let evd = h
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| RobustError::Numerical(format!("eigen-decomposition in the mixed mu bound failed: {e:?}")))?;
    let n = h.nrows();
    let lam = (0..n).map(|i| evd.S().column_vector()[i].re).collect();
    Ok((lam, evd.U().to_owned()))
}

/// f_t and its gradient in (log-D generators, Ĝ) at the scaled matrix `b` (already divided by the
/// normalization), Ĝ = `g`.
fn evaluate(b: MatRef<c64>, s: &BlockStructure, g: &[Mat<c64>], t: f64, ws: &mut Workspace) -> Result<Eval> {
    let h = h_matrix(b, s, g);
    let n = h.nrows();
    // Vectors only for the eigenvalues that carry weight e^{t(λ−λ₁)} > 1e-16 (the tridiagonal solver
    // of the complex bound); the dense solver only if its QR iteration fails.
    let needed = |lam: &[f64]| {
        let top = lam.last().copied().unwrap_or(0.0);
        lam.iter().filter(|&&l| t * (l - top) > -36.8).count().max(1)
    };
    let (lam, vecs) = match top_eigen(h.as_ref(), ws, needed) {
        Some(te) => (te.lam, te.vecs),
        None => {
            let (lam, u) = eigen(&h)?;
            // eigen() is ascending; reorder the vectors so that column c belongs to lam[n − 1 − c].
            let vecs = Mat::from_fn(n, n, |p, c| u[(p, n - 1 - c)]);
            (lam, vecs)
        }
    };
    let top = lam.last().copied().unwrap_or(f64::NAN);
    if !top.is_finite() {
        return Err(RobustError::Numerical(
            "non-finite eigenvalue in the mixed mu bound".into(),
        ));
    }
    let np: usize = s.blocks().iter().map(|b| n_d(b) + n_g(b)).sum();
    let mut grad = vec![0.0; np];
    let mut sum = 0.0;
    let mut weights = Vec::new();
    for (c, &l) in lam.iter().rev().enumerate() {
        let w = (t * (l - top)).exp();
        if w <= 1e-16 || c >= vecs.ncols() {
            break;
        }
        weights.push((c, w));
        sum += w;
    }
    let f = top + sum.ln() / t;
    let nr = b.nrows();
    let jj = c64::new(0.0, 1.0);
    for &(i, w) in &weights {
        let wk = w / sum;
        let v: Vec<c64> = (0..n).map(|p| vecs[(p, i)]).collect();
        let bv: Vec<c64> = (0..nr)
            .map(|p| (0..n).fold(ZERO, |acc, q| acc + b[(p, q)] * v[q]))
            .collect();
        // u = Bv − j Ĝᴴv (Ĝᴴ is nr×nc: block Ĝ_jᴴ at (row range, column range)).
        let mut u = bv.clone();
        for (j, blk) in s.blocks().iter().enumerate() {
            if !blk.is_real() {
                continue;
            }
            let (rr, cr) = (s.row_range(j), s.col_range(j));
            for (q, rq) in rr.clone().enumerate() {
                let mut acc = ZERO;
                for (p, cp) in cr.clone().enumerate() {
                    acc += g[j][(p, q)].conj() * v[cp];
                }
                u[rq] -= jj * acc;
            }
        }
        let y: Vec<c64> = (0..n)
            .map(|q| (0..nr).fold(ZERO, |acc, p| acc + b[(p, q)].conj() * u[p]))
            .collect();
        let mut off = 0;
        for (j, blk) in s.blocks().iter().enumerate() {
            let (rr, cr) = (s.row_range(j), s.col_range(j));
            // d(vᴴHv) along E_L B − B E_R = 2 Re(uᴴ E_L (Bv) − yᴴ E_R v).
            match blk {
                BlockKind::Full { .. } => {
                    let a: f64 = rr.clone().map(|p| (u[p].conj() * bv[p]).re).sum();
                    let c: f64 = cr.clone().map(|q| (y[q].conj() * v[q]).re).sum();
                    grad[off] += wk * 2.0 * (a - c);
                    off += 1;
                }
                _ => {
                    let r = blk.rows();
                    let (uu, ww, yy, vv) = (&u[rr.clone()], &bv[rr.clone()], &y[cr.clone()], &v[cr.clone()]);
                    // Entry (p, q) of E with value z contributes 2 Re(z (ū_p w_q − ȳ_p v_q)).
                    let kappa = |p: usize, q: usize| uu[p].conj() * ww[q] - yy[p].conj() * vv[q];
                    for p in 0..r {
                        grad[off] += wk * 2.0 * kappa(p, p).re;
                        off += 1;
                    }
                    for p in 0..r {
                        for q in p + 1..r {
                            grad[off] += wk * 2.0 * (kappa(p, q) + kappa(q, p)).re;
                            grad[off + 1] += wk * 2.0 * (jj * kappa(p, q) - jj * kappa(q, p)).re;
                            off += 2;
                        }
                    }
                    if blk.is_real() {
                        // vᴴ j(EB − BᴴEᴴ) v = −2 Im(vᴴ E Bv) with E at (column range, row range).
                        let (vc, wr) = (&v[cr.clone()], &bv[rr.clone()]);
                        let a = |p: usize, q: usize| vc[p].conj() * wr[q];
                        for p in 0..r {
                            grad[off] += wk * (-2.0) * a(p, p).im;
                            off += 1;
                        }
                        for p in 0..r {
                            for q in p + 1..r {
                                grad[off] += wk * (-2.0) * (a(p, q) + a(q, p)).im;
                                grad[off + 1] += wk * (-2.0) * (jj * a(p, q) - jj * a(q, p)).im;
                                off += 2;
                            }
                        }
                    }
                }
            }
        }
    }
    Ok(Eval { f, lam_max: top, grad })
}

/// Applies a step: D_j ← exp(E_j) D_j, Ĝ_j ← Ĝ_j + ΔĜ_j.
fn step_point(s: &BlockStructure, x: &Point, theta: &[f64]) -> Result<Point> {
    let mut per_block = Vec::with_capacity(s.len());
    let mut g = x.g.clone();
    let mut off = 0;
    for (j, blk) in s.blocks().iter().enumerate() {
        let nd = n_d(blk);
        let e = match blk {
            BlockKind::Full { .. } => Mat::from_fn(1, 1, |_, _| c64::new(theta[off].exp(), 0.0)),
            _ => expm_hermitian(&hermitian(blk.rows(), &theta[off..off + nd]))?,
        };
        per_block.push(&e * &x.d.per_block[j]);
        off += nd;
        let ng = n_g(blk);
        if ng > 0 {
            g[j] = &g[j] + hermitian(blk.rows(), &theta[off..off + ng]);
            off += ng;
        }
    }
    Ok(Point {
        d: DScales::from_blocks(s, per_block),
        g,
    })
}

/// Largest |component| of a step among the log-D generators (the Ĝ ones are additive and uncapped).
fn d_step_max(s: &BlockStructure, theta: &[f64]) -> f64 {
    let mut off = 0;
    let mut out = 0.0_f64;
    for blk in s.blocks() {
        let nd = n_d(blk);
        out = theta[off..off + nd].iter().fold(out, |a, v| a.max(v.abs()));
        off += nd + n_g(blk);
    }
    out
}

fn scaled(m: MatRef<c64>, x: &Point, norm: f64) -> Mat<c64> {
    let b = x.d.apply(m);
    Mat::from_fn(b.nrows(), b.ncols(), |i, k| b[(i, k)] / norm)
}

/// The D–G upper bound of μ(M) for a structure with real scalar blocks, started from the complex
/// bound's D-scales `d0` with value `complex` = σ̄(D_L M D_R⁻¹). `target` is a known lower bound
/// (stop once within `rel_tol` of it). Returns `None` when no certified bound below `complex` is found.
pub fn mixed_upper_bound(
    m: MatRef<c64>,
    s: &BlockStructure,
    d0: &DScales,
    complex: f64,
    target: f64,
    rel_tol: f64,
) -> Result<Option<MixedUpper>> {
    s.check_matrix(m.nrows(), m.ncols())?;
    let fits = d0.left.nrows() == m.nrows()
        && d0.left.ncols() == m.nrows()
        && d0.right_inv.nrows() == m.ncols()
        && d0.right_inv.ncols() == m.ncols()
        && d0.per_block.len() == s.len()
        && s.blocks().iter().zip(&d0.per_block).all(|(b, dj)| {
            let r = if let BlockKind::Full { .. } = b { 1 } else { b.rows() };
            dj.nrows() == r && dj.ncols() == r
        });
    if !fits {
        return Err(RobustError::InvalidArgument(
            "the D-scales do not fit the block structure and M".into(),
        ));
    }
    if (0..m.ncols()).any(|j| (0..m.nrows()).any(|i| !(m[(i, j)].re.is_finite() && m[(i, j)].im.is_finite()))) {
        return Err(RobustError::InvalidArgument("M has a non-finite entry".into()));
    }
    if !(s.has_real() && complex.is_finite() && complex > 0.0) {
        return Ok(None);
    }
    let norm = complex;
    let g0: Vec<Mat<c64>> = s
        .blocks()
        .iter()
        .map(|b| {
            if b.is_real() {
                Mat::zeros(b.rows(), b.rows())
            } else {
                Mat::zeros(0, 0)
            }
        })
        .collect();
    let mut x = Point { d: d0.clone(), g: g0 };
    let np: usize = s.blocks().iter().map(|b| n_d(b) + n_g(b)).sum();
    // In normalized units the complex bound is λ_max = 1; the target is (target/complex)².
    let tgt = (target / norm).powi(2);
    let mut t = 8.0;
    let t_max = 1.0e6;
    let mut ws = Workspace::default();
    let mut b = scaled(m, &x, norm);
    let mut cur = evaluate(b.as_ref(), s, &x.g, t, &mut ws)?;
    let mut best = (cur.lam_max, x.clone());
    let mut h = identity(np);
    let done = |lam: f64| lam <= 0.0 || (target > 0.0 && lam <= tgt * (1.0 + 2.0 * rel_tol));
    'stages: loop {
        for _ in 0..60 {
            let Some((p, slope, mut alpha)) = descent(&mut h, &cur.grad, 1e-14) else {
                break;
            };
            let alpha0 = alpha;
            let mut accepted = None;
            for _ in 0..30 {
                let step: Vec<f64> = p.iter().map(|v| alpha * v).collect();
                let xn = step_point(s, &x, &step)?;
                let bn = scaled(m, &xn, norm);
                let en = evaluate(bn.as_ref(), s, &xn.g, t, &mut ws)?;
                if en.lam_max < best.0 {
                    best = (en.lam_max, xn.clone());
                }
                if en.f <= cur.f + 1e-4 * alpha * slope {
                    accepted = Some((step, xn, bn, en));
                    break;
                }
                alpha *= 0.3;
            }
            let Some((mut step, mut xn, mut bn, mut en)) = accepted else {
                break;
            };
            // Along Ĝ the function can be (nearly) linear and unbounded below (μ = 0 when no real δ
            // fits): BFGS learns no curvature there, so a step taken in full is stretched while it
            // keeps paying off, within the per-step cap on the D generators (e³).
            if alpha == alpha0 && cur.f - en.f >= -0.9 * alpha * slope {
                for _ in 0..40 {
                    let longer: Vec<f64> = step.iter().map(|v| 4.0 * v).collect();
                    if d_step_max(s, &longer) > 3.0 || longer.iter().any(|v| v.abs() > 1e8) {
                        break;
                    }
                    let xl = step_point(s, &x, &longer)?;
                    let bl = scaled(m, &xl, norm);
                    let el = evaluate(bl.as_ref(), s, &xl.g, t, &mut ws)?;
                    if el.lam_max < best.0 {
                        best = (el.lam_max, xl.clone());
                    }
                    if !el.f.is_finite() || el.f >= en.f {
                        break;
                    }
                    (step, xn, bn, en) = (longer, xl, bl, el);
                }
            }
            let yv: Vec<f64> = en.grad.iter().zip(&cur.grad).map(|(a, c)| a - c).collect();
            let sy: f64 = step.iter().zip(&yv).map(|(a, c)| a * c).sum();
            let df = cur.f - en.f;
            x = xn;
            b = bn;
            cur = en;
            if sy > 1e-300 {
                bfgs_update(&mut h, &step, &yv, sy);
            }
            if done(best.0) {
                break 'stages;
            }
            let tol = if t >= t_max { 1e-2 * rel_tol } else { 1e-3 / t };
            if df <= tol.max(1e-14) * (1.0 + cur.f.abs()) {
                break;
            }
        }
        if t >= t_max || done(best.0) {
            break;
        }
        t *= 4.0;
        scale(&mut h, 0.25);
        cur = evaluate(b.as_ref(), s, &x.g, t, &mut ws)?;
    }
    certify(m, s, &best.1, norm)
}

/// Maps Ĝ back to M's coordinates (G_j = D_jᴴ (norm·Ĝ_j) D_j), takes β² = λ_max of the scaled problem
/// from a dense eigen-decomposition (plus a relative margin), and checks
/// λ_max(Mᴴ P_L M + j(G M − Mᴴ G) − β² P_R) ≤ 1e-12 · (the terms' size) directly.
fn certify(m: MatRef<c64>, s: &BlockStructure, x: &Point, norm: f64) -> Result<Option<MixedUpper>> {
    let b = x.d.apply(m);
    let g_hat: Vec<Mat<c64>> =
        x.g.iter()
            .map(|g| Mat::from_fn(g.nrows(), g.ncols(), |i, k| g[(i, k)] * norm))
            .collect();
    let h = h_matrix(b.as_ref(), s, &g_hat);
    let (lam, _) = eigen(&h)?;
    let top = lam.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let hn = h.norm_l2();
    let beta2 = (top + 1e-13 * hn).max(0.0);
    let g: Vec<Mat<c64>> = s
        .blocks()
        .iter()
        .enumerate()
        .map(|(j, blk)| {
            if blk.is_real() {
                let dj = &x.d.per_block[j];
                dj.adjoint() * &g_hat[j] * dj
            } else {
                Mat::zeros(0, 0)
            }
        })
        .collect();
    // D_R = (D_R⁻¹)⁻¹ blockwise: P_R = D_Rᴴ D_R; P_L = D_Lᴴ D_L.
    let nc = m.ncols();
    let d_r = x.d.right_inv.partial_piv_lu().inverse();
    let p_r = d_r.adjoint() * &d_r;
    let p_l = x.d.left.adjoint() * &x.d.left;
    let mpm = m.adjoint() * &p_l * m;
    let gm = g_times(s, &g, m);
    let jj = c64::new(0.0, 1.0);
    let a = Mat::from_fn(nc, nc, |p, q| {
        mpm[(p, q)] + jj * (gm[(p, q)] - gm[(q, p)].conj()) - p_r[(p, q)] * beta2
    });
    let (lam_a, _) = eigen(&a)?;
    let top_a = lam_a.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let scale = mpm.norm_l2() + 2.0 * gm.norm_l2() + beta2 * p_r.norm_l2();
    if top_a.is_nan() || top_a > 1e-12 * scale || !beta2.is_finite() {
        return Ok(None);
    }
    Ok(Some(MixedUpper {
        value: beta2.sqrt(),
        d: x.d.clone(),
        g,
    }))
}
