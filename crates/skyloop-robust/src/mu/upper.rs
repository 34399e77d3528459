//! μ upper bound by D-scaling: μ(M) ≤ inf_D σ̄(D_L M D_R⁻¹) over D commuting with Δ.
//!
//! Osborne balancing of the block norms gives the start; then log σ̄ is minimized over the
//! D-scales (log σ̄(e^X M e^−X) is convex in commuting X, Sezginer & Overton 1990). Because σ̄ is
//! not smooth where the top singular value is multiple (typical at the optimum), the smooth
//! Schatten-type surrogate f_t = log σ₁ + ln(Σ (σᵢ/σ₁)^{2t}) / (2t) is minimized by BFGS for
//! t = 4, 16, …, 65536 (f_t − log σ̄ ≤ ln(multiplicity)/(2t)). Steps are multiplicative,
//! D ← exp(E)·D with E Hermitian and block diagonal (a scalar per full block, a Hermitian r×r
//! matrix per repeated scalar block), so every iterate is a valid scaling and every σ̄ seen is a
//! valid upper bound; the smallest one is returned. Real scalar blocks are treated as complex here
//! (a valid but conservative bound); for structures with real blocks `mu` then tightens it with
//! D–G scalings started from this optimum (`mixed::mixed_upper_bound`).

use super::bfgs::{bfgs_update, descent, identity, scale};
use crate::error::Result;
use crate::error::RobustError;
use crate::uncertainty::blocks::{BlockKind, BlockStructure};
use faer::linalg::solvers::Solve;
use faer::{c64, Mat, MatRef, Side};
use skyloop_linalg::hermitian::{top_eigen, Workspace};

/// D-scales for one block structure: D_L acts on M's rows, D_R on M's columns.
#[derive(Debug, Clone, PartialEq)]
pub struct DScales {
    /// Left scaling matrix (block diagonal, size M rows).
    pub left: Mat<c64>,
    /// Inverse of the right scaling matrix (block diagonal, size M columns).
    pub right_inv: Mat<c64>,
    /// Per block: the scale d_j of a full block, or for a δI_r block the r×r matrix D_j (row-major
    /// as a Mat); σ̄(D_L M D_R⁻¹) is invariant to a common factor, so only ratios matter.
    pub per_block: Vec<Mat<c64>>,
}

impl DScales {
    /// Identity scales for a structure.
    pub fn identity(s: &BlockStructure) -> Self {
        let per_block = s
            .blocks()
            .iter()
            .map(|b| match b {
                BlockKind::Full { .. } => Mat::<c64>::identity(1, 1),
                _ => Mat::<c64>::identity(b.rows(), b.rows()),
            })
            .collect();
        Self::from_blocks(s, per_block)
    }

    /// Assembles D_L and D_R⁻¹ from per-block scales (inverting each block).
    pub fn from_blocks(s: &BlockStructure, per_block: Vec<Mat<c64>>) -> Self {
        let mut left = Mat::<c64>::zeros(s.m_rows(), s.m_rows());
        let mut right_inv = Mat::<c64>::zeros(s.m_cols(), s.m_cols());
        for (j, b) in s.blocks().iter().enumerate() {
            let (rr, cr) = (s.row_range(j), s.col_range(j));
            let dj = &per_block[j];
            if let BlockKind::Full { .. } = b {
                let d = dj[(0, 0)];
                let di = c64::new(1.0, 0.0) / d;
                for i in rr {
                    left[(i, i)] = d;
                }
                for i in cr {
                    right_inv[(i, i)] = di;
                }
            } else {
                let inv = small_inverse(dj.as_ref());
                let r = b.rows();
                for p in 0..r {
                    for q in 0..r {
                        left[(rr.start + p, rr.start + q)] = dj[(p, q)];
                        right_inv[(cr.start + p, cr.start + q)] = inv[(p, q)];
                    }
                }
            }
        }
        DScales {
            left,
            right_inv,
            per_block,
        }
    }

    /// D_L · M · D_R⁻¹.
    pub fn apply(&self, m: MatRef<c64>) -> Mat<c64> {
        &self.left * m * &self.right_inv
    }

