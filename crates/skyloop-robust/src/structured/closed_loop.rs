//! The closed loop lft(P, K) of a generalized plant and a tunable controller, and the first-order
//! sensitivity of its spectral abscissa and H∞ norm to the controller's realization.
//!
//! Every derivative here has the same form: Re(a·dD·r + a·dC·x + b·dA·x + b·dB·r) for complex
//! vectors (a, b, x, r) computed once per evaluation ([`KSens`]), so the gradient with respect to any
//! block parameter is a contraction with that parameter's d(A, B, C, D) (see [`super::blocks`]).
//!
//! - H∞ norm (Apkarian & Noll 2006, "Nonsmooth H∞ synthesis"): at the peak frequency ω₀ with
//!   singular vectors (u, v) of T(jω₀), dσ = Re(uᴴ·P12·(I − K·P22)⁻¹·dK(jω₀)·(I − P22·K)⁻¹·P21·v)
//!   and dK(s) = dD + dC·X + Y·dA·X + Y·dB with X = (sI − A_K)⁻¹B_K, Y = C_K(sI − A_K)⁻¹.
//! - Spectral abscissa (Burke, Lewis & Overton; HIFOO's stabilization phase): for the rightmost
//!   eigenvalue λ with right and left eigenvectors v, y, dλ = yᵀ·dA_cl·v / (yᵀv); dA_cl expanded
//!   through the loop equations collapses to the same contraction with a = y₁ᵀB2·M + y₂ᵀB_K·D22·M,
//!   r = N·C2·v₁ + D22·M·C_K·v₂, b = y₂ᵀ, x = v₂ (M = (I − D_K·D22)⁻¹, N = (I − D22·D_K)⁻¹).

use super::blocks::RealizationGrad;
use crate::error::{Result, RobustError};
use faer::linalg::solvers::Solve;
use faer::{c64, Mat};
use skyloop_lti::freqresp::FreqEvaluator;
use skyloop_lti::StateSpace;

/// A generalized plant [z; y] = P·[w; u] split for the loop u = K·y (last `nmeas` outputs and
/// last `ncon` inputs, as hinfsyn), delay free.
#[derive(Debug, Clone)]
pub struct GenPlant {
    /// The plant.
    pub p: StateSpace,
    /// Number of measurements y.
    pub nmeas: usize,
    /// Number of controls u.
    pub ncon: usize,
    ev: FreqEvaluator,
}

/// A closed loop's A and its classified poles, from [`GenPlant::spectral_abscissa_poles`].
#[derive(Debug, Clone)]
pub struct LoopPoles {
    a: Mat<f64>,
    summary: skyloop_lti::freqresp::PoleSummary,
}

/// The contraction vectors of one derivative (see the module documentation).
#[derive(Debug, Clone)]
pub struct KSens {
    a: Vec<c64>,
    b: Vec<c64>,
    x: Vec<c64>,
    r: Vec<c64>,
}

impl KSens {
    /// a·dD·r + a·dC·x + b·dA·x + b·dB·r for one parameter's d(A, B, C, D).
    pub fn apply(&self, g: &RealizationGrad) -> c64 {
        let bil = |l: &[c64], m: &Mat<f64>, r: &[c64]| {
            let mut s = c64::new(0.0, 0.0);
            for i in 0..m.nrows() {
                let mut t = c64::new(0.0, 0.0);
                for j in 0..m.ncols() {
                    if m[(i, j)] != 0.0 {
                        t += r[j] * m[(i, j)];
                    }
                }
                s += l[i] * t;
            }
            s
        };
        bil(&self.a, &g.d, &self.r)
            + bil(&self.a, &g.c, &self.x)
            + bil(&self.b, &g.a, &self.x)
            + bil(&self.b, &g.b, &self.r)
    }
}

fn cmat(m: &Mat<f64>) -> Mat<c64> {
    Mat::from_fn(m.nrows(), m.ncols(), |i, j| c64::new(m[(i, j)], 0.0))
}

fn cinv(m: &Mat<c64>, what: &str) -> Result<Mat<c64>> {
    let n = m.nrows();
    let x = m.partial_piv_lu().solve(Mat::<c64>::identity(n, n));
    if x.norm_max().is_finite() {
        Ok(x)
    } else {
        Err(RobustError::Numerical(format!("{what} is singular")))
    }
}

