//! μ lower bound by the power iteration of Packard & Doyle (Automatica 29(1), 1993, §9).
//!
//! For complex structures μ(M) = max over block-diagonal unitary Q of ρ(QM). A local maximum
//! satisfies M b = β a, Mᴴ z = β w with b = Q a, z = Qᴴ w; for a full block the alignment
//! conditions are z_j = (‖w_j‖/‖a_j‖) a_j and b_j = (‖a_j‖/‖w_j‖) w_j, for a δI block
//! z_j = φ(w_jᴴa_j) w_j and b_j = φ(a_jᴴw_j) a_j with φ(x) = x/|x| (derived from the stationarity
//! of ρ(QM) under Q_j → Q_j e^{iH_j}). The iteration alternates these with multiplications by M
//! and Mᴴ. Whatever it converges to, the reported bound is ρ(QM) of an explicit Q in the unit
//! ball of the structure, so it is always a valid lower bound, and Δ = Q e^{−i∠λ}/|λ| makes
//! I − MΔ singular.
//!
//! Real scalar blocks: the iteration treats them as complex, then rounds each to ±1 and searches
//! the common phase of the complex blocks for a real eigenvalue of QM (only real eigenvalues give
//! a real destabilizing δ). This gives a valid but often weak bound (mixed μ lower bounds are
//! discontinuous; Young & Doyle's mixed power iteration is not implemented).

use crate::error::Result;
use crate::error::RobustError;
use crate::uncertainty::blocks::{BlockKind, BlockStructure};
use faer::{c64, Mat, MatRef};

/// The (b, w) vector pair a power-iteration start is made of.
type StartVectors = (Vec<c64>, Vec<c64>);

/// A lower bound with the perturbation that proves it.
#[derive(Debug, Clone)]
pub struct LowerBound {
    /// The bound ρ(QM) (dimensionless); 0 when nothing was found.
    pub value: f64,
    /// A structured Δ with σ̄(Δ) = 1/value and I − MΔ singular (zeros when value is 0).
    pub delta: Mat<c64>,
}

fn zero() -> c64 {
    c64::new(0.0, 0.0)
}

fn phase(x: c64) -> c64 {
    let n = x.norm();
    if n > 0.0 {
        x / n
    } else {
        c64::new(1.0, 0.0)
    }
}

fn norm(v: &[c64]) -> f64 {
    v.iter().map(|x| x.norm_sqr()).sum::<f64>().sqrt()
}

fn normalize(v: &mut [c64]) -> f64 {
    let n = norm(v);
    if n > 0.0 {
        for x in v.iter_mut() {
            *x /= n;
        }
    }
    n
}

fn dot(a: &[c64], b: &[c64]) -> c64 {
    a.iter().zip(b).fold(zero(), |acc, (x, y)| acc + x.conj() * y)
}

/// M copied column-major into one slice: the power iteration's matrix–vector products run on
/// contiguous memory instead of through the strided view.
struct Dense {
    nr: usize,
    nc: usize,
    data: Vec<c64>,
}

impl Dense {
    fn new(m: MatRef<c64>) -> Self {
        let (nr, nc) = (m.nrows(), m.ncols());
        let data = (0..nc).flat_map(|j| (0..nr).map(move |i| m[(i, j)])).collect();
        Dense { nr, nc, data }
    }

    /// out = M x.
    fn mul_into(&self, x: &[c64], out: &mut [c64]) {
        out.iter_mut().for_each(|o| *o = zero());
        for (col, &xj) in self.data.chunks_exact(self.nr).zip(x) {
            for (o, &mij) in out.iter_mut().zip(col) {
                *o += mij * xj;
            }
        }
    }

    /// out = Mᴴ x.
    fn mul_adj_into(&self, x: &[c64], out: &mut [c64]) {
        for (o, col) in out.iter_mut().zip(self.data.chunks_exact(self.nr)) {
            *o = col.iter().zip(x).fold(zero(), |acc, (mij, xi)| acc + mij.conj() * xi);
        }
        debug_assert_eq!(out.len(), self.nc);
    }
}