    /// D_L · M · D_R⁻¹ using the block-diagonal pattern of `s` (O(n²·r) instead of two dense products).
    fn apply_blocks(&self, s: &BlockStructure, m: MatRef<c64>) -> Mat<c64> {
        let (nr, nc) = (m.nrows(), m.ncols());
        let mut left = Mat::<c64>::zeros(nr, nc);
        for j in 0..s.len() {
            let rr = s.row_range(j);
            for i in rr.clone() {
                for k in rr.clone() {
                    let l = self.left[(i, k)];
                    if l != c64::new(0.0, 0.0) {
                        for q in 0..nc {
                            left[(i, q)] += l * m[(k, q)];
                        }
                    }
                }
            }
        }
        let mut out = Mat::<c64>::zeros(nr, nc);
        for j in 0..s.len() {
            let cr = s.col_range(j);
            for k in cr.clone() {
                for q in cr.clone() {
                    let r = self.right_inv[(k, q)];
                    if r != c64::new(0.0, 0.0) {
                        for i in 0..nr {
                            out[(i, q)] += left[(i, k)] * r;
                        }
                    }
                }
            }
        }
        out
    }
}

/// Inverse of a small nonsingular matrix (an exp(E) product, so well conditioned by construction).
fn small_inverse(a: MatRef<c64>) -> Mat<c64> {
    let n = a.nrows();
    a.partial_piv_lu().solve(Mat::<c64>::identity(n, n))
}

/// Result of the upper-bound optimization.
#[derive(Debug, Clone)]
pub struct UpperBound {
    /// The bound σ̄(D_L M D_R⁻¹) (dimensionless).
    pub value: f64,
    /// The scales achieving it.
    pub d: DScales,
    /// Top left singular vector of the scaled matrix (start for the lower bound).
    pub u: Vec<c64>,
    /// Top right singular vector of the scaled matrix.
    pub v: Vec<c64>,
    /// BFGS inverse Hessian (row-major, one row per D-scale generator parameter) and the smoothing
    /// exponent t where the optimization ended: a warm start for a neighbouring frequency.
    pub curvature: (Vec<f64>, f64),
}

/// Osborne's iteration on the block norms: scalar d_j making each block row and column of
/// D M D⁻¹ equally heavy in Frobenius norm (minimizes ‖D M D⁻¹‖_F over scalar D).
pub fn osborne(m: MatRef<c64>, s: &BlockStructure) -> Result<DScales> {
    s.check_matrix(m.nrows(), m.ncols())?;
    let nb = s.len();
    // Squared Frobenius norms of the blocks M_jk (rows of block j, columns of block k).
    let mut nrm = vec![vec![0.0; nb]; nb];
    for (j, row) in nrm.iter_mut().enumerate() {
        for (k, v) in row.iter_mut().enumerate() {
            let mut acc = 0.0;
            for p in s.row_range(j) {
                for q in s.col_range(k) {
                    acc += m[(p, q)].norm_sqr();
                }
            }
            *v = acc;
        }
    }
    let mut d = vec![1.0_f64; nb];
    for _sweep in 0..50 {
        let mut change = 0.0_f64;
        for j in 0..nb {
            // Scaled block (j,k) is d_j/d_k M_jk; balance row j (outgoing) against column j.
            let (mut row, mut col) = (0.0, 0.0);
            for k in 0..nb {
                if k != j {
                    row += nrm[j][k] / (d[k] * d[k]);
                    col += nrm[k][j] * d[k] * d[k];
                }
            }
            if row > 0.0 && col > 0.0 {
                let new = (col / row).sqrt().sqrt();
                // Keep scales within a sane range so a decoupled block cannot drive them to 0 or ∞.
                let new = new.clamp(1e-8, 1e8);
                change = change.max((new / d[j]).ln().abs());
                d[j] = new;
            }
        }
        if change < 1e-3 {
            break;
        }
    }
    let per_block = s
        .blocks()
        .iter()
        .zip(&d)
        .map(|(b, &dj)| {
            let r = if b.is_scalar() { b.rows() } else { 1 };
            let mut x = Mat::<c64>::zeros(r, r);
            for i in 0..r {
                x[(i, i)] = c64::new(dj, 0.0);
            }
            x
        })
        .collect();
    Ok(DScales::from_blocks(s, per_block))
}