fn rinv(m: &Mat<f64>, what: &str) -> Result<Mat<f64>> {
    let n = m.nrows();
    let x = m.partial_piv_lu().solve(Mat::<f64>::identity(n, n));
    if x.norm_max().is_finite() && x.norm_max() < 1e14 {
        Ok(x)
    } else {
        Err(RobustError::Numerical(format!("{what} is singular (ill-posed loop)")))
    }
}

/// K(s), X = (sI − A_K)⁻¹B_K and Y = C_K(sI − A_K)⁻¹ (s = ∞ gives K = D_K, X = Y = 0).
pub(crate) fn k_at(k: &StateSpace, s: Option<c64>) -> Result<(Mat<c64>, Mat<c64>, Mat<c64>)> {
    let n = k.nx();
    let dk = cmat(&k.d);
    let Some(s) = s.filter(|_| n > 0) else {
        return Ok((dk, Mat::zeros(n, k.nu()), Mat::zeros(k.ny(), n)));
    };
    let si_a = Mat::from_fn(n, n, |i, j| if i == j { s } else { c64::new(0.0, 0.0) } - k.a[(i, j)]);
    let r = cinv(&si_a, "sI - A_K (s is a controller pole)")?;
    let x = &r * cmat(&k.b);
    let y = cmat(&k.c) * &r;
    let kv = &dk + cmat(&k.c) * &x;
    Ok((kv, x, y))
}

/// The sensitivity of K(s) itself (SISO): dK(s) = ks.apply(g).
pub(crate) fn k_sens_siso(k: &StateSpace, s: Option<c64>) -> Result<(c64, KSens)> {
    let (kv, x, y) = k_at(k, s)?;
    let one = vec![c64::new(1.0, 0.0)];
    Ok((
        kv[(0, 0)],
        KSens {
            a: one.clone(),
            b: (0..k.nx()).map(|j| y[(0, j)]).collect(),
            x: (0..k.nx()).map(|i| x[(i, 0)]).collect(),
            r: one,
        },
    ))
}

impl GenPlant {
    /// Splits `p` (delay free, continuous) for `nmeas` measurements and `ncon` controls.
    ///
    /// # Errors
    /// Delays, discrete time, or channel counts that leave no room (at least one of each).
    pub fn new(p: &StateSpace, nmeas: usize, ncon: usize) -> Result<Self> {
        p.validate()?;
        if p.has_delay() || p.dt != 0.0 {
            return Err(RobustError::Unsupported(
                "the generalized plant must be continuous and rational (replace delays by Padé approximants)".into(),
            ));
        }
        if nmeas == 0 || ncon == 0 || nmeas >= p.ny() || ncon >= p.nu() {
            return Err(RobustError::Dimension(format!(
                "nmeas must be in 1..={} and ncon in 1..={} for a generalized plant with {} outputs and {} inputs (it needs at least one performance output z and one disturbance input w besides the measurements and controls), got nmeas = {nmeas}, ncon = {ncon}",
                p.ny().saturating_sub(1),
                p.nu().saturating_sub(1),
                p.ny(),
                p.nu()
            )));
        }
        Ok(GenPlant {
            ev: FreqEvaluator::new(p)?,
            p: p.clone(),
            nmeas,
            ncon,
        })
    }

    fn sizes(&self) -> (usize, usize) {
        (self.p.ny() - self.nmeas, self.p.nu() - self.ncon)
    }

    fn check_k(&self, k: &StateSpace) -> Result<()> {
        if k.ny() != self.ncon || k.nu() != self.nmeas {
            return Err(RobustError::Dimension(format!(
                "the controller must be {}x{} (controls x measurements), got {}x{}",
                self.ncon,
                self.nmeas,
                k.ny(),
                k.nu()
            )));
        }
        Ok(())
    }

    /// (M, N) = ((I − D_K·D22)⁻¹, (I − D22·D_K)⁻¹).
    fn mn(&self, k: &StateSpace) -> Result<(Mat<f64>, Mat<f64>)> {
        let (p1, m1) = self.sizes();
        let d22 = self.p.d.get(p1.., m1..).to_owned();
        let m = rinv(
            &(Mat::<f64>::identity(self.ncon, self.ncon) - &k.d * &d22),
            "I - D_K D22",
        )?;
        let n = rinv(
            &(Mat::<f64>::identity(self.nmeas, self.nmeas) - &d22 * &k.d),
            "I - D22 D_K",
        )?;
        Ok((m, n))
    }

