//! H∞ output-feedback synthesis with MATLAB conventions: the last `nmeas` outputs of P are the
//! measurements y, the last `ncon` inputs are the controls u, the controller closes u = K·y and the
//! closed loop is lft(P, K).
//!
//! Method (Glover & Doyle 1988; Zhou, Doyle & Glover, *Robust and Optimal Control*, ch. 17;
//! Safonov, Limebeer & Chiang 1989 for the loop shifting):
//! 1. D22 is removed by loop shifting (design for D22 = 0, then K = K0·(I + D22·K0)⁻¹).
//! 2. D12 and D21 are brought to [0; I] and [0 I] by orthogonal output/disturbance rotations and
//!    invertible control/measurement scalings (SVDs); the H∞ norm is unchanged.
//! 3. γ is bisected on the two-Riccati test: X∞ and Y∞ stabilizing and ≥ 0, ρ(X∞Y∞) < γ², with
//!    the general-D11 Riccati equations (indefinite R) and the D11 condition of ZDG Thm 17.1.
//! 4. The central controller of ZDG §17.2 is built slightly above the bisection's γ (its Z factor
//!    is singular at γ_opt), and the closed loop is verified: stable and ‖lft(P,K)‖∞ ≤ γ·(1+1e-3);
//!    otherwise γ is raised until it is.
//!
//! Discrete-time plants go through the bilinear map (`skyloop_lti::discretize` Tustin d2c/c2d),
//! which preserves stability and the H∞ norm.

use crate::error::Result;
use crate::error::RobustError;
use crate::matrix_ops::{
    balance_states, hcat, inv, max_real_eig, sigma_max, spectral_radius, sym_min_eig, uncontrollable_unstable_mode,
    vcat,
};
use faer::{Mat, MatRef, Side};
use skyloop_linalg::riccati::{care_with, CareMethod, RiccatiOptions};
use skyloop_lti::discretize::{c2d, d2c, Method};
use skyloop_lti::StateSpace;

/// Options of the γ iteration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HinfOptions {
    /// Search range for γ (lower, upper); an infinite upper bound means "find one by doubling".
    /// A finite upper bound is hard: the returned γ never exceeds it, and when no verified
    /// controller exists at or below it the synthesis fails with [`RobustError::Infeasible`].
    pub gamma_range: (f64, f64),
    /// Relative tolerance of the bisection on γ.
    pub rel_tol: f64,
}

impl Default for HinfOptions {
    fn default() -> Self {
        HinfOptions {
            gamma_range: (0.0, f64::INFINITY),
            rel_tol: 1e-4,
        }
    }
}

/// The result of [`hinfsyn`].
#[derive(Debug, Clone)]
pub struct HinfSolution {
    /// Controller for u = K·y (ncon outputs, nmeas inputs), same sample time as the plant.
    pub controller: StateSpace,
    /// Performance level the controller was built for; the closed loop is verified to satisfy
    /// ‖lft(P,K)‖∞ ≤ `gamma`·(1 + 1e-3).
    pub gamma: f64,
    /// Largest γ the bisection found infeasible (a lower bound on the optimal γ).
    pub gamma_lower: f64,
    /// Achieved closed-loop H∞ norm ‖lft(P,K)‖∞.
    pub closed_loop_norm: f64,
    /// The closed loop lft(P, K).
    pub closed_loop: StateSpace,
}

/// H∞ synthesis with default options (γ range (0, ∞), relative tolerance 1e-4).
///
/// # Errors
/// Too few inputs or outputs for `nmeas`/`ncon`, D₁₂ or D₂₁ without full rank, an unstabilizable or undetectable plant, or no γ in range with a verified controller.
///
/// # Examples
/// ```
/// use skyloop_lti::expr::parse_model;
/// use skyloop_robust::{hinfsyn::hinfsyn, mixsyn::augw};
/// let g = parse_model("10/(s+1)")?;
/// let p = augw(&g, Some(&parse_model("(0.5*s+2)/(s+0.02)")?), Some(&parse_model("0.1")?), None)?;
/// let sol = hinfsyn(&p, 1, 1)?;
/// let cl = skyloop_lti::interconnect::lft_lower(&p, &sol.controller)?;
/// let (norm, _) = skyloop_lti::norms::hinf_norm(&cl)?;
/// assert!(norm <= sol.gamma * (1.0 + 1e-6));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn hinfsyn(p: &StateSpace, nmeas: usize, ncon: usize) -> Result<HinfSolution> {
    hinfsyn_with(p, nmeas, ncon, &HinfOptions::default())
}