/// Number of real parameters of the Hermitian generator E of block `b`.
fn n_params(b: &BlockKind) -> usize {
    match b {
        BlockKind::Full { .. } => 1,
        _ => b.rows() * b.rows(),
    }
}

/// Smooth surrogate value, gradient w.r.t. the generator parameters, σ̄ and top singular vectors.
struct Eval {
    f: f64,
    grad: Vec<f64>,
    sigma_max: f64,
    u: Vec<c64>,
    v: Vec<c64>,
}

/// Eigenvalues of the smaller Gram matrix of the scaled matrix (ascending) and the eigenvectors of
/// the largest ones: column c of `vecs` belongs to `lam[n − 1 − c]`.
struct Spectrum {
    /// Whether the Gram matrix is BᴴB (right singular vectors) rather than BBᴴ.
    use_right: bool,
    lam: Vec<f64>,
    vecs: Mat<c64>,
}

/// Weights (λᵢ/λ₁)^t below this are dropped from the surrogate (and need no eigenvector).
const WEIGHT_FLOOR: f64 = 1e-15;

/// Spectrum of `b` with eigenvectors for every eigenvalue whose surrogate weight at `t` (or any
/// larger t) reaches WEIGHT_FLOOR.
fn spectrum(b: MatRef<c64>, t: f64, ws: &mut Workspace) -> Result<Spectrum> {
    let (nr, nc) = (b.nrows(), b.ncols());
    // Work with the smaller Gram matrix; singular vectors on the other side follow from B.
    let use_right = nc <= nr;
    let gram = if use_right { b.adjoint() * b } else { b * b.adjoint() };
    let needed = |lam: &[f64]| {
        let top = lam.last().copied().unwrap_or(0.0).max(0.0);
        if top == 0.0 {
            return 1;
        }
        let k = lam
            .iter()
            .rev()
            .take_while(|&&l| (l.max(0.0) / top).powf(t) >= WEIGHT_FLOOR)
            .count();
        k.max(1)
    };
    if let Some(te) = top_eigen(gram.as_ref(), ws, needed) {
        return Ok(Spectrum {
            use_right,
            lam: te.lam.iter().map(|l| l.max(0.0)).collect(),
            vecs: te.vecs,
        });
    }
    // The tridiagonal QR did not converge: the dense solver decides.
    let evd = gram
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| RobustError::Numerical(format!("eigen-decomposition in the mu upper bound failed: {e:?}")))?;
    let n = gram.nrows();
    let lam: Vec<f64> = (0..n).map(|i| evd.S().column_vector()[i].re.max(0.0)).collect();
    let vecs = Mat::from_fn(n, n, |p, c| evd.U()[(p, n - 1 - c)]);
    Ok(Spectrum { use_right, lam, vecs })
}

/// Evaluates f_t at the scaled matrix `b` (rows × cols), with gradients in the block generators.
fn evaluate(b: MatRef<c64>, s: &BlockStructure, t: f64, ws: &mut Workspace) -> Result<(Eval, Spectrum)> {
    let sp = spectrum(b, t, ws)?;
    Ok((surrogate(b, s, t, &sp)?, sp))
}