    /// The closed loop lft(P, K), states [x_P; x_K].
    ///
    /// # Errors
    /// A controller of the wrong size or an ill-posed loop (I − D_K·D22 singular).
    pub fn closed_loop(&self, k: &StateSpace) -> Result<StateSpace> {
        self.check_k(k)?;
        let (p1, m1) = self.sizes();
        let p = &self.p;
        let (n, nk) = (p.nx(), k.nx());
        let b1 = p.b.get(.., ..m1);
        let b2 = p.b.get(.., m1..);
        let c1 = p.c.get(..p1, ..);
        let c2 = p.c.get(p1.., ..);
        let d11 = p.d.get(..p1, ..m1);
        let d12 = p.d.get(..p1, m1..);
        let d21 = p.d.get(p1.., ..m1);
        let d22 = p.d.get(p1.., m1..);
        let (mm, nn) = self.mn(k)?;
        let mdk = &mm * &k.d;
        let mck = &mm * &k.c;
        let mut a = Mat::zeros(n + nk, n + nk);
        a.get_mut(..n, ..n).copy_from(p.a.as_ref() + b2 * &mdk * c2);
        a.get_mut(..n, n..).copy_from(b2 * &mck);
        a.get_mut(n.., ..n).copy_from(&k.b * &nn * c2);
        a.get_mut(n.., n..).copy_from(&k.a + &k.b * d22 * &mck);
        let mut b = Mat::zeros(n + nk, m1);
        b.get_mut(..n, ..).copy_from(b1 + b2 * &mdk * d21);
        b.get_mut(n.., ..).copy_from(&k.b * &nn * d21);
        let mut c = Mat::zeros(p1, n + nk);
        c.get_mut(.., ..n).copy_from(c1 + d12 * &mdk * c2);
        c.get_mut(.., n..).copy_from(d12 * &mck);
        let d = d11 + d12 * &mdk * d21;
        Ok(StateSpace::new(a, b, c, d, 0.0)?)
    }

    /// Spectral abscissa max Re λ(A_cl) and its gradient with respect to the parameters whose
    /// realization derivatives are `dk` (the gradient of the rightmost eigenvalue's real part).
    ///
    /// # Errors
    /// As [`GenPlant::closed_loop`], or an eigenvalue computation that does not converge.
    pub fn spectral_abscissa(&self, k: &StateSpace, dk: &[RealizationGrad]) -> Result<(f64, Vec<f64>)> {
        self.spectral_abscissa_poles(k, dk).map(|(a, g, _)| (a, g))
    }

    /// [`GenPlant::spectral_abscissa`], also returning the closed loop's A and classified poles
    /// for [`GenPlant::hinf_known`] on another channel of the same loop.
    ///
    /// # Errors
    /// As [`GenPlant::spectral_abscissa`].
    pub fn spectral_abscissa_poles(
        &self,
        k: &StateSpace,
        dk: &[RealizationGrad],
    ) -> Result<(f64, Vec<f64>, LoopPoles)> {
        let cl = self.closed_loop(k)?;
        let summary = skyloop_lti::freqresp::pole_summary(&cl)
            .map_err(|e| RobustError::Numerical(format!("closed-loop eigenvalues: {e}")))?;
        let (a, g) = self.abscissa_gradient(k, dk, &cl, &summary.poles)?;
        Ok((a, g, LoopPoles { a: cl.a, summary }))
    }