/// H∞ synthesis: finds (nearly) the smallest γ and a stabilizing K with ‖lft(P,K)‖∞ ≤ γ.
///
/// Errors name the cause: [`RobustError::RankDeficient`] for a singular D12/D21,
/// [`RobustError::NotStabilizable`] / [`RobustError::NotDetectable`] with the offending mode, and
/// [`RobustError::Infeasible`] when no controller achieves γ ≤ the upper end of the range (or any
/// γ up to 1e12, or no verified controller could be built near the γ the bisection found).
pub fn hinfsyn_with(p: &StateSpace, nmeas: usize, ncon: usize, opts: &HinfOptions) -> Result<HinfSolution> {
    p.validate()?;
    if p.has_delay() {
        return Err(RobustError::Unsupported(
            "hinfsyn needs a rational plant: replace the delays by Padé approximants first".into(),
        ));
    }
    let (lo_opt, hi_opt) = opts.gamma_range;
    if !(lo_opt >= 0.0 && hi_opt > lo_opt) || lo_opt.is_nan() || hi_opt.is_nan() {
        return Err(RobustError::InvalidArgument(format!(
            "gamma range must satisfy 0 <= min < max, got ({lo_opt}, {hi_opt})"
        )));
    }
    if !(opts.rel_tol > 0.0 && opts.rel_tol < 1.0) {
        return Err(RobustError::InvalidArgument(format!(
            "relative tolerance must be in (0, 1), got {}",
            opts.rel_tol
        )));
    }
    if p.dt > 0.0 {
        return hinfsyn_discrete(p, nmeas, ncon, opts);
    }
    let np = Normalized::new(&balance_states(p)?, nmeas, ncon)?;

    // γ must exceed the part of D11 no controller can touch (ZDG Thm 17.1).
    let mut lo = np.d11_bound()?.max(lo_opt);
    let mut last_fail = String::new();
    let mut hi = if hi_opt.is_finite() {
        if np.riccati_pair(hi_opt, &mut last_fail)?.is_none() {
            return Err(structural_cause(p, nmeas, ncon).unwrap_or(RobustError::Infeasible {
                gamma: hi_opt,
                reason: format!("upper end of the range: {last_fail}"),
            }));
        }
        hi_opt
    } else {
        let mut g = (2.0 * lo).max(1.0);
        loop {
            if np.riccati_pair(g, &mut last_fail)?.is_some() {
                break g;
            }
            lo = lo.max(g);
            g *= 4.0;
            if g > 1e12 {
                return Err(structural_cause(p, nmeas, ncon).unwrap_or(RobustError::Infeasible {
                    gamma: 1e12,
                    reason: format!("{last_fail}; P12 or P21 may have zeros on the imaginary axis"),
                }));
            }
        }
    };
    while hi - lo > opts.rel_tol * hi {
        let mid = if lo > 0.0 { (lo * hi).sqrt() } else { 0.5 * hi };
        if np.riccati_pair(mid, &mut last_fail)?.is_some() {
            hi = mid;
        } else {
            lo = mid;
        }
    }

    // The central controller's Z = (I − γ⁻²YX)⁻¹ is singular at γ_opt: back off a little, verify,
    // and back off more if the verified closed loop misses its γ — but never above a finite upper
    // end of the range, which is a hard bound.
    let mut backoff = 1e-3;
    let mut why = String::new();
    let mut tried = f64::NAN;
    for _ in 0..12 {
        let gamma = (hi * (1.0 + backoff)).min(hi_opt);
        if gamma == tried {
            break;
        }
        tried = gamma;
        if let Some(rp) = np.riccati_pair(gamma, &mut why)? {
            match np.controller(gamma, &rp) {
                Ok(k) => {
                    // Balanced: hinf_norm treats poles within 1e-7·‖A‖ of 0 as integrators.
                    let cl = balance_states(&skyloop_lti::interconnect::lft_lower(p, &k)?)?;
                    let stable = max_real_eig(cl.a.as_ref())? < 0.0;
                    if stable {
                        let (norm, _) = skyloop_lti::norms::hinf_norm(&cl)?;
                        if norm <= gamma * (1.0 + 1e-3) {
                            return Ok(HinfSolution {
                                controller: k,
                                gamma,
                                gamma_lower: lo,
                                closed_loop_norm: norm,
                                closed_loop: cl,
                            });
                        }
                        why = format!("closed-loop norm {norm:.6e} exceeds gamma {gamma:.6e}");
                    } else {
                        why = "closed loop is not stable".into();
                    }
                }
                Err(e) => why = e.to_string(),
            }
        }
        backoff *= 3.0;
    }
    Err(RobustError::Infeasible {
        gamma: tried,
        reason: format!("could not build a verified controller near gamma = {hi:.6e}: {why}"),
    })
}