/// f_t and its gradient from the spectrum of `b` (reused when only t changes).
fn surrogate(b: MatRef<c64>, s: &BlockStructure, t: f64, sp: &Spectrum) -> Result<Eval> {
    let (nr, nc) = (b.nrows(), b.ncols());
    let use_right = sp.use_right;
    let lam = &sp.lam;
    let n = lam.len();
    let top = lam[n - 1];
    let sigma_max = top.sqrt();
    let np: usize = s.blocks().iter().map(n_params).sum();
    if !sigma_max.is_finite() {
        return Err(RobustError::Numerical(
            "non-finite singular value in the mu upper bound".into(),
        ));
    }
    if sigma_max == 0.0 {
        return Ok(Eval {
            f: f64::NEG_INFINITY,
            grad: vec![0.0; np],
            sigma_max,
            u: vec![c64::new(0.0, 0.0); nr],
            v: vec![c64::new(0.0, 0.0); nc],
        });
    }
    // Weights (σᵢ/σ₁)^{2t} = (λᵢ/λ₁)^t.
    let mut weights = Vec::new();
    let mut sum = 0.0;
    for i in (0..n).rev() {
        let w = (lam[i] / top).powf(t);
        // Vectors exist for every weight ≥ WEIGHT_FLOOR at the spectrum's t ≤ this t.
        if w < WEIGHT_FLOOR || n - 1 - i >= sp.vecs.ncols() {
            break;
        }
        weights.push((i, w));
        sum += w;
    }
    let f = sigma_max.ln() + sum.ln() / (2.0 * t);
    let mut grad = vec![0.0; np];
    let (mut u_top, mut v_top) = (Vec::new(), Vec::new());
    for (k, &(i, w)) in weights.iter().enumerate() {
        let sig = lam[i].sqrt().max(f64::MIN_POSITIVE);
        let x: Vec<c64> = (0..n).map(|p| sp.vecs[(p, n - 1 - i)]).collect();
        // The other side: B v / σ (or Bᴴ u / σ).
        let (u, v) = if use_right {
            let u: Vec<c64> = (0..nr)
                .map(|p| (0..nc).fold(c64::new(0.0, 0.0), |acc, q| acc + b[(p, q)] * x[q]) / sig)
                .collect();
            (u, x)
        } else {
            let v: Vec<c64> = (0..nc)
                .map(|q| (0..nr).fold(c64::new(0.0, 0.0), |acc, p| acc + b[(p, q)].conj() * x[p]) / sig)
                .collect();
            (x, v)
        };
        let wk = w / sum;
        let mut off = 0;
        for (j, blk) in s.blocks().iter().enumerate() {
            let (rr, cr) = (s.row_range(j), s.col_range(j));
            match blk {
                BlockKind::Full { .. } => {
                    let gu: f64 = rr.map(|p| u[p].norm_sqr()).sum();
                    let gv: f64 = cr.map(|q| v[q].norm_sqr()).sum();
                    grad[off] += wk * (gu - gv);
                    off += 1;
                }
                _ => {
                    let r = blk.rows();
                    let (uu, vv) = (&u[rr], &v[cr]);
                    for p in 0..r {
                        grad[off] += wk * (uu[p].norm_sqr() - vv[p].norm_sqr());
                        off += 1;
                    }
                    for p in 0..r {
                        for q in p + 1..r {
                            let cu = uu[p].conj() * uu[q];
                            let cv = vv[p].conj() * vv[q];
                            grad[off] += wk * 2.0 * (cu.re - cv.re);
                            grad[off + 1] += wk * (-2.0) * (cu.im - cv.im);
                            off += 2;
                        }
                    }
                }
            }
        }
        if k == 0 {
            u_top = u;
            v_top = v;
        }
    }
    Ok(Eval {
        f,
        grad,
        sigma_max,
        u: u_top,
        v: v_top,
    })
}

/// exp(E_j) of the Hermitian generator of each block, from the parameter vector.
fn block_exponentials(s: &BlockStructure, theta: &[f64]) -> Result<Vec<Mat<c64>>> {
    let mut out = Vec::with_capacity(s.len());
    let mut off = 0;
    for blk in s.blocks() {
        match blk {
            BlockKind::Full { .. } => {
                out.push(Mat::from_fn(1, 1, |_, _| c64::new(theta[off].exp(), 0.0)));
                off += 1;
            }
            _ => {
                let r = blk.rows();
                let mut e = Mat::<c64>::zeros(r, r);
                for p in 0..r {
                    e[(p, p)] = c64::new(theta[off], 0.0);
                    off += 1;
                }
                for p in 0..r {
                    for q in p + 1..r {
                        let z = c64::new(theta[off], theta[off + 1]);
                        e[(p, q)] = z;
                        e[(q, p)] = z.conj();
                        off += 2;
                    }
                }
                if r == 1 {
                    out.push(Mat::from_fn(1, 1, |_, _| c64::new(e[(0, 0)].re.exp(), 0.0)));
                } else {
                    // exp(E) = Σ e^{λ_k} x_k x_kᴴ; the small solver avoids the dense one's set-up cost.
                    let mut ws = Workspace::default();
                    let (lam, uq) = match top_eigen(e.as_ref(), &mut ws, |l| l.len()) {
                        Some(te) => (te.lam.iter().rev().copied().collect::<Vec<f64>>(), te.vecs),
                        None => {
                            let evd = e.self_adjoint_eigen(Side::Lower).map_err(|err| {
                                RobustError::Numerical(format!(
                                    "eigen-decomposition of a D-scale generator failed: {err:?}"
                                ))
                            })?;
                            let lam = (0..r).map(|k| evd.S().column_vector()[k].re).collect();
                            (lam, evd.U().to_owned())
                        }
                    };
                    let ex = Mat::<c64>::from_fn(r, r, |p, q| {
                        (0..r).fold(c64::new(0.0, 0.0), |acc, k| {
                            acc + uq[(p, k)] * lam[k].exp() * uq[(q, k)].conj()
                        })
                    });
                    out.push(ex);
                }
            }
        }
    }
    Ok(out)
}