    /// The abscissa and its gradient from the closed loop `cl` and its eigenvalues `lam`.
    fn abscissa_gradient(
        &self,
        k: &StateSpace,
        dk: &[RealizationGrad],
        cl: &StateSpace,
        lam: &[c64],
    ) -> Result<(f64, Vec<f64>)> {
        if cl.nx() == 0 {
            return Ok((f64::NEG_INFINITY, vec![0.0; dk.len()]));
        }
        let imax = (0..lam.len())
            .max_by(|&i, &j| lam[i].re.total_cmp(&lam[j].re).then(lam[i].im.total_cmp(&lam[j].im)))
            .unwrap_or(0);
        let l0 = lam[imax];
        let (v, y) = match eigenvectors_by_inverse_iteration(&cl.a, l0) {
            Some(vy) => vy,
            None => eigenvectors_by_qr(&cl.a, l0)?,
        };
        let ytv: c64 = y.iter().zip(&v).map(|(a, b)| a * b).sum();
        if ytv.norm() < 1e-12 {
            // A defective eigenvalue has no derivative; report the value with a zero gradient
            // (the line search then treats the point as a kink).
            return Ok((l0.re, vec![0.0; dk.len()]));
        }
        let (p1, m1) = self.sizes();
        let _ = p1;
        let n = self.p.nx();
        let b2 = cmat(&self.p.b.get(.., m1..).to_owned());
        let c2 = cmat(&self.p.c.get(self.p.ny() - self.nmeas.., ..).to_owned());
        let d22 = cmat(&self.p.d.get(self.p.ny() - self.nmeas.., m1..).to_owned());
        let (mm, nn) = self.mn(k)?;
        let (mm, nn) = (cmat(&mm), cmat(&nn));
        let (bk, ck) = (cmat(&k.b), cmat(&k.c));
        let y1 = Mat::from_fn(1, n, |_, j| y[j]);
        let y2 = Mat::from_fn(1, k.nx(), |_, j| y[n + j]);
        let v1 = Mat::from_fn(n, 1, |i, _| v[i]);
        let v2 = Mat::from_fn(k.nx(), 1, |i, _| v[n + i]);
        let a = &y1 * &b2 * &mm + &y2 * &bk * &d22 * &mm;
        let r = &nn * &c2 * &v1 + &d22 * &mm * &ck * &v2;
        let ks = KSens {
            a: (0..a.ncols()).map(|j| a[(0, j)]).collect(),
            b: (0..y2.ncols()).map(|j| y2[(0, j)]).collect(),
            x: (0..v2.nrows()).map(|i| v2[(i, 0)]).collect(),
            r: (0..r.nrows()).map(|i| r[(i, 0)]).collect(),
        };
        Ok((l0.re, dk.iter().map(|g| (ks.apply(g) / ytv).re).collect()))
    }

    /// ‖lft(P, K)‖∞ (infinite when the closed loop is unstable), its peak frequency (rad/s, may be
    /// infinite) and the gradient with respect to the parameters whose realization derivatives
    /// are `dk` (empty gradient when unstable).
    ///
    /// # Errors
    /// As [`GenPlant::closed_loop`], or a failure of the H∞ norm computation.
    pub fn hinf(&self, k: &StateSpace, dk: &[RealizationGrad]) -> Result<(f64, f64, Vec<f64>)> {
        self.hinf_known(k, dk, None)
    }

    /// [`GenPlant::hinf`], reusing `known` poles when they were computed on the same closed-loop
    /// A (bit for bit: channels of one loop without weights share it); otherwise as `hinf`.
    ///
    /// # Errors
    /// As [`GenPlant::hinf`].
    pub fn hinf_known(
        &self,
        k: &StateSpace,
        dk: &[RealizationGrad],
        known: Option<&LoopPoles>,
    ) -> Result<(f64, f64, Vec<f64>)> {
        let cl = self.closed_loop(k)?;
        let (gamma, w) = match known {
            Some(lp) if lp.a == cl.a => skyloop_lti::norms::hinf_norm_with_poles(&cl, &lp.summary)?,
            _ => skyloop_lti::norms::hinf_norm(&cl)?,
        };
        if !gamma.is_finite() {
            return Ok((f64::INFINITY, f64::NAN, Vec::new()));
        }
        let s = if w.is_finite() && w < 1e12 {
            Some(c64::new(0.0, w))
        } else {
            None
        };
        let pj = match s {
            Some(s) => self.ev.eval(s)?,
            None => cmat(&self.p.d),
        };
        let (p1, m1) = self.sizes();
        let p11 = pj.get(..p1, ..m1).to_owned();
        let p12 = pj.get(..p1, m1..).to_owned();
        let p21 = pj.get(p1.., ..m1).to_owned();
        let p22 = pj.get(p1.., m1..).to_owned();
        let (kv, x, y) = k_at(k, s)?;
        let left = cinv(&(Mat::<c64>::identity(self.ncon, self.ncon) - &kv * &p22), "I - K P22")?;
        let right = cinv(
            &(Mat::<c64>::identity(self.nmeas, self.nmeas) - &p22 * &kv),
            "I - P22 K",
        )?;
        let t = &p11 + &p12 * &kv * &right * &p21;
        let svd = t
            .svd()
            .map_err(|_| RobustError::Numerical("SVD of the closed loop at its peak did not converge".into()))?;
        let u = svd.U().col(0).to_owned();
        let v = svd.V().col(0).to_owned();
        let uh = Mat::from_fn(1, p1, |_, j| u[j].conj());
        let vm = Mat::from_fn(m1, 1, |i, _| v[i]);
        let a = &uh * &p12 * &left;
        let r = &right * &p21 * &vm;
        let b = &a * &y;
        let xr = &x * &r;
        let ks = KSens {
            a: (0..a.ncols()).map(|j| a[(0, j)]).collect(),
            b: (0..b.ncols()).map(|j| b[(0, j)]).collect(),
            x: (0..xr.nrows()).map(|i| xr[(i, 0)]).collect(),
            r: (0..r.nrows()).map(|i| r[(i, 0)]).collect(),
        };
        Ok((gamma, w, dk.iter().map(|g| ks.apply(g).re).collect()))
    }
}

