//! Algebraic Riccati equations with cross term and indefinite weighting.
//!
//! CARE  `AᵀX + XA − (XB + S)·R⁻¹·(BᵀX + Sᵀ) + Q = 0`, from order 16 on by structure-preserving
//! doubling after a Cayley transform of the (scaled and balanced) Hamiltonian (Chu, Fan & Lin
//! 2005), which works on n×n matrices; below that, and whenever doubling does not deliver, by
//! Laub's method: the ordered real Schur form of the Hamiltonian gives an orthonormal basis
//! `[U11; U21]` of its stable invariant subspace and `X = U21·U11⁻¹` ([`CareMethod`]).
//!
//! DARE  `AᵀXA − X − (AᵀXB + S)·(R + BᵀXB)⁻¹·(BᵀXA + Sᵀ) + Q = 0`, solved by the structure-preserving
//! doubling algorithm (Chu, Fan, Lin & Wang 2004), which needs no inverse of `A`.
//!
//! `R` may be indefinite (H∞ synthesis needs it) but must be nonsingular. Every solution is checked:
//! `X` must be stabilizing (closed-loop eigenvalues strictly inside the left half-plane / unit disc);
//! otherwise `LinalgError::NoSolution` explains why.

// `!(x < tol)` comparisons are deliberate: they also reject NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use faer::linalg::solvers::{FullPivLu, Solve};
use faer::{c64, Mat, MatRef};

use crate::balance::{try_balance_with, BalanceJob};
use crate::dense::{fro_norm, Dm};
use crate::schur::{block_eigenvalues, eigenvalues, reorder_dm, schur_dm};
use crate::{LinalgError, Result};

/// Stabilizing solution of a CARE or DARE.
#[derive(Debug, Clone)]
pub struct RiccatiSolution {
    /// Symmetric stabilizing solution `X`.
    pub x: Mat<f64>,
    /// Optimal gain: CARE `K = R⁻¹(BᵀX + Sᵀ)`, DARE `K = (R + BᵀXB)⁻¹(BᵀXA + Sᵀ)`; control `u = −K·x`.
    pub k: Mat<f64>,
    /// Eigenvalues of the closed loop `A − B·K` (all with negative real part / inside the unit disc).
    /// For a CARE solution taken from the Hamiltonian's Schur form without refinement, these are
    /// the Hamiltonian's stable eigenvalues (the exact closed loop's spectrum), and stability of
    /// `A − B·K` itself is proven by a Lyapunov certificate; otherwise they are computed from
    /// `A − B·K`.
    pub closed_loop_eigs: Vec<c64>,
    /// Relative residual: ‖residual‖_F divided by the sum of the Frobenius norms of its terms.
    pub residual: f64,
}

/// Tuning of the Riccati solvers; `Default` is what [`care`] and [`dare`] use.
#[derive(Debug, Clone, Copy)]
pub struct RiccatiOptions {
    /// Balance the Hamiltonian (structure-preserving diagonal scaling) before the Schur form (CARE).
    pub balance: bool,
    /// Scale `Q` and `G = B·R⁻¹·Bᵀ` to equal norms before forming the Hamiltonian (CARE).
    pub scale: bool,
    /// Maximum number of Newton refinement steps after the direct solution (Kleinman for the CARE,
    /// Hewer for the DARE); each solves one (Stein-)Lyapunov equation and is kept only if it halves
    /// the residual.
    pub newton_steps: usize,
    /// Refine only while the relative residual exceeds this (at rounding level a Newton step cannot
    /// improve X and on ill-conditioned problems only moves it around).
    pub refine_above: f64,
    /// Hamiltonian eigenvalues with |Re λ| ≤ `axis_tol`·‖H‖ count as on the imaginary axis (CARE);
    /// for the DARE, closed-loop eigenvalues with |λ| ≥ 1 − `axis_tol` count as on the unit circle.
    pub axis_tol: f64,
    /// Maximum number of doubling steps (DARE, and the CARE's doubling method).
    pub max_iter: usize,
    /// How the CARE is solved.
    pub care_method: CareMethod,
}

/// Method of [`care_with`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CareMethod {
    /// Doubling first from order [`CARE_DOUBLING_MIN_ORDER`] on; Laub's Schur method below it and
    /// when doubling stops without a solution (no convergence within [`CARE_DOUBLING_STEPS`], a
    /// singular step, or a result that is not stabilizing). The default.
    Auto,
    /// Laub's ordered-Schur method of the Hamiltonian only. H∞ synthesis uses it: its γ search
    /// probes Hamiltonians with eigenvalues on the imaginary axis, where doubling cannot converge
    /// and would only add the failed iterations to every infeasible γ.
    Schur,
    /// Structure-preserving doubling after a Cayley transform of the Hamiltonian only.
    Doubling,
}

/// Doubling steps [`CareMethod::Auto`] allows before it turns to the Schur method: beyond about 30
/// the iterations cost more than the Schur form of the Hamiltonian, and a convergence factor that
/// slow means Hamiltonian eigenvalues within ~1e-9·γ of the imaginary axis, where the Schur
/// method's checks decide better.
pub const CARE_DOUBLING_STEPS: usize = 30;

/// Smallest order at which [`CareMethod::Auto`] tries doubling: below it the Schur form of the
/// (at most 30×30) Hamiltonian costs under 0.1 ms, doubling saves nothing, and the backward-stable
/// Schur method is kept (on CAREX 2.4 at n = 2 it is 10⁴ times more accurate).
pub const CARE_DOUBLING_MIN_ORDER: usize = 16;

/// Relative residual up to which [`CareMethod::Auto`] accepts a (refined) doubling solution without
/// also running the Schur method.
const DOUBLING_ACCEPT: f64 = 1e-10;

impl Default for RiccatiOptions {
    fn default() -> Self {
        RiccatiOptions {
            balance: true,
            scale: true,
            newton_steps: 2,
            refine_above: 1e-13,
            axis_tol: 1e2 * f64::EPSILON,
            max_iter: 100,
            care_method: CareMethod::Auto,
        }
    }
}