/// One power-iteration run from (b0, w0); returns the final a, w and b.
fn power_iteration(
    m: MatRef<c64>,
    s: &BlockStructure,
    b0: &[c64],
    w0: &[c64],
    iters: usize,
) -> (Vec<c64>, Vec<c64>, Vec<c64>) {
    let mut b = b0.to_vec();
    let mut w = w0.to_vec();
    normalize(&mut b);
    normalize(&mut w);
    let md = Dense::new(m);
    let mut a = vec![zero(); m.nrows()];
    md.mul_into(&b, &mut a);
    let mut wn = vec![zero(); m.ncols()];
    let mut z = vec![zero(); m.nrows()];
    let mut bn = vec![zero(); m.ncols()];
    let mut beta_old = f64::NAN;
    for _ in 0..iters {
        md.mul_into(&b, &mut a);
        let beta = normalize(&mut a);
        if beta == 0.0 {
            break;
        }
        z.iter_mut().for_each(|x| *x = zero());
        for (j, blk) in s.blocks().iter().enumerate() {
            let (rr, cr) = (s.row_range(j), s.col_range(j));
            match blk {
                BlockKind::Full { .. } => {
                    let (na, nw) = (norm(&a[rr.clone()]), norm(&w[cr]));
                    if na > 0.0 {
                        for p in rr {
                            z[p] = a[p] * (nw / na);
                        }
                    }
                }
                _ => {
                    let ph = phase(dot(&w[cr.clone()], &a[rr.clone()]));
                    for (p, q) in rr.zip(cr) {
                        z[p] = ph * w[q];
                    }
                }
            }
        }
        md.mul_adj_into(&z, &mut wn);
        if normalize(&mut wn) == 0.0 {
            break;
        }
        std::mem::swap(&mut w, &mut wn);
        bn.iter_mut().for_each(|x| *x = zero());
        for (j, blk) in s.blocks().iter().enumerate() {
            let (rr, cr) = (s.row_range(j), s.col_range(j));
            match blk {
                BlockKind::Full { .. } => {
                    let (na, nw) = (norm(&a[rr]), norm(&w[cr.clone()]));
                    if nw > 0.0 {
                        for q in cr {
                            bn[q] = w[q] * (na / nw);
                        }
                    }
                }
                _ => {
                    let ph = phase(dot(&a[rr.clone()], &w[cr.clone()]));
                    for (p, q) in rr.zip(cr) {
                        bn[q] = ph * a[p];
                    }
                }
            }
        }
        if normalize(&mut bn) == 0.0 {
            break;
        }
        std::mem::swap(&mut b, &mut bn);
        if (beta - beta_old).abs() <= 1e-10 * beta {
            break;
        }
        beta_old = beta;
    }
    (a, w, b)
}

/// Eigenvalues of a square complex matrix.
fn eigenvalues(x: MatRef<c64>) -> Result<Vec<c64>> {
    x.eigenvalues()
        .map_err(|e| RobustError::Numerical(format!("eigenvalues in the mu lower bound failed: {e:?}")))
}