/// Explains why no γ works when the cause is structural: an unstabilizable mode of (A, B2) or an
/// undetectable mode of (C2, A); `None` when both pairs pass the PBH test.
fn structural_cause(p: &StateSpace, nmeas: usize, ncon: usize) -> Option<RobustError> {
    let (p1, m1) = (p.ny() - nmeas, p.nu() - ncon);
    let b2 = p.b.get(.., m1..).to_owned();
    let at = p.a.transpose().to_owned();
    let c2t = p.c.get(p1.., ..).transpose().to_owned();
    if let Ok(Some(mode)) = uncontrollable_unstable_mode(p.a.as_ref(), b2.as_ref()) {
        return Some(RobustError::NotStabilizable {
            system: "(A, B2)",
            mode,
        });
    }
    if let Ok(Some(mode)) = uncontrollable_unstable_mode(at.as_ref(), c2t.as_ref()) {
        return Some(RobustError::NotDetectable {
            system: "(C2, A)",
            mode,
        });
    }
    None
}

/// Discrete-time synthesis through the bilinear (Tustin) map of skyloop-lti: it maps the unit disk
/// onto the left half plane and e^{jωT} onto j(2/T)·tan(ωT/2), so stability and the H∞ norm of
/// every closed loop are preserved; design on d2c(P), map the controller back with c2d.
fn hinfsyn_discrete(p: &StateSpace, nmeas: usize, ncon: usize, opts: &HinfOptions) -> Result<HinfSolution> {
    let tustin = Method::Tustin { prewarp_rad_s: None };
    let pc = d2c(p, tustin)?;
    let sol = hinfsyn_with(&pc, nmeas, ncon, opts)?;
    let k = c2d(&sol.controller, p.dt, tustin)?;
    let cl = skyloop_lti::interconnect::lft_lower(p, &k)?;
    Ok(HinfSolution {
        controller: k,
        closed_loop: cl,
        ..sol
    })
}

/// Solutions of the two H∞ Riccati equations at one γ.
struct RiccatiPair {
    x: Mat<f64>,
    y: Mat<f64>,
    /// F = −R⁻¹(D1•ᵀC1 + BᵀX), (m1 + m2) × n.
    f: Mat<f64>,
    /// L = −(B1D•1ᵀ + YCᵀ)R̃⁻¹, n × (p1 + p2).
    l: Mat<f64>,
}

/// The plant after loop shifting and scaling: D12 = [0; I], D21 = [0 I], plus the maps back.
struct Normalized {
    a: Mat<f64>,
    b1: Mat<f64>,
    b2: Mat<f64>,
    c1: Mat<f64>,
    c2: Mat<f64>,
    d11: Mat<f64>,
    d22: Mat<f64>,
    /// u = tu·ũ.
    tu: Mat<f64>,
    /// ỹ = ty·y.
    ty: Mat<f64>,
    m1: usize,
    m2: usize,
    p1: usize,
    p2: usize,
}