/// Right and left eigenvectors (v, y: A·v = λv, Aᵀ·y = λy) of `a` for its computed eigenvalue
/// `lam`, by two steps of inverse iteration with one complex LU of A − λ̃I, λ̃ = λ + δ(1 + i)
/// (δ = 1e-10·(‖A‖_F + |λ|), so the pivots stay finite). None when a step leaves a non-finite
/// vector or a residual ‖(A − λI)v‖ above 1e-8·(‖A‖_F + |λ|).
///
/// Why: the two full eigendecompositions this replaces (faer's, with every eigenvector of A and
/// of Aᵀ) were a fifth of a PID tuning run (`examples/time_tune.rs`); only the rightmost pair is
/// needed. The error of an inverse-iteration vector after k steps is (δ/gap)^k relative, far
/// below the QR vectors' ε·κ whenever the eigenvalue is not within 1e-5 of another.
fn eigenvectors_by_inverse_iteration(a: &Mat<f64>, lam: c64) -> Option<(Vec<c64>, Vec<c64>)> {
    let n = a.nrows();
    let scale = skyloop_linalg::fro_norm(a.as_ref()) + lam.norm();
    let delta = 1e-10 * scale.max(f64::MIN_POSITIVE);
    let shifted = lam + c64::new(delta, delta);
    let m = Mat::<c64>::from_fn(n, n, |i, j| {
        c64::new(a[(i, j)], 0.0) - if i == j { shifted } else { c64::new(0.0, 0.0) }
    });
    let lu = m.partial_piv_lu();
    // A start with every component nonzero and no special direction.
    let start = || Mat::<c64>::from_fn(n, 1, |i, _| c64::new(1.0 + 0.37 * i as f64, 0.5 - 0.11 * i as f64));
    let normalize = |x: &mut Mat<c64>| -> Option<()> {
        let nrm = (0..n).map(|i| x[(i, 0)].norm_sqr()).sum::<f64>().sqrt();
        if !nrm.is_finite() || nrm == 0.0 {
            return None;
        }
        (0..n).for_each(|i| x[(i, 0)] /= nrm);
        Some(())
    };
    let mut v = start();
    let mut y = start();
    for _ in 0..2 {
        lu.solve_in_place(v.as_mut());
        normalize(&mut v)?;
        lu.solve_transpose_in_place(y.as_mut());
        normalize(&mut y)?;
    }
    let residual = |x: &Mat<c64>, transpose: bool| -> f64 {
        (0..n)
            .map(|i| {
                let mut s = -lam * x[(i, 0)];
                for j in 0..n {
                    s += x[(j, 0)] * if transpose { a[(j, i)] } else { a[(i, j)] };
                }
                s.norm_sqr()
            })
            .sum::<f64>()
            .sqrt()
    };
    let tol = 1e-8 * scale;
    if residual(&v, false) > tol || residual(&y, true) > tol {
        return None;
    }
    Some(((0..n).map(|i| v[(i, 0)]).collect(), (0..n).map(|i| y[(i, 0)]).collect()))
}