/// The block-diagonal Q (Δ-shaped: M cols × M rows) aligned with the vectors a (M-row space) and
/// w (M-column space), every block with σ̄ ≤ 1, as a sum of r outer products Q = U Vᴴ (U: M cols × r,
/// V: M rows × r): a full block's Q_j is rank one and a δI_k block contributes k columns, so r is the
/// number of full blocks plus the sizes of the scalar blocks, usually far below M's size.
fn low_rank_q(s: &BlockStructure, a: &[c64], w: &[c64]) -> (Mat<c64>, Mat<c64>) {
    // One (u, v) pair per column, each a sparse list of (index, value).
    type Sparse = Vec<(usize, c64)>;
    let mut cols: Vec<(Sparse, Sparse)> = Vec::new();
    for (j, blk) in s.blocks().iter().enumerate() {
        let (rr, cr) = (s.row_range(j), s.col_range(j));
        let (aj, wj) = (&a[rr.clone()], &w[cr.clone()]);
        match blk {
            BlockKind::Full { .. } => {
                let (na, nw) = (norm(aj), norm(wj));
                if na > 0.0 && nw > 0.0 {
                    let u = cr.clone().zip(wj).map(|(i, x)| (i, x / nw)).collect();
                    let v = rr.clone().zip(aj).map(|(i, x)| (i, x / na)).collect();
                    cols.push((u, v));
                }
            }
            _ => {
                let ph = phase(dot(aj, wj));
                for (p, q) in cr.zip(rr) {
                    cols.push((vec![(p, ph)], vec![(q, c64::new(1.0, 0.0))]));
                }
            }
        }
    }
    let r = cols.len();
    let mut u = Mat::<c64>::zeros(s.m_cols(), r);
    let mut v = Mat::<c64>::zeros(s.m_rows(), r);
    for (c, (uc, vc)) in cols.iter().enumerate() {
        for &(i, x) in uc {
            u[(i, c)] = x;
        }
        for &(i, x) in vc {
            v[(i, c)] = x;
        }
    }
    (u, v)
}

/// The candidate bound of Q = low_rank_q(a, w): for complex structures ρ(QM) and Δ = Q e^{−i∠λ}/|λ|.
fn candidate(m: MatRef<c64>, s: &BlockStructure, a: &[c64], w: &[c64]) -> Result<LowerBound> {
    let (u, v) = low_rank_q(s, a, w);
    let q = &u * v.adjoint();
    if s.has_real() {
        return real_candidate(m, s, &q);
    }
    // The nonzero eigenvalues of QM = U (VᴴM) are those of the small VᴴMU.
    let lam = if u.ncols() == 0 {
        Vec::new()
    } else {
        let small = v.adjoint() * (m * &u);
        eigenvalues(small.as_ref())?
    };
    let best = lam.iter().copied().max_by(|x, y| x.norm().total_cmp(&y.norm()));
    match best {
        Some(l) if l.norm() > 0.0 => {
            let rot = phase(l).conj() / l.norm();
            Ok(LowerBound {
                value: l.norm(),
                delta: Mat::from_fn(q.nrows(), q.ncols(), |i, j| q[(i, j)] * rot),
            })
        }
        _ => Ok(LowerBound {
            value: 0.0,
            delta: Mat::zeros(q.nrows(), q.ncols()),
        }),
    }
}