/// Solve the CARE `AᵀX + XA − (XB + S)R⁻¹(BᵀX + Sᵀ) + Q = 0` for its stabilizing solution
/// (`S = None` means `S = 0`). `R` may be indefinite but not singular.
pub fn care(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    r: MatRef<f64>,
    s: Option<MatRef<f64>>,
) -> Result<RiccatiSolution> {
    care_with(a, b, q, r, s, &RiccatiOptions::default())
}

/// Solve the DARE `AᵀXA − X − (AᵀXB + S)(R + BᵀXB)⁻¹(BᵀXA + Sᵀ) + Q = 0` for its stabilizing
/// solution (`S = None` means `S = 0`). `R` may be indefinite but not singular.
pub fn dare(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    r: MatRef<f64>,
    s: Option<MatRef<f64>>,
) -> Result<RiccatiSolution> {
    dare_with(a, b, q, r, s, &RiccatiOptions::default())
}

/// Checked data of a Riccati problem with `R⁻¹` folded in: `Ā = A − B·R⁻¹·Sᵀ`, `G = B·R⁻¹·Bᵀ`,
/// `Q̄ = Q − S·R⁻¹·Sᵀ`.
struct Reduced {
    abar: Mat<f64>,
    g: Mat<f64>,
    qbar: Mat<f64>,
    s: Mat<f64>,
    /// `R`, symmetrized.
    r: Mat<f64>,
    r_lu: Option<FullPivLu<f64>>,
}

fn check_finite(m: MatRef<f64>, name: &str, who: &str) -> Result<()> {
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            if !m[(i, j)].is_finite() {
                return Err(LinalgError::InvalidArgument(format!(
                    "{who}: {name} has NaN or infinite entries"
                )));
            }
        }
    }
    Ok(())
}

fn check_symmetric(m: MatRef<f64>, name: &str, who: &str) -> Result<Mat<f64>> {
    let asym = fro_norm((m - m.transpose()).as_ref());
    let nrm = fro_norm(m);
    if asym > 1e-10 * nrm.max(f64::MIN_POSITIVE) && asym > 0.0 {
        return Err(LinalgError::InvalidArgument(format!(
            "{who}: {name} must be symmetric (‖{name} − {name}ᵀ‖/‖{name}‖ = {:.1e})",
            asym / nrm
        )));
    }
    Ok(symmetrize(m))
}

fn symmetrize(m: MatRef<f64>) -> Mat<f64> {
    let n = m.nrows();
    Mat::from_fn(n, n, |i, j| 0.5 * (m[(i, j)] + m[(j, i)]))
}

fn reduce(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    r: MatRef<f64>,
    s: Option<MatRef<f64>>,
    who: &str,
) -> Result<Reduced> {
    let n = a.nrows();
    let m = b.ncols();
    let dim = |what: String| Err(LinalgError::Dimension(format!("{who}: {what}")));
    if a.ncols() != n {
        return dim(format!("A is {}x{}, not square", n, a.ncols()));
    }
    if b.nrows() != n {
        return dim(format!("B has {} rows, A has {}", b.nrows(), n));
    }
    if q.nrows() != n || q.ncols() != n {
        return dim(format!("Q is {}x{}, expected {n}x{n}", q.nrows(), q.ncols()));
    }
    if r.nrows() != m || r.ncols() != m {
        return dim(format!("R is {}x{}, expected {m}x{m}", r.nrows(), r.ncols()));
    }
    if let Some(s) = s {
        if s.nrows() != n || s.ncols() != m {
            return dim(format!("S is {}x{}, expected {n}x{m}", s.nrows(), s.ncols()));
        }
    }
    for (mat, name) in [(a, "A"), (b, "B"), (q, "Q"), (r, "R")] {
        check_finite(mat, name, who)?;
    }
    if let Some(s) = s {
        check_finite(s, "S", who)?;
    }
    let q = check_symmetric(q, "Q", who)?;
    let r = check_symmetric(r, "R", who)?;
    let s = s.map(|s| s.to_owned()).unwrap_or_else(|| Mat::zeros(n, m));
    if m == 0 {
        return Ok(Reduced {
            abar: a.to_owned(),
            g: Mat::zeros(n, n),
            qbar: q,
            s,
            r,
            r_lu: None,
        });
    }
    let lu = r.full_piv_lu();
    // Reciprocal condition of R from its 1-norm and the 1-norm of its inverse (m is small).
    let rinv = lu.solve(Mat::<f64>::identity(m, m));
    let rcond = 1.0 / (norm1(r.as_ref()) * norm1(rinv.as_ref()));
    if !(rcond > f64::EPSILON) {
        return Err(LinalgError::Singular(format!(
            "{who}: R is singular to working precision (reciprocal condition {rcond:.1e})"
        )));
    }
    // [R⁻¹Bᵀ, R⁻¹Sᵀ] in one solve.
    let mut rhs = Mat::zeros(m, 2 * n);
    rhs.as_mut().submatrix_mut(0, 0, m, n).copy_from(b.transpose());
    rhs.as_mut().submatrix_mut(0, n, m, n).copy_from(s.transpose());
    let sol = lu.solve(&rhs);
    let rinv_bt = sol.as_ref().submatrix(0, 0, m, n);
    let rinv_st = sol.as_ref().submatrix(0, n, m, n);
    let abar = a - b * rinv_st;
    let g = symmetrize((b * rinv_bt).as_ref());
    let qbar = symmetrize((&q - &s * rinv_st).as_ref());
    Ok(Reduced {
        abar,
        g,
        qbar,
        s,
        r,
        r_lu: Some(lu),
    })
}

/// Smallest and largest |uᵢᵢ| of an LU factor's `U`: their ratio is the singularity test of
/// every factorization here.
fn pivot_extremes(u: MatRef<f64>) -> (f64, f64) {
    let d = (0..u.nrows().min(u.ncols())).map(|i| u[(i, i)].abs());
    (d.clone().fold(f64::INFINITY, f64::min), d.fold(0.0, f64::max))
}