/// Multiplies the current per-block scales by exp(E) on the left.
fn update_scales(s: &BlockStructure, d: &DScales, theta: &[f64]) -> Result<DScales> {
    let ex = block_exponentials(s, theta)?;
    let per_block = ex.iter().zip(&d.per_block).map(|(e, dj)| e * dj).collect();
    Ok(DScales::from_blocks(s, per_block))
}

/// Options for the upper bound.
#[derive(Debug, Clone, Copy)]
pub struct UpperOptions {
    /// Stop once the bound is within this relative distance of `target` (a known lower bound).
    pub rel_tol: f64,
    /// Largest smoothing exponent t of the surrogate.
    pub t_max: f64,
    /// BFGS iterations per smoothing stage.
    pub iters_per_stage: usize,
    /// First smoothing exponent t (4 from a cold start; larger when the start is already near the
    /// optimum, e.g. the D-scales of a previous pass or of a neighbouring frequency).
    pub t_start: f64,
}

impl Default for UpperOptions {
    fn default() -> Self {
        UpperOptions {
            rel_tol: 1e-6,
            t_max: 65536.0,
            iters_per_stage: 40,
            t_start: 4.0,
        }
    }
}

/// Minimizes σ̄(D_L M D_R⁻¹) from `start` (Osborne when `None`). `target` is a known lower bound
/// (0 if none) used only to stop early once the gap is below `opts.rel_tol`.
pub fn upper_bound(
    m: MatRef<c64>,
    s: &BlockStructure,
    start: Option<&DScales>,
    target: f64,
    opts: &UpperOptions,
) -> Result<UpperBound> {
    upper_bound_from(m, s, start, None, target, opts)
}