/// Mixed structures: real blocks rounded to ±1, complex blocks rotated by a common phase φ; a real
/// eigenvalue λ of Q(φ)M gives the real-compatible perturbation Q(φ)/λ.
fn real_candidate(m: MatRef<c64>, s: &BlockStructure, q: &Mat<c64>) -> Result<LowerBound> {
    let mut base = q.clone();
    let mut complex_rows = vec![false; q.nrows()];
    for (j, blk) in s.blocks().iter().enumerate() {
        let cr = s.col_range(j);
        if blk.is_real() {
            let rr = s.row_range(j);
            for (p, k) in cr.zip(rr) {
                base[(p, k)] = c64::new(if base[(p, k)].re >= 0.0 { 1.0 } else { -1.0 }, 0.0);
            }
        } else {
            for p in cr {
                complex_rows[p] = true;
            }
        }
    }
    let any_complex = complex_rows.iter().any(|&c| c);
    let rotated = |phi: f64| {
        let e = c64::new(phi.cos(), phi.sin());
        Mat::from_fn(base.nrows(), base.ncols(), |i, k| {
            if complex_rows[i] {
                base[(i, k)] * e
            } else {
                base[(i, k)]
            }
        })
    };
    let mut best = LowerBound {
        value: 0.0,
        delta: Mat::zeros(q.nrows(), q.ncols()),
    };
    let consider = |qq: &Mat<c64>, lam: c64, best: &mut LowerBound| {
        if lam.norm() > best.value && lam.im.abs() <= 1e-9 * lam.norm() {
            best.value = lam.norm();
            let inv = 1.0 / lam.re;
            best.delta = Mat::from_fn(qq.nrows(), qq.ncols(), |i, k| qq[(i, k)] * inv);
        }
    };
    let n_phi = if any_complex { 72 } else { 1 };
    let mut prev: Option<(f64, Vec<c64>)> = None;
    for k in 0..=n_phi {
        let phi = if any_complex {
            2.0 * std::f64::consts::PI * k as f64 / n_phi as f64
        } else {
            0.0
        };
        let qq = rotated(phi);
        let lam = eigenvalues((&qq * m).as_ref())?;
        for &l in &lam {
            consider(&qq, l, &mut best);
        }
        if let Some((phi0, lam0)) = &prev {
            // Track each eigenvalue from phi0 to phi by nearest neighbour; bisect sign changes of Im λ.
            for &l0 in lam0 {
                let Some(&l1) = lam.iter().min_by(|x, y| (*x - l0).norm().total_cmp(&(*y - l0).norm())) else {
                    continue;
                };
                if l0.im * l1.im < 0.0 && l0.re * l1.re > 0.0 && l1.norm() > best.value {
                    let (mut lo, mut hi, mut llo) = (*phi0, phi, l0);
                    let mut found = None;
                    for _ in 0..60 {
                        let mid = 0.5 * (lo + hi);
                        let qm = rotated(mid);
                        let lm = eigenvalues((&qm * m).as_ref())?;
                        let Some(&lmid) = lm.iter().min_by(|x, y| (*x - llo).norm().total_cmp(&(*y - llo).norm()))
                        else {
                            break;
                        };
                        found = Some((qm, lmid));
                        if lmid.im * llo.im > 0.0 {
                            lo = mid;
                            llo = lmid;
                        } else {
                            hi = mid;
                        }
                        if lmid.im.abs() <= 1e-12 * lmid.norm() {
                            break;
                        }
                    }
                    if let Some((qm, lmid)) = found {
                        consider(&qm, lmid, &mut best);
                    }
                }
            }
        }
        if !any_complex {
            break;
        }
        prev = Some((phi, lam));
    }
    Ok(best)
}

/// Runs the power iteration from each start (b0 in M's column space, w0 likewise) and returns the
/// best bound found.
pub fn lower_bound(
    m: MatRef<c64>,
    s: &BlockStructure,
    starts: &[(Vec<c64>, Vec<c64>)],
    iters: usize,
) -> Result<LowerBound> {
    Ok(lower_bound_vectors(m, s, starts, iters)?.0)
}

/// As [`lower_bound`], also returning the final (b, w) of the best run: a start for the power
/// iteration at a neighbouring frequency (empty when nothing was found).
pub fn lower_bound_vectors(
    m: MatRef<c64>,
    s: &BlockStructure,
    starts: &[(Vec<c64>, Vec<c64>)],
    iters: usize,
) -> Result<(LowerBound, StartVectors)> {
    s.check_matrix(m.nrows(), m.ncols())?;
    let mut best = LowerBound {
        value: 0.0,
        delta: Mat::zeros(s.m_cols(), s.m_rows()),
    };
    let mut best_start = (Vec::new(), Vec::new());
    for (b0, w0) in starts {
        if b0.len() != m.ncols() || w0.len() != m.ncols() {
            return Err(RobustError::Dimension(format!(
                "power-iteration start vectors must have length {}",
                m.ncols()
            )));
        }
        let (a, w, b) = power_iteration(m, s, b0, w0, iters);
        let c = candidate(m, s, &a, &w)?;
        if c.value > best.value {
            best = c;
            best_start = (b, w);
        }
    }
    Ok((best, best_start))
}