impl Normalized {
    fn new(p: &StateSpace, nmeas: usize, ncon: usize) -> Result<Self> {
        let (ny, nu) = (p.ny(), p.nu());
        if nmeas == 0 || ncon == 0 {
            return Err(RobustError::InvalidArgument("nmeas and ncon must be at least 1".into()));
        }
        if nmeas >= ny || ncon >= nu {
            return Err(RobustError::Dimension(format!(
                "the plant has {ny} outputs and {nu} inputs: nmeas = {nmeas} and ncon = {ncon} leave no \
                 performance outputs or disturbance inputs"
            )));
        }
        let (p2, m2) = (nmeas, ncon);
        let (p1, m1) = (ny - p2, nu - m2);
        let b1 = p.b.get(.., ..m1).to_owned();
        let b2 = p.b.get(.., m1..).to_owned();
        let c1 = p.c.get(..p1, ..).to_owned();
        let c2 = p.c.get(p1.., ..).to_owned();
        let d11 = p.d.get(..p1, ..m1).to_owned();
        let d12 = p.d.get(..p1, m1..).to_owned();
        let d21 = p.d.get(p1.., ..m1).to_owned();
        let d22 = p.d.get(p1.., m1..).to_owned();
        let scale = p.d.norm_max().max(p.b.norm_max()).max(p.c.norm_max()).max(1.0);

        if p1 < m2 {
            return Err(RobustError::Unsupported(format!(
                "D12 ({p1}x{m2}) cannot have full column rank: need at least as many performance outputs as controls"
            )));
        }
        if m1 < p2 {
            return Err(RobustError::Unsupported(format!(
                "D21 ({p2}x{m1}) cannot have full row rank: need at least as many disturbances as measurements"
            )));
        }
        let svd12 = d12
            .svd()
            .map_err(|_| RobustError::Numerical("SVD of D12 did not converge".into()))?;
        let s12: Vec<f64> = (0..m2).map(|i| svd12.S()[i]).collect();
        if s12[m2 - 1] <= 1e-10 * scale {
            return Err(RobustError::RankDeficient {
                matrix: "D12",
                sigma_min: s12[m2 - 1],
            });
        }
        let svd21 = d21
            .svd()
            .map_err(|_| RobustError::Numerical("SVD of D21 did not converge".into()))?;
        let s21: Vec<f64> = (0..p2).map(|i| svd21.S()[i]).collect();
        if s21[p2 - 1] <= 1e-10 * scale {
            return Err(RobustError::RankDeficient {
                matrix: "D21",
                sigma_min: s21[p2 - 1],
            });
        }
        // z̃ = Θᵀz with Θ = [U⊥ U1] puts the range of D12 last; u = V·S⁻¹·ũ makes that block I.
        let u12 = svd12.U();
        let theta = hcat(&[u12.get(.., m2..), u12.get(.., ..m2)], p1);
        let tu = Mat::from_fn(m2, m2, |i, j| svd12.V()[(i, j)] / s12[j]);
        // w = Φ·w̃ with Φ = [Ṽ⊥ Ṽ1]; ỹ = S⁻¹Ũᵀ·y makes D21 = [0 I].
        let v21 = svd21.V();
        let phi = hcat(&[v21.get(.., p2..), v21.get(.., ..p2)], m1);
        let ty = Mat::from_fn(p2, p2, |i, j| svd21.U()[(j, i)] / s21[i]);

        let tht = theta.transpose();
        Ok(Normalized {
            a: p.a.clone(),
            b1: &b1 * &phi,
            b2: &b2 * &tu,
            c1: tht * &c1,
            c2: &ty * &c2,
            d11: tht * &d11 * &phi,
            d22: &ty * &d22 * &tu,
            tu,
            ty,
            m1,
            m2,
            p1,
            p2,
        })
    }

    /// D11 blocks [D1111 D1112; D1121 D1122] with D1111 of size (p1−m2)×(m1−p2).
    fn d11_blocks(&self) -> [MatRef<'_, f64>; 4] {
        let (r, c) = (self.p1 - self.m2, self.m1 - self.p2);
        let d = self.d11.as_ref();
        [d.get(..r, ..c), d.get(..r, c..), d.get(r.., ..c), d.get(r.., c..)]
    }