fn norm1(m: MatRef<f64>) -> f64 {
    (0..m.ncols())
        .map(|j| (0..m.nrows()).map(|i| m[(i, j)].abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// [`care`] with explicit options.
pub fn care_with(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    r: MatRef<f64>,
    s: Option<MatRef<f64>>,
    opts: &RiccatiOptions,
) -> Result<RiccatiSolution> {
    const WHO: &str = "care";
    let n = a.nrows();
    let red = reduce(a, b, q, r, s, WHO)?;
    if n == 0 {
        return Ok(RiccatiSolution {
            x: Mat::zeros(0, 0),
            k: Mat::zeros(b.ncols(), 0),
            closed_loop_eigs: vec![],
            residual: 0.0,
        });
    }

    // Scale X = σ·Y so that ‖σG‖ = ‖Q̄/σ‖ (SLICOT SB02MD's scaling): the Hamiltonian's blocks
    // then have comparable norms.
    let (gn, qn) = (fro_norm(red.g.as_ref()), fro_norm(red.qbar.as_ref()));
    let sigma = if opts.scale && gn > 0.0 && qn > 0.0 {
        (qn / gn).sqrt()
    } else {
        1.0
    };
    let g = &red.g * sigma;
    let qs = &red.qbar * (1.0 / sigma);

    let mut h = Dm::zeros(2 * n);
    for j in 0..n {
        for i in 0..n {
            h[(i, j)] = red.abar[(i, j)];
            h[(i, j + n)] = -g[(i, j)];
            h[(i + n, j)] = -qs[(i, j)];
            h[(i + n, j + n)] = -red.abar[(j, i)];
        }
    }

    // Structure-preserving balancing: D = diag(D1, D1⁻¹) keeps H Hamiltonian; the ARE of the
    // balanced data has solution Y' = D1·Y·D1.
    let mut d1 = vec![1.0; n];
    if opts.balance {
        let hm = h.to_mat();
        let bal = try_balance_with(
            hm.as_ref(),
            BalanceJob {
                permute: false,
                scale: true,
            },
        )?;
        for (i, di) in d1.iter_mut().enumerate() {
            let e = ((bal.scale[i].log2() - bal.scale[i + n].log2()) / 2.0).round();
            *di = 2f64.powi(e as i32);
        }
        for j in 0..2 * n {
            for i in 0..2 * n {
                let di = if i < n { d1[i] } else { 1.0 / d1[i - n] };
                let dj = if j < n { d1[j] } else { 1.0 / d1[j - n] };
                h[(i, j)] *= dj / di;
            }
        }
    }
    let hnorm = fro_norm(MatRef::from_column_major_slice(&h.d, 2 * n, 2 * n));

    let try_doubling = match opts.care_method {
        CareMethod::Schur => false,
        CareMethod::Auto => n >= CARE_DOUBLING_MIN_ORDER,
        CareMethod::Doubling => true,
    };
    let mut doubled = None;
    if try_doubling {
        let steps = match opts.care_method {
            CareMethod::Doubling => opts.max_iter,
            _ => opts.max_iter.min(CARE_DOUBLING_STEPS),
        };
        // The balanced blocks [Ā' −G'; −Q' −Ā'ᵀ] of H; their solution is Y' = D1·Y·D1.
        let ab = Mat::from_fn(n, n, |i, j| h[(i, j)]);
        let gb = Mat::from_fn(n, n, |i, j| -h[(i, j + n)]);
        let qb = Mat::from_fn(n, n, |i, j| -h[(i + n, j)]);
        let by_doubling = care_doubling(ab.as_ref(), gb.as_ref(), qb.as_ref(), steps).and_then(|yp| {
            let x = Mat::from_fn(n, n, |i, j| sigma * yp[(i, j)] / (d1[i] * d1[j]));
            care_finish(a, b, q, &red, x, None)
        });
        match by_doubling.and_then(|sol| care_refine(a, b, q, &red, sol, opts)) {
            Ok(sol) if sol.residual <= DOUBLING_ACCEPT || opts.care_method == CareMethod::Doubling => return Ok(sol),
            Err(e) if opts.care_method == CareMethod::Doubling => return Err(e),
            // Doubling has no backward-stability guarantee: a poor result is kept only if the
            // Schur method does no better.
            Ok(sol) => doubled = Some(sol),
            Err(_) => {}
        }
    }

    let (mut t, mut z) = schur_dm(h)?;
    let tol = opts.axis_tol * hnorm.max(f64::MIN_POSITIVE);
    let mut near_axis = None;
    let mut k = 0;
    while k < 2 * n {
        let re = t[(k, k)];
        if re.abs() <= tol {
            near_axis = Some(re);
        }
        k += if k + 1 < 2 * n && t[(k + 1, k)] != 0.0 { 2 } else { 1 };
    }
    if let Some(re) = near_axis {
        return Err(LinalgError::NoSolution(format!(
            "care: the Hamiltonian has an eigenvalue on or near the imaginary axis (Re λ = {re:.2e}, \
             ‖H‖ = {hnorm:.2e}); no stabilizing solution"
        )));
    }
    let nstable = reorder_dm(&mut t, &mut z, &|z: c64| z.re < 0.0)?;
    if nstable != n {
        return Err(LinalgError::NoSolution(format!(
            "care: the Hamiltonian has {nstable} stable eigenvalues, {n} needed; no stabilizing solution"
        )));
    }

    // The stable eigenvalues: those of the exact closed loop (H is similar to the Hamiltonian of
    // the unscaled problem); the first n of the reordered form.
    let mut stable_eigs = block_eigenvalues(&t);
    stable_eigs.truncate(n);

    // X' = U21·U11⁻¹, i.e. U11ᵀ·X' = U21ᵀ (X' is symmetric), by full-pivoting LU.
    let u11t = Mat::from_fn(n, n, |i, j| z[(j, i)]);
    let u21t = Mat::from_fn(n, n, |i, j| z[(j + n, i)]);
    let lu = u11t.full_piv_lu();
    let (umin, umax) = pivot_extremes(lu.U());
    if !(umin > 1e2 * f64::EPSILON * umax.max(1.0)) {
        return Err(LinalgError::NoSolution(format!(
            "care: U11 of the stable invariant subspace is singular (pivot ratio {:.1e}); \
             no stabilizing solution (is (A, B) stabilizable?)",
            umin / umax
        )));
    }
    let xp = lu.solve(&u21t);
    let x = Mat::from_fn(n, n, |i, j| sigma * 0.5 * (xp[(i, j)] + xp[(j, i)]) / (d1[i] * d1[j]));

    let sol = care_finish(a, b, q, &red, x, Some(stable_eigs))?;
    let sol = care_refine(a, b, q, &red, sol, opts)?;
    Ok(match doubled {
        Some(d) if d.residual < sol.residual => d,
        _ => sol,
    })
}

/// Newton refinement of a CARE solution while its residual is above `opts.refine_above`, each
/// step kept only if it halves the residual.
fn care_refine(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    red: &Reduced,
    mut sol: RiccatiSolution,
    opts: &RiccatiOptions,
) -> Result<RiccatiSolution> {
    for _ in 0..opts.newton_steps {
        if !(sol.residual > opts.refine_above.max(2.0 * f64::EPSILON)) {
            break;
        }
        match newton_care_step(a, b, q, red, &sol)? {
            Some(better) if better.residual < 0.5 * sol.residual => sol = better,
            _ => break,
        }
    }
    Ok(sol)
}

/// Stabilizing solution of `AᵀX + XA − XGX + Q = 0` by doubling (Chu, Fan & Lin 2005, SDA-1):
/// the Cayley transform `(ℋ − γI)⁻¹(ℋ + γI)` maps the Hamiltonian's stable eigenvalues into the
/// unit disc, and with `A_γ = A − γI`, `W = A_γᵀ + Q·A_γ⁻¹·G` the transformed pencil is in
/// standard symplectic form with
///   `G₀ = 2γ·A_γ⁻¹·G·W⁻¹`,  `E₀ = I + (2γI − G₀Q)·A_γ⁻¹`,  `H₀ = A_γ⁻ᵀ·(2γI − Q·G₀)·Q·A_γ⁻¹`
/// (from `M₀(ℋ − γI) = L₀(ℋ + γI)`), which [`doubling`] takes to `X`.
///
/// Why: it works on n×n matrices where Laub's method needs the Schur form of the 2n×2n
/// Hamiltonian; at n = 50 it takes about half the time. `γ` (chosen in [`cayley_start`]) is near
/// the typical magnitude of the Hamiltonian's eigenvalues, so both small and large ones map away
/// from the unit circle.
fn care_doubling(a: MatRef<f64>, g: MatRef<f64>, q: MatRef<f64>, max_iter: usize) -> Result<Mat<f64>> {
    let (e0, g0, h0) = cayley_start(a, g, q)?;
    doubling(e0, g0, h0, max_iter).map_err(|stop| {
        LinalgError::NoSolution(match stop {
            DoublingStop::Singular => "care: doubling: I + G·H became singular".into(),
            DoublingStop::NotConverged => format!("care: doubling: no convergence in {max_iter} steps"),
        })
    })
}

/// The standard symplectic form `(E₀, G₀, H₀)` of the Cayley-transformed Hamiltonian of
/// `AᵀX + XA − XGX + Q = 0` (see [`care_doubling`]); its fixed point
/// `X = H₀ + E₀ᵀX(I + G₀X)⁻¹E₀` is the CARE's stabilizing solution.
fn cayley_start(a: MatRef<f64>, g: MatRef<f64>, q: MatRef<f64>) -> Result<(Mat<f64>, Mat<f64>, Mat<f64>)> {
    let n = a.nrows();
    let fail = |why: &str| Err(LinalgError::NoSolution(format!("care: doubling: {why}")));
    // γ near the typical magnitude of the Hamiltonian's eigenvalues λ: |tr(ℋ²)|/2n is the mean
    // of λ² over the stable half (exact, O(n²)); the RMS bound ‖ℋ‖_F/√(2n) overestimates it for
    // non-normal data and takes over only where the trace cancels (as many |Re λ| as |Im λ|).
    let hnorm = (2.0 * fro_norm(a).powi(2) + fro_norm(g).powi(2) + fro_norm(q).powi(2)).sqrt();
    let rms_bound = hnorm / ((2 * n) as f64).sqrt();
    let mut tr2 = 0.0;
    for j in 0..n {
        for i in 0..n {
            tr2 += 2.0 * (a[(i, j)] * a[(j, i)] + g[(i, j)] * q[(j, i)]);
        }
    }
    let mean_square = (tr2.abs() / (2 * n) as f64).sqrt();
    let gamma = if mean_square >= 0.1 * rms_bound {
        mean_square
    } else {
        rms_bound
    };
    if !(gamma > 0.0 && gamma.is_finite()) {
        return fail("the Hamiltonian is zero or not finite");
    }
    let well_conditioned = |u: MatRef<f64>| {
        let (umin, umax) = pivot_extremes(u);
        umin > 1e4 * f64::EPSILON * umax
    };
    let mut ag = a.to_owned();
    for i in 0..n {
        ag[(i, i)] -= gamma;
    }
    let lu_a = ag.full_piv_lu();
    if !well_conditioned(lu_a.U()) {
        return fail("A − γI is nearly singular");
    }
    let p = lu_a.solve(g); // A_γ⁻¹·G
    let w = ag.transpose() + q * &p;
    let lu_w = w.full_piv_lu();
    if !well_conditioned(lu_w.U()) {
        return fail("the Cayley transform is nearly singular");
    }
    let g0 = symmetrize((lu_w.rsolve(&p) * (2.0 * gamma)).as_ref());
    let mut t = -(&g0 * q);
    for i in 0..n {
        t[(i, i)] += 2.0 * gamma;
    }
    let mut e0 = lu_a.rsolve(&t);
    for i in 0..n {
        e0[(i, i)] += 1.0;
    }
    let h0 = symmetrize(lu_a.solve_transpose(lu_a.rsolve(t.transpose() * q)).as_ref());
    Ok((e0, g0, h0))
}

/// One Newton (Kleinman) step `X ← X + N` with `A_clᵀ·N + N·A_cl + Res(X) = 0`, `A_cl = A − B·K`:
/// the linearization of the CARE at `X` (Benner & Byers's refinement without line search).
fn newton_care_step(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    red: &Reduced,
    sol: &RiccatiSolution,
) -> Result<Option<RiccatiSolution>> {
    let x = &sol.x;
    let xbs = x * b + &red.s;
    let aterm = a.transpose() * x;
    let res = symmetrize((&aterm + aterm.transpose() - &xbs * &sol.k + q).as_ref());
    let acl = a - b * &sol.k;
    let step = match crate::lyapunov::lyap(acl.transpose(), res.as_ref()) {
        Ok(n) => n,
        Err(LinalgError::NoSolution(_)) | Err(LinalgError::Singular(_)) => return Ok(None),
        Err(e) => return Err(e),
    };
    let xn = symmetrize((x + &step).as_ref());
    match care_finish(a, b, q, red, xn, None) {
        Ok(s) => Ok(Some(s)),
        Err(LinalgError::NoSolution(_)) => Ok(None),
        Err(e) => Err(e),
    }
}

/// Gain `K = R⁻¹(BᵀX + Sᵀ)` and relative residual of a CARE solution candidate.
fn care_gain_residual(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    red: &Reduced,
    x: MatRef<f64>,
) -> (Mat<f64>, f64) {
    let n = a.nrows();
    let m = b.ncols();
    let xbs = x * b + &red.s; // XB + S
    let k = match &red.r_lu {
        Some(lu) => lu.solve(xbs.transpose()),
        None => Mat::zeros(m, n),
    };
    let aterm = a.transpose() * x;
    let res = &aterm + aterm.transpose() - &xbs * &k + q;
    let denom = fro_norm(q) + 2.0 * fro_norm(aterm.as_ref()) + fro_norm(xbs.as_ref()) * fro_norm(k.as_ref());
    let residual = if denom > 0.0 {
        fro_norm(res.as_ref()) / denom
    } else {
        fro_norm(res.as_ref())
    };
    (k, residual)
}

/// Relative residual of a candidate CARE solution `x`:
/// ‖AᵀX + XA − (XB + S)R⁻¹(BᵀX + Sᵀ) + Q‖_F / (‖Q‖_F + 2‖AᵀX‖_F + ‖XB + S‖_F·‖R⁻¹(BᵀX + Sᵀ)‖_F).
pub fn care_residual(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    r: MatRef<f64>,
    s: Option<MatRef<f64>>,
    x: MatRef<f64>,
) -> Result<f64> {
    let red = reduce(a, b, q, r, s, "care_residual")?;
    if x.nrows() != a.nrows() || x.ncols() != a.nrows() {
        return Err(LinalgError::Dimension(format!(
            "care_residual: X is {}x{}",
            x.nrows(),
            x.ncols()
        )));
    }
    Ok(care_gain_residual(a, b, q, &red, x).1)
}

/// Closed-loop eigenvalues, stabilizing check and residual of a CARE solution candidate.
///
/// With `ham_eigs` (the Hamiltonian's stable eigenvalues, for `X` straight from its Schur form)
/// the stability of `A − B·K` is proven by [`lyapunov_certificate`] where it applies, and
/// `ham_eigs` are reported as the closed-loop eigenvalues; otherwise (no `ham_eigs`, or the
/// certificate does not apply) the eigenvalues of `A − B·K` are computed and checked.
fn care_finish(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    red: &Reduced,
    x: Mat<f64>,
    ham_eigs: Option<Vec<c64>>,
) -> Result<RiccatiSolution> {
    let (k, residual) = care_gain_residual(a, b, q, red, x.as_ref());
    let acl = a - b * &k;
    let certified = ham_eigs
        .filter(|e| e.len() == a.nrows() && lyapunov_certificate(a, b, q, red, x.as_ref(), k.as_ref(), acl.as_ref()));
    let eigs = match certified {
        Some(e) => e,
        None => eigenvalues(acl.as_ref())?,
    };
    if let Some(z) = eigs.iter().find(|z| !(z.re < 0.0)) {
        return Err(LinalgError::NoSolution(format!(
            "care: the solution is not stabilizing (closed-loop eigenvalue {z}); no stabilizing solution"
        )));
    }
    Ok(RiccatiSolution {
        x,
        k,
        closed_loop_eigs: eigs,
        residual,
    })
}

/// Whether Lyapunov's theorem proves `A_cl = A − B·K` Hurwitz, in floating point: with
/// `M = Q + KᵀRK − S·K − KᵀSᵀ` and `Res = A_clᵀX + X·A_cl + M` (the CARE residual at `X` when
/// `K = R⁻¹(BᵀX + Sᵀ)`), `A_clᵀX + X·A_cl = −(M − Res)`, so `X ≻ 0` and `λ_min(M) > ‖Res‖₂`
/// imply that `A_cl` is Hurwitz. Both are checked by Cholesky factorizations of `X − η·I` and
/// `M − (‖Res‖_F + e)·I`, where `η` covers the backward error of the Cholesky factorization
/// (`γ_{n+1}·trace`, doubled) and `e` bounds the rounding errors of forming `A_cl`, `M` and `Res`
/// and of `‖Res‖_F` itself (the standard `γ_k` bounds of products and sums, in Frobenius norms,
/// with a margin); every quantity is exact for the returned `X` and `K`, so the proof is for them.
///
/// Why: it costs a few 50×50 products and two Cholesky factorizations, where the eigenvalues of
/// `A_cl` cost a Hessenberg reduction and a QR iteration (about a tenth of a 50-state solve). It
/// does not apply when `X` is not positive definite or `M` is not safely positive definite
/// (e.g. singular `Q` with few inputs, or the indefinite `R` of H∞ synthesis): `false` then, and
/// the caller computes the eigenvalues instead.
fn lyapunov_certificate(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    red: &Reduced,
    x: MatRef<f64>,
    k: MatRef<f64>,
    acl: MatRef<f64>,
) -> bool {
    use faer::Side;
    let n = a.nrows();
    let m = b.ncols();
    if m == 0 || red.r_lu.is_none() {
        return false;
    }
    let gamma = |k: usize| {
        let u = (k as f64) * f64::EPSILON;
        u / (1.0 - u)
    };
    // X ≻ 0: a Cholesky factorization that succeeds on X − η·I with η ≥ its backward error.
    let trace = |mat: MatRef<f64>| (0..mat.nrows()).map(|i| mat[(i, i)]).sum::<f64>();
    let eta = 2.0 * gamma(n + 1) * trace(x).abs();
    let mut xs = x.to_owned();
    for i in 0..n {
        xs[(i, i)] -= eta;
    }
    if xs.llt(Side::Lower).is_err() {
        return false;
    }
    let sk = &red.s * k;
    let mut mm = q + k.transpose() * &red.r * k - &sk - sk.transpose();
    let xacl = x * acl;
    let res = &xacl + xacl.transpose() + &mm;
    let (kn, xn, rn) = (fro_norm(k), fro_norm(x), fro_norm(res.as_ref()));
    // Each product or sum of the terms below errs by at most γ_k·(product of the factors' norms)
    // with k ≤ n + 2m + 4; the M error enters twice (in M and in Res), hence the factor 4.
    let err = 4.0
        * gamma(n + 2 * m + 4)
        * (2.0 * (fro_norm(a) + fro_norm(b) * kn) * xn
            + fro_norm(q)
            + kn * kn * fro_norm(red.r.as_ref())
            + 2.0 * fro_norm(red.s.as_ref()) * kn
            + rn);
    // rn itself: a sum of n² squares, relative error below γ_{n²+2}.
    let delta = rn * (1.0 + gamma(n * n + 2)) + err;
    let shift = delta + 2.0 * gamma(n + 1) * (trace(mm.as_ref()).abs() + n as f64 * delta);
    for i in 0..n {
        mm[(i, i)] -= shift;
    }
    shift.is_finite() && mm.llt(Side::Lower).is_ok()
}

/// Why a doubling iteration stopped without a solution.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DoublingStop {
    /// `I + G·H` became singular to working precision.
    Singular,
    /// No convergence within the step limit, or the iterates overflowed.
    NotConverged,
}

/// Structure-preserving doubling (Chu, Fan, Lin & Wang 2004) on the standard symplectic form
/// `M = [E 0; −H I]`, `L = [I G; 0 Eᵀ]` whose stable deflating subspace is `[I; X]`:
///   `E ← E(I + GH)⁻¹E`,  `G ← G + E(I + GH)⁻¹GEᵀ`,  `H ← H + EᵀH(I + GH)⁻¹E`;
/// `H → X` quadratically, at the rate of the squared spectral radius of the stable part.
fn doubling(
    mut ek: Mat<f64>,
    mut gk: Mat<f64>,
    mut hk: Mat<f64>,
    max_iter: usize,
) -> std::result::Result<Mat<f64>, DoublingStop> {
    let n = ek.nrows();
    let eye = Mat::<f64>::identity(n, n);
    let mut settling = false;
    for _ in 0..max_iter {
        let w = &eye + &gk * &hk;
        let lu = w.partial_piv_lu();
        let (umin, umax) = pivot_extremes(lu.U());
        if !(umin > 1e2 * f64::EPSILON * umax) {
            return Err(DoublingStop::Singular);
        }
        // W⁻¹·[E G] in one solve.
        let mut rhs = Mat::zeros(n, 2 * n);
        rhs.as_mut().submatrix_mut(0, 0, n, n).copy_from(&ek);
        rhs.as_mut().submatrix_mut(0, n, n, n).copy_from(&gk);
        let v = lu.solve(&rhs);
        let (v1, v2) = (v.as_ref().submatrix(0, 0, n, n), v.as_ref().submatrix(0, n, n, n));
        let h_next = symmetrize((&hk + ek.transpose() * (&hk * v1)).as_ref());
        let e_next = &ek * v1;
        let change = fro_norm((&h_next - &hk).as_ref());
        let hn = fro_norm(h_next.as_ref());
        if !hn.is_finite() {
            return Err(DoublingStop::NotConverged);
        }
        // The next update is Eᵀ·H·W⁻¹·E with the new E: relative to ‖H‖ at most about
        // ‖E‖²·‖W⁻¹‖ (‖W⁻¹‖ estimated by 1/min|uᵢᵢ|, W → I + G·X changing little by now).
        let en = fro_norm(e_next.as_ref());
        // Quadratic convergence: once the update is at rounding level, one more step settles it;
        // once the next update is predicted below rounding level, this step has settled it.
        if change <= 4.0 * f64::EPSILON * hn
            || (settling && change <= 1e-12 * hn)
            || (change <= 1e-6 * hn && en * en / umin <= f64::EPSILON)
        {
            return Ok(h_next);
        }
        settling = change <= 1e-12 * hn;
        gk = symmetrize((&gk + &ek * v2 * ek.transpose()).as_ref());
        ek = e_next;
        hk = h_next;
    }
    Err(DoublingStop::NotConverged)
}

/// [`dare`] with explicit options.
pub fn dare_with(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    r: MatRef<f64>,
    s: Option<MatRef<f64>>,
    opts: &RiccatiOptions,
) -> Result<RiccatiSolution> {
    const WHO: &str = "dare";
    let n = a.nrows();
    let m = b.ncols();
    let red = reduce(a, b, q, r, s, WHO)?;
    if n == 0 {
        return Ok(RiccatiSolution {
            x: Mat::zeros(0, 0),
            k: Mat::zeros(m, 0),
            closed_loop_eigs: vec![],
            residual: 0.0,
        });
    }
    // X = ĀᵀX(I + GX)⁻¹Ā + Q̄ is the standard symplectic form with E₀ = Ā, G₀ = G, H₀ = Q̄.
    let hk = match doubling(red.abar.clone(), red.g.clone(), red.qbar.clone(), opts.max_iter) {
        Ok(h) => h,
        Err(DoublingStop::Singular) => {
            return Err(LinalgError::NoSolution(
                "dare: I + G·H became singular in the doubling iteration; no stabilizing solution \
                 (or R + BᵀXB singular)"
                    .into(),
            ))
        }
        Err(DoublingStop::NotConverged) => {
            return Err(LinalgError::NoSolution(format!(
                "dare: doubling iteration did not converge in {} steps: the symplectic pencil has \
                 eigenvalues on or near the unit circle; no stabilizing solution",
                opts.max_iter
            )))
        }
    };
    let mut sol = dare_finish(a, b, q, r, &red, hk, opts)?;
    for _ in 0..opts.newton_steps {
        if !(sol.residual > opts.refine_above.max(2.0 * f64::EPSILON)) {
            break;
        }
        match newton_dare_step(a, b, q, r, &red, &sol, opts)? {
            Some(better) if better.residual < 0.5 * sol.residual => sol = better,
            _ => break,
        }
    }
    Ok(sol)
}

/// One Newton (Hewer) step `X ← X + N` with `A_clᵀ·N·A_cl − N + Res(X) = 0`, `A_cl = A − B·K`.
fn newton_dare_step(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    r: MatRef<f64>,
    red: &Reduced,
    sol: &RiccatiSolution,
    opts: &RiccatiOptions,
) -> Result<Option<RiccatiSolution>> {
    let x = &sol.x;
    let bxas = b.transpose() * x * a + red.s.transpose();
    let res = symmetrize((a.transpose() * x * a - x - bxas.transpose() * &sol.k + q).as_ref());
    let acl = a - b * &sol.k;
    let step = match crate::lyapunov::dlyap(acl.transpose(), res.as_ref()) {
        Ok(n) => n,
        Err(LinalgError::NoSolution(_)) | Err(LinalgError::Singular(_)) => return Ok(None),
        Err(e) => return Err(e),
    };
    let xn = symmetrize((x + &step).as_ref());
    match dare_finish(a, b, q, r, red, xn, opts) {
        Ok(s) => Ok(Some(s)),
        Err(LinalgError::NoSolution(_)) => Ok(None),
        Err(e) => Err(e),
    }
}

/// Gain `K = (R + BᵀXB)⁻¹(BᵀXA + Sᵀ)` and relative residual of a DARE solution candidate.
fn dare_gain_residual(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    r: MatRef<f64>,
    red: &Reduced,
    x: MatRef<f64>,
) -> Result<(Mat<f64>, f64)> {
    let n = a.nrows();
    let m = b.ncols();
    let xa = x * a;
    let xb = x * b;
    let bxas = b.transpose() * &xa + red.s.transpose(); // BᵀXA + Sᵀ
    let k = if m == 0 {
        Mat::zeros(0, n)
    } else {
        let rbxb = symmetrize((r + b.transpose() * &xb).as_ref());
        let lu = rbxb.full_piv_lu();
        let (umin, umax) = pivot_extremes(lu.U());
        if !(umin > 1e2 * f64::EPSILON * umax) {
            return Err(LinalgError::NoSolution("dare: R + BᵀXB is singular".into()));
        }
        lu.solve(&bxas)
    };
    let axa = a.transpose() * &xa;
    let res = &axa - x - bxas.transpose() * &k + q;
    let denom =
        fro_norm(axa.as_ref()) + fro_norm(x.as_ref()) + fro_norm(bxas.as_ref()) * fro_norm(k.as_ref()) + fro_norm(q);
    let residual = if denom > 0.0 {
        fro_norm(res.as_ref()) / denom
    } else {
        fro_norm(res.as_ref())
    };
    Ok((k, residual))
}

/// Relative residual of a candidate DARE solution `x`: ‖AᵀXA − X − (AᵀXB + S)(R + BᵀXB)⁻¹(BᵀXA + Sᵀ)
/// + Q‖_F divided by the sum of the Frobenius norms of the four terms.
pub fn dare_residual(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    r: MatRef<f64>,
    s: Option<MatRef<f64>>,
    x: MatRef<f64>,
) -> Result<f64> {
    let red = reduce(a, b, q, r, s, "dare_residual")?;
    if x.nrows() != a.nrows() || x.ncols() != a.nrows() {
        return Err(LinalgError::Dimension(format!(
            "dare_residual: X is {}x{}",
            x.nrows(),
            x.ncols()
        )));
    }
    Ok(dare_gain_residual(a, b, q, r, &red, x)?.1)
}

fn dare_finish(
    a: MatRef<f64>,
    b: MatRef<f64>,
    q: MatRef<f64>,
    r: MatRef<f64>,
    red: &Reduced,
    x: Mat<f64>,
    opts: &RiccatiOptions,
) -> Result<RiccatiSolution> {
    let (k, residual) = dare_gain_residual(a, b, q, r, red, x.as_ref())?;
    let acl = a - b * &k;
    let eigs = eigenvalues(acl.as_ref())?;
    if let Some(z) = eigs.iter().find(|z| !(z.norm() < 1.0 - opts.axis_tol)) {
        return Err(LinalgError::NoSolution(format!(
            "dare: the solution is not stabilizing (closed-loop eigenvalue {z}, |λ| = {:.6}); \
             no stabilizing solution",
            z.norm()
        )));
    }
    Ok(RiccatiSolution {
        x,
        k,
        closed_loop_eigs: eigs,
        residual,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `A = diag(1, 2)`, `B = Q = R = I`: per state `2aₖx − x² + 1 = 0`, `x = aₖ ± √(aₖ² + 1)`.
    fn diagonal_problem() -> (Mat<f64>, Mat<f64>, Mat<f64>, Mat<f64>) {
        let a = Mat::from_fn(2, 2, |i, j| if i == j { (i + 1) as f64 } else { 0.0 });
        (a, Mat::identity(2, 2), Mat::identity(2, 2), Mat::identity(2, 2))
    }

    /// The certificate for a candidate `x`, with its gain and closed loop formed as the solver does.
    fn certifies(a: &Mat<f64>, b: &Mat<f64>, q: &Mat<f64>, red: &Reduced, x: &Mat<f64>) -> bool {
        let (k, _) = care_gain_residual(a.as_ref(), b.as_ref(), q.as_ref(), red, x.as_ref());
        let acl = a - b * &k;
        lyapunov_certificate(
            a.as_ref(),
            b.as_ref(),
            q.as_ref(),
            red,
            x.as_ref(),
            k.as_ref(),
            acl.as_ref(),
        )
    }

    fn sorted_re(mut v: Vec<c64>) -> Vec<f64> {
        v.sort_by(|x, y| x.re.total_cmp(&y.re));
        v.iter().map(|z| z.re).collect()
    }

    #[test]
    fn cayley_start_has_the_care_solution_as_its_fixed_point() {
        // A = diag(1, 2) with a coupling, G = Q = I: the stabilizing X (from the Schur method) must
        // satisfy X = H₀ + E₀ᵀX(I + G₀X)⁻¹E₀, and doubling from the start must reach it.
        let a = Mat::from_fn(3, 3, |i, j| [[1.0, 0.5, 0.0], [0.0, 2.0, -1.0], [0.3, 0.0, -4.0]][i][j]);
        let eye = Mat::<f64>::identity(3, 3);
        let opts = RiccatiOptions {
            care_method: CareMethod::Schur,
            ..Default::default()
        };
        let x = care_with(a.as_ref(), eye.as_ref(), eye.as_ref(), eye.as_ref(), None, &opts)
            .unwrap()
            .x;
        let (e0, g0, h0) = cayley_start(a.as_ref(), eye.as_ref(), eye.as_ref()).unwrap();
        let w = &eye + &g0 * &x;
        let fixed = &h0 + e0.transpose() * &x * w.full_piv_lu().solve(&e0);
        let scale = fro_norm(x.as_ref());
        assert!(fro_norm((&fixed - &x).as_ref()) < 1e-14 * scale, "{fixed:?} vs {x:?}");
        let xd = care_doubling(a.as_ref(), eye.as_ref(), eye.as_ref(), 50).unwrap();
        assert!(fro_norm((&xd - &x).as_ref()) < 1e-14 * scale);
    }

    #[test]
    fn certificate_accepts_the_stabilizing_solution() {
        let (a, b, q, r) = diagonal_problem();
        let red = reduce(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None, "test").unwrap();
        let root = |ak: f64| (ak * ak + 1.0).sqrt();
        let x = Mat::from_fn(2, 2, |i, j| {
            if i == j {
                (i + 1) as f64 + root((i + 1) as f64)
            } else {
                0.0
            }
        });
        assert!(certifies(&a, &b, &q, &red, &x));
        // The closed loop is diag(−√2, −√5): the solver's result reports the same spectrum.
        let sol = care(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None).unwrap();
        let got = sorted_re(sol.closed_loop_eigs);
        let want = [-5f64.sqrt(), -2f64.sqrt()];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-14, "{got:?}");
        }
    }

    #[test]
    fn anti_stabilizing_claim_is_caught_by_the_eigenvalue_fallback() {
        // The anti-stabilizing solution x = aₖ − √(aₖ² + 1) < 0, handed over with a (false) claim
        // of stable Hamiltonian eigenvalues: the certificate does not apply (X is not positive
        // definite), the eigenvalues of A − BK (+√2, +√5) are computed, and the claim is refused.
        let (a, b, q, r) = diagonal_problem();
        let red = reduce(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None, "test").unwrap();
        let x = Mat::from_fn(2, 2, |i, j| {
            let ak = (i + 1) as f64;
            if i == j {
                ak - (ak * ak + 1.0).sqrt()
            } else {
                0.0
            }
        });
        let (_, residual) = care_gain_residual(a.as_ref(), b.as_ref(), q.as_ref(), &red, x.as_ref());
        assert!(residual < 1e-15, "it does solve the CARE: {residual}");
        assert!(!certifies(&a, &b, &q, &red, &x));
        let claim = vec![c64::new(-2f64.sqrt(), 0.0), c64::new(-5f64.sqrt(), 0.0)];
        let e = care_finish(a.as_ref(), b.as_ref(), q.as_ref(), &red, x, Some(claim)).unwrap_err();
        assert!(matches!(e, LinalgError::NoSolution(_)), "{e}");
    }

    #[test]
    fn singular_weight_falls_back_to_the_eigenvalues() {
        // Q = 0 and a stable A: X = 0 (not positive definite, so no certificate); the closed loop
        // is A itself, and its eigenvalues are computed.
        let a = Mat::from_fn(2, 2, |i, j| [[-1.0, 3.0], [0.0, -2.0]][i][j]);
        let (b, q, r) = (Mat::identity(2, 2), Mat::zeros(2, 2), Mat::identity(2, 2));
        let sol = care(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None).unwrap();
        assert!(fro_norm(sol.x.as_ref()) < 1e-14);
        let got = sorted_re(sol.closed_loop_eigs);
        assert!((got[0] + 2.0).abs() < 1e-14 && (got[1] + 1.0).abs() < 1e-14, "{got:?}");
    }

    #[test]
    fn fro_norm_matches_faer_and_survives_extreme_scales() {
        let m = Mat::from_fn(7, 5, |i, j| (i as f64 - 3.0) * 0.37 + j as f64 * 1.1);
        let want = m.norm_l2();
        assert!((fro_norm(m.as_ref()) - want).abs() <= 4.0 * f64::EPSILON * want);
        for s in [1e-200, 1e200] {
            let ms = &m * s;
            let got = fro_norm(ms.as_ref());
            assert!((got - want * s).abs() <= 8.0 * f64::EPSILON * want * s, "{s}: {got}");
        }
        assert_eq!(fro_norm(Mat::<f64>::zeros(3, 3).as_ref()), 0.0);
        // A strided view (rows of a transposed matrix) takes the entry-wise path.
        let t = m.transpose();
        assert!((fro_norm(t) - want).abs() <= 4.0 * f64::EPSILON * want);
    }
}
