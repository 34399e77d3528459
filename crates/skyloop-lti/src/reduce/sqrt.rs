//! The square-root machinery shared by the reduction methods: with P = Lc·Lcᵀ and Q = Lo·Loᵀ
//! (Hammarling factors), the SVD Loᵀ·Lc = W·Σ·Vᵀ gives the Hankel singular values Σ and the
//! projections (Tombs & Postlethwaite 1987; Varga 1991 for the balancing-free variant).

use crate::error::{LtiError, Result};
use crate::gramian::gram_chol_pair_schur;
use crate::ss::StateSpace;
use faer::{Mat, MatRef};
use skyloop_linalg::schur::Schur;

pub(super) struct SquareRoot {
    lc: Mat<f64>,
    lo: Mat<f64>,
    w: Mat<f64>,
    v: Mat<f64>,
    pub(super) hsv: Vec<f64>,
}

impl SquareRoot {
    /// Factors and SVD for a stable model whose A has the real Schur form `schur`.
    pub(super) fn new(sys: &StateSpace, schur: &Schur) -> Result<Self> {
        let (lc, lo) = gram_chol_pair_schur(sys, schur)?;
        let finite = |f: &Mat<f64>| f.col_iter().all(|c| c.iter().all(|x| x.is_finite()));
        if !finite(&lc) || !finite(&lo) {
            // An SVD of non-finite numbers only reports NoConvergence; say where it came from.
            return Err(LtiError::Numerical("a gramian's Cholesky factor is not finite".into()));
        }
        // Loᵀ·Lc of the two upper-triangular factors: lower times upper.
        let m = skyloop_linalg::product_using_triangles(lo.transpose(), lc.as_ref());
        let svd = m
            .thin_svd()
            .map_err(|e| LtiError::Numerical(format!("SVD of the gramian factors failed: {e:?}")))?;
        let hsv: Vec<f64> = (0..svd.S().dim()).map(|i| svd.S()[i]).collect();
        Ok(SquareRoot {
            w: svd.U().to_owned(),
            v: svd.V().to_owned(),
            lc,
            lo,
            hsv,
        })
    }

    /// Number of Hankel singular values above n·ε·σ₁ (SLICOT's default rank tolerance).
    pub(super) fn minimal_order(&self) -> usize {
        let n = self.hsv.len();
        let tol = (n.max(1) as f64) * f64::EPSILON * self.hsv.first().copied().unwrap_or(0.0);
        self.hsv.iter().filter(|&&s| s > tol).count()
    }

    /// Balanced truncation to r states: Tl = Σ₁^{-1/2}·W₁ᵀ·Loᵀ, Tr = Lc·V₁·Σ₁^{-1/2}; the result is
    /// balanced with gramians diag(σ₁..σᵣ).
    pub(super) fn truncate(&self, sys: &StateSpace, r: usize) -> Result<StateSpace> {
        let mut tl = self.w.get(.., ..r).transpose() * self.lo.transpose();
        let mut tr = &self.lc * self.v.get(.., ..r);
        for i in 0..r {
            let s = 1.0 / self.hsv[i].sqrt();
            for j in 0..tl.ncols() {
                tl[(i, j)] *= s;
                tr[(j, i)] *= s;
            }
        }
        project(sys, tl.as_ref(), tr.as_ref())
    }

    /// Singular perturbation approximation to r states by the balancing-free square-root method:
    /// orthonormal bases X₁ = orth(Lc·V₁), Y₁ = orth(Lo·W₁) for the kept part and X₂, Y₂ for the
    /// discarded part of the minimal realization, Lᵢ = (Yᵢᵀ·Xᵢ)⁻¹·Yᵢᵀ, then residualize the
    /// second block: Ar = A11 + A12·(γI − A22)⁻¹·A21 with γ = 0 (continuous) or 1 (discrete).
    pub(super) fn singular_perturbation(&self, sys: &StateSpace, r: usize) -> Result<StateSpace> {
        let nmin = self.minimal_order();
        if r >= nmin {
            return self.truncate(sys, nmin);
        }
        let (x1, l1) = self.oblique_basis(0..r)?;
        let (x2, l2) = self.oblique_basis(r..nmin)?;
        let ax1 = &sys.a * &x1;
        let ax2 = &sys.a * &x2;
        let a11 = &l1 * &ax1;
        let a12 = &l1 * &ax2;
        let a21 = &l2 * &ax1;
        let a22 = &l2 * &ax2;
        let b1 = &l1 * &sys.b;
        let b2 = &l2 * &sys.b;
        let c1 = &sys.c * &x1;
        let c2 = &sys.c * &x2;
        let k = nmin - r;
        let gamma = if sys.is_continuous() { 0.0 } else { 1.0 };
        let m = Mat::from_fn(k, k, |i, j| if i == j { gamma } else { 0.0 }) - &a22;
        let lu = m.as_ref().full_piv_lu();
        // M⁻¹·[A21 B2]; M = γI − A22 is regular because A22 of a stable balanced system is stable.
        let rhs = Mat::from_fn(k, r + sys.nu(), |i, j| if j < r { a21[(i, j)] } else { b2[(i, j - r)] });
        let sol = faer::linalg::solvers::Solve::solve(&lu, &rhs);
        if !sol.as_ref().is_all_finite() {
            return Err(LtiError::Numerical(
                "singular perturbation: γI − A22 is singular (model not stable?)".into(),
            ));
        }
        let m21 = sol.get(.., ..r);
        let mb2 = sol.get(.., r..);
        let ar = &a11 + &a12 * m21;
        let br = &b1 + &a12 * mb2;
        let cr = &c1 + &c2 * m21;
        let dr = &sys.d + &c2 * mb2;
        StateSpace::new(ar, br, cr, dr, sys.dt)?.with_delays(sys.input_delay.clone(), sys.output_delay.clone())
    }

    /// X = orth(Lc·V[:, cols]) and L = (Yᵀ·X)⁻¹·Yᵀ with Y = orth(Lo·W[:, cols]).
    fn oblique_basis(&self, cols: std::ops::Range<usize>) -> Result<(Mat<f64>, Mat<f64>)> {
        let lv = &self.lc * self.v.get(.., cols.clone());
        let lw = &self.lo * self.w.get(.., cols);
        let x = lv.qr().compute_thin_Q();
        let y = lw.qr().compute_thin_Q();
        let ytx = y.transpose() * &x;
        let lu = ytx.as_ref().full_piv_lu();
        let l = faer::linalg::solvers::Solve::solve(&lu, y.transpose());
        if !l.as_ref().is_all_finite() {
            return Err(LtiError::Numerical("balancing-free projection is singular".into()));
        }
        Ok((x, l))
    }
}

/// The projected model (Tl·A·Tr, Tl·B, C·Tr, D) with the original sample time and delays.
fn project(sys: &StateSpace, tl: MatRef<f64>, tr: MatRef<f64>) -> Result<StateSpace> {
    let a = tl * &sys.a * tr;
    let b = tl * &sys.b;
    let c = &sys.c * tr;
    StateSpace::new(a, b, c, sys.d.clone(), sys.dt)?.with_delays(sys.input_delay.clone(), sys.output_delay.clone())
}