    /// max(σ̄[D1111 D1112], σ̄[D1111; D1121]): no γ at or below this is achievable.
    fn d11_bound(&self) -> Result<f64> {
        let [d1111, d1112, d1121, _] = self.d11_blocks();
        let rows = hcat(&[d1111, d1112], d1111.nrows());
        let cols = vcat(&[d1111, d1121], d1111.ncols());
        Ok(sigma_max(rows.as_ref())?.max(sigma_max(cols.as_ref())?))
    }

    /// D1• = [D11 D12] and D•1 = [D11; D21] of the normalized plant.
    fn d1dot(&self) -> (Mat<f64>, Mat<f64>) {
        let (p1, m1, m2, p2) = (self.p1, self.m1, self.m2, self.p2);
        let mut d1 = Mat::zeros(p1, m1 + m2);
        d1.get_mut(.., ..m1).copy_from(&self.d11);
        for i in 0..m2 {
            d1[(p1 - m2 + i, m1 + i)] = 1.0;
        }
        let mut d2 = Mat::zeros(p1 + p2, m1);
        d2.get_mut(..p1, ..).copy_from(&self.d11);
        for i in 0..p2 {
            d2[(p1 + i, m1 - p2 + i)] = 1.0;
        }
        (d1, d2)
    }

    /// The two-Riccati test at γ: `Some` when γ is achievable, `None` (with the reason in `why`) if not.
    fn riccati_pair(&self, gamma: f64, why: &mut String) -> Result<Option<RiccatiPair>> {
        let (n, m1, p1) = (self.a.nrows(), self.m1, self.p1);
        let g2 = gamma * gamma;
        let (d1r, d1c) = self.d1dot();
        let b = hcat(&[self.b1.as_ref(), self.b2.as_ref()], n);
        let c = vcat(&[self.c1.as_ref(), self.c2.as_ref()], n);

        let mut r = d1r.transpose() * &d1r;
        for i in 0..m1 {
            r[(i, i)] -= g2;
        }
        let q = self.c1.transpose() * &self.c1;
        let s = self.c1.transpose() * &d1r;
        // The Schur method: the γ search probes infeasible γ whose Hamiltonians have eigenvalues
        // on the imaginary axis, where doubling would spend its step limit before giving up.
        let opts = RiccatiOptions {
            care_method: CareMethod::Schur,
            ..Default::default()
        };
        let care = |a: MatRef<f64>, b: MatRef<f64>, q: MatRef<f64>, r: MatRef<f64>, s: MatRef<f64>| {
            care_with(a, b, q, r, Some(s), &opts)
        };
        let xs = match care(self.a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), s.as_ref()) {
            Ok(x) => x,
            Err(e) => {
                *why = format!("X Riccati equation: {e}");
                return Ok(None);
            }
        };
        let mut rt = &d1c * d1c.transpose();
        for i in 0..p1 {
            rt[(i, i)] -= g2;
        }
        let at = self.a.transpose().to_owned();
        let ct = c.transpose().to_owned();
        let qy = &self.b1 * self.b1.transpose();
        let sy = &self.b1 * d1c.transpose();
        let ys = match care(at.as_ref(), ct.as_ref(), qy.as_ref(), rt.as_ref(), sy.as_ref()) {
            Ok(y) => y,
            Err(e) => {
                *why = format!("Y Riccati equation: {e}");
                return Ok(None);
            }
        };
        let tol = 1e-9;
        let xmin = sym_min_eig(xs.x.as_ref())?;
        if xmin < -tol * xs.x.norm_max().max(1.0) {
            *why = format!("X is not positive semidefinite (min eigenvalue {xmin:.3e})");
            return Ok(None);
        }
        let ymin = sym_min_eig(ys.x.as_ref())?;
        if ymin < -tol * ys.x.norm_max().max(1.0) {
            *why = format!("Y is not positive semidefinite (min eigenvalue {ymin:.3e})");
            return Ok(None);
        }
        let rho = spectral_radius((&xs.x * &ys.x).as_ref())?;
        if rho >= g2 {
            *why = format!("coupling condition fails: rho(XY) = {rho:.6e} >= gamma^2 = {g2:.6e}");
            return Ok(None);
        }
        let f = -&xs.k;
        let l = -ys.k.transpose().to_owned();
        Ok(Some(RiccatiPair { x: xs.x, y: ys.x, f, l }))
    }

    /// Central controller of ZDG §17.2 for the normalized plant, mapped back to the original
    /// coordinates (scalings undone, D22 loop shift undone).
    fn controller(&self, gamma: f64, rp: &RiccatiPair) -> Result<StateSpace> {
        let (n, m1, m2, p1, p2) = (self.a.nrows(), self.m1, self.m2, self.p1, self.p2);
        let g2 = gamma * gamma;
        let [d1111, d1112, d1121, d1122] = self.d11_blocks();
        let (r, c) = (p1 - m2, m1 - p2);

        let mut gm_r = -(d1111 * d1111.transpose());
        for i in 0..r {
            gm_r[(i, i)] += g2;
        }
        let gm_r_inv = inv(gm_r.as_ref(), "gamma^2 I - D1111 D1111'")?;
        let mut gm_c = -(d1111.transpose() * d1111);
        for i in 0..c {
            gm_c[(i, i)] += g2;
        }
        let gm_c_inv = inv(gm_c.as_ref(), "gamma^2 I - D1111' D1111")?;
        let dk11 = -(d1121 * d1111.transpose() * &gm_r_inv * d1112) - d1122;
        let m12 = Mat::<f64>::identity(m2, m2) - d1121 * &gm_c_inv * d1121.transpose();
        let m21 = Mat::<f64>::identity(p2, p2) - d1112.transpose() * &gm_r_inv * d1112;
        let dk12 = m12
            .llt(Side::Lower)
            .map_err(|_| {
                RobustError::Numerical("I - D1121 (g^2 I - D1111'D1111)^-1 D1121' is not positive definite".into())
            })?
            .L()
            .to_owned();
        let dk21 = m21
            .llt(Side::Lower)
            .map_err(|_| {
                RobustError::Numerical("I - D1112' (g^2 I - D1111 D1111')^-1 D1112 is not positive definite".into())
            })?
            .L()
            .transpose()
            .to_owned();

        let f12 = rp.f.get(c..m1, ..);
        let f2 = rp.f.get(m1.., ..);
        let l12 = rp.l.get(.., r..p1);
        let l2 = rp.l.get(.., p1..);
        let zinv = Mat::<f64>::identity(n, n) - &rp.y * &rp.x * (1.0 / g2);
        let z = inv(zinv.as_ref(), "I - gamma^-2 Y X")?;
        let b = hcat(&[self.b1.as_ref(), self.b2.as_ref()], n);

        let bk2 = &z * (&self.b2 + l12) * &dk12;
        let ck2 = -(&dk21 * (&self.c2 + f12));
        let dk12_inv = inv(dk12.as_ref(), "D^12")?;
        let dk21_inv = inv(dk21.as_ref(), "D^21")?;
        let bk1 = -(&z * l2) + &bk2 * &dk12_inv * &dk11;
        let ck1 = f2 + &dk11 * &dk21_inv * &ck2;
        let ak = &self.a + &b * &rp.f + &bk1 * &dk21_inv * &ck2;

        // Undo the D22 shift: u = K0·(y − D22·u).
        let mk = inv(
            (Mat::<f64>::identity(p2, p2) + &self.d22 * &dk11).as_ref(),
            "I + D22 Dk (the loop with D22 is ill-posed)",
        )?;
        let ak = &ak - &bk1 * &mk * &self.d22 * &ck1;
        let bk = &bk1 * &mk;
        let ck = &ck1 - &dk11 * &mk * &self.d22 * &ck1;
        let dk = &dk11 * &mk;

        // Undo the scalings: u = tu·ũ, ỹ = ty·y.
        Ok(StateSpace::new(
            ak,
            &bk * &self.ty,
            &self.tu * &ck,
            &self.tu * &dk * &self.ty,
            0.0,
        )?)
    }
}