/// Right and left eigenvectors of `a` for the eigenvalue nearest `lam`, from full
/// eigendecompositions of A and Aᵀ (the fallback of [`eigenvectors_by_inverse_iteration`]).
fn eigenvectors_by_qr(a: &Mat<f64>, lam: c64) -> Result<(Vec<c64>, Vec<c64>)> {
    let n = a.nrows();
    let nearest = |m: &Mat<f64>| -> Result<Vec<c64>> {
        let e = m
            .eigen()
            .map_err(|_| RobustError::Numerical("closed-loop eigenvalues did not converge".into()))?;
        let s = e.S().column_vector();
        let j = (0..n)
            .min_by(|&i, &j| (s[i] - lam).norm().total_cmp(&(s[j] - lam).norm()))
            .unwrap_or(0);
        Ok((0..n).map(|i| e.U()[(i, j)]).collect())
    };
    Ok((nearest(a)?, nearest(&a.transpose().to_owned())?))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::super::blocks::{Block, DerivativeFilter, Structure};
    use super::*;
    use skyloop_lti::expr::parse_model;

    fn plant() -> GenPlant {
        // S-weighted loop around G = 1/((s+1)(0.2s+1)) with a control weight: [W1 S; W3 K S].
        let g = parse_model("1/((s+1)*(0.2*s+1))").unwrap();
        let w1 = parse_model("(0.5*s+1)/(s+0.1)").unwrap();
        let w3 = parse_model("0.1").unwrap();
        let p = crate::mixsyn::augw(&g, Some(&w1), None, Some(&w3)).unwrap();
        GenPlant::new(&p, 1, 1).unwrap()
    }

    #[test]
    fn closed_loop_matches_lti_lft() {
        let p = plant();
        let s = Structure::new(Block::Pid(DerivativeFilter::Tuned));
        let k = s.realize(&[2.0, 1.0, 0.3, (0.02f64).ln()]).unwrap();
        let ours = p.closed_loop(&k).unwrap();
        let theirs = skyloop_lti::interconnect::lft_lower(&p.p, &k).unwrap();
        let (n1, _) = skyloop_lti::norms::hinf_norm(&ours).unwrap();
        let (n2, _) = skyloop_lti::norms::hinf_norm(&theirs).unwrap();
        assert!((n1 - n2).abs() < 1e-9 * n2, "{n1} vs {n2}");
    }

    #[test]
    fn inverse_iteration_vectors_match_the_full_decomposition() {
        // A non-normal 12 × 12 matrix with a complex rightmost pair and a real cluster.
        let a = Mat::<f64>::from_fn(12, 12, |i, j| {
            let x = ((i * 31 + j * 17 + 7) % 23) as f64 / 23.0 - 0.5;
            if i == j {
                -(i as f64) - 0.5 + x
            } else if j > i {
                3.0 * x
            } else {
                0.4 * x
            }
        });
        let lam = skyloop_lti::freqresp::balanced_eigenvalues(&a).unwrap();
        let l0 = *lam.iter().max_by(|p, q| p.re.total_cmp(&q.re)).unwrap();
        let (v, y) = eigenvectors_by_inverse_iteration(&a, l0).unwrap();
        let (vq, yq) = eigenvectors_by_qr(&a, l0).unwrap();
        let cos = |x: &[c64], z: &[c64]| {
            let d: c64 = x.iter().zip(z).map(|(p, q)| p.conj() * q).sum();
            let n = |w: &[c64]| w.iter().map(|t| t.norm_sqr()).sum::<f64>().sqrt();
            d.norm() / (n(x) * n(z))
        };
        assert!((1.0 - cos(&v, &vq)).abs() < 1e-10, "right: {}", cos(&v, &vq));
        assert!((1.0 - cos(&y, &yq)).abs() < 1e-10, "left: {}", cos(&y, &yq));
    }

    #[test]
    fn gradients_match_finite_differences() {
        let p = plant();
        let s = Structure::new(Block::Pid(DerivativeFilter::Tuned));
        let th = [2.0, 1.0, 0.3, (0.02f64).ln()];
        let k = s.realize(&th).unwrap();
        let dk = s.realize_grad(&th).unwrap();
        let (g0, _, grad) = p.hinf(&k, &dk).unwrap();
        let (a0, agrad) = p.spectral_abscissa(&k, &dk).unwrap();
        assert!(g0.is_finite() && a0 < 0.0);
        for i in 0..th.len() {
            let h = 1e-6;
            let (mut tp, mut tm) = (th, th);
            tp[i] += h;
            tm[i] -= h;
            let f = |t: &[f64]| p.hinf(&s.realize(t).unwrap(), &[]).unwrap().0;
            let fd = (f(&tp) - f(&tm)) / (2.0 * h);
            assert!(
                (fd - grad[i]).abs() < 1e-4 * (1.0 + fd.abs()),
                "hinf param {i}: fd {fd} vs {}",
                grad[i]
            );
            let sa = |t: &[f64]| p.spectral_abscissa(&s.realize(t).unwrap(), &[]).unwrap().0;
            let fd = (sa(&tp) - sa(&tm)) / (2.0 * h);
            assert!(
                (fd - agrad[i]).abs() < 1e-4 * (1.0 + fd.abs()),
                "abscissa param {i}: fd {fd} vs {}",
                agrad[i]
            );
        }
    }
}