/// As [`upper_bound`], with the quasi-Newton curvature (`UpperBound::curvature`) of a neighbouring
/// problem as the initial inverse Hessian (ignored when its size does not match the structure).
pub fn upper_bound_from(
    m: MatRef<c64>,
    s: &BlockStructure,
    start: Option<&DScales>,
    curvature: Option<&(Vec<f64>, f64)>,
    target: f64,
    opts: &UpperOptions,
) -> Result<UpperBound> {
    s.check_matrix(m.nrows(), m.ncols())?;
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            if !(m[(i, j)].re.is_finite() && m[(i, j)].im.is_finite()) {
                return Err(RobustError::InvalidArgument(format!("M[{i},{j}] is not finite")));
            }
        }
    }
    let mut d = match start {
        Some(d0) => d0.clone(),
        None => osborne(m, s)?,
    };
    let np: usize = s.blocks().iter().map(n_params).sum();
    let mut b = d.apply_blocks(s, m);
    let mut ws = Workspace::default();
    let mut t = opts.t_start.clamp(1.0, opts.t_max.max(1.0));
    let (mut cur, mut cur_sp) = evaluate(b.as_ref(), s, t, &mut ws)?;
    let mut best = UpperBound {
        value: cur.sigma_max,
        d: d.clone(),
        u: cur.u.clone(),
        v: cur.v.clone(),
        curvature: (Vec::new(), t),
    };
    if cur.sigma_max == 0.0 || (target > 0.0 && best.value <= target * (1.0 + opts.rel_tol)) {
        return Ok(best);
    }
    // Inverse Hessian approximation in the (local) generator coordinates. A neighbour's estimate is
    // reused only if it was made at a stage no sharper than this one (rescaled by tw/t: the kink's
    // curvature grows like t). One from a sharper stage, scaled up, makes the steps along the smooth
    // directions far too long; on the bench sweeps that left the bound ~1e-5 short of its optimum.
    let mut h = match curvature {
        Some((hw, tw)) if hw.len() == np * np && hw.iter().all(|x| x.is_finite()) && *tw > 0.0 && *tw <= t => {
            let f = tw / t;
            (0..np).map(|i| (0..np).map(|k| hw[i * np + k] * f).collect()).collect()
        }
        _ => identity(np),
    };
    let finish = |mut best: UpperBound, h: &[Vec<f64>], t: f64| {
        best.curvature = (h.iter().flatten().copied().collect(), t);
        best
    };
    loop {
        for _ in 0..opts.iters_per_stage {
            let Some((p, slope, mut alpha)) = descent(&mut h, &cur.grad, 1e-12) else {
                break;
            };
            let mut accepted = None;
            for _ in 0..30 {
                let step: Vec<f64> = p.iter().map(|x| alpha * x).collect();
                let dn = update_scales(s, &d, &step)?;
                let bn = dn.apply_blocks(s, m);
                let (en, en_sp) = evaluate(bn.as_ref(), s, t, &mut ws)?;
                if en.sigma_max < best.value {
                    best = UpperBound {
                        value: en.sigma_max,
                        d: dn.clone(),
                        u: en.u.clone(),
                        v: en.v.clone(),
                        curvature: (Vec::new(), t),
                    };
                }
                if en.f <= cur.f + 1e-4 * alpha * slope {
                    accepted = Some((step, dn, bn, en, en_sp));
                    break;
                }
                // Backtrack to the minimizer of the quadratic through f(0), f'(0) and f(α)
                // (Nocedal & Wright §3.5), kept within [α/10, α/2]: a far too long first step
                // (e.g. a neighbour's curvature that does not fit here) costs a few evaluations, not ten.
                let excess = en.f - cur.f - slope * alpha;
                let quad = if excess > 0.0 && excess.is_finite() {
                    -slope * alpha * alpha / (2.0 * excess)
                } else {
                    0.5 * alpha
                };
                alpha = quad.clamp(0.1 * alpha, 0.5 * alpha);
            }
            let Some((step, dn, bn, en, en_sp)) = accepted else {
                break;
            };
            let y: Vec<f64> = en.grad.iter().zip(&cur.grad).map(|(a, b)| a - b).collect();
            let sy: f64 = step.iter().zip(&y).map(|(a, b)| a * b).sum();
            let df = cur.f - en.f;
            d = dn;
            b = bn;
            cur = en;
            cur_sp = en_sp;
            if sy > 1e-300 {
                bfgs_update(&mut h, &step, &y, sy);
            }
            // The bound cannot get meaningfully below a proven lower bound: stop as soon as it meets it.
            if target > 0.0 && best.value <= target * (1.0 + opts.rel_tol) {
                return Ok(finish(best, &h, t));
            }
            // Intermediate stages only steer towards the next one: resolving them finer than their
            // smoothing bias (≤ ln(multiplicity)/(2t)) buys nothing; the last stage goes to rel_tol.
            let stage_tol = if t >= opts.t_max {
                (1e-2 * opts.rel_tol).max(1e-13)
            } else {
                (1e-3 / t).max(1e-13)
            };
            if df <= stage_tol * (1.0 + cur.f.abs()) {
                break;
            }
        }
        if target > 0.0 && best.value <= target * (1.0 + opts.rel_tol) {
            break;
        }
        if t >= opts.t_max {
            break;
        }
        t *= 4.0;
        scale(&mut h, 0.25);
        // Same matrix, sharper surrogate: only the weights change, not the spectrum.
        cur = surrogate(b.as_ref(), s, t, &cur_sp)?;
    }
    Ok(finish(best, &h, t))
}
