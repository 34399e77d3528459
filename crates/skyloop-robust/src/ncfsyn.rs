//! Glover–McFarlane H∞ loop shaping (normalized coprime factor robust stabilization).
//!
//! The shaped plant Ps = W2·P·W1 = (A, B, C, D) gives, with S = I + DᵀD, R = I + DDᵀ and
//! Ar = A − B·S⁻¹·DᵀC (Skogestad & Postlethwaite, *Multivariable Feedback Control*, §9.4;
//! McFarlane & Glover 1990):
//!   X: Arᵀ·X + X·Ar − X·B·S⁻¹·Bᵀ·X + Cᵀ·R⁻¹·C = 0,
//!   Z: Ar·Z + Z·Arᵀ − Z·Cᵀ·R⁻¹·C·Z + B·S⁻¹·Bᵀ = 0,
//!   γ_min = sqrt(1 + ρ(X·Z)),
//! and for γ > γ_min the central controller (positive feedback u = K∞·y on Ps)
//!   F = −S⁻¹(DᵀC + BᵀX), L = (1 − γ²)I + X·Z,
//!   K∞ = (A + BF + γ²L⁻ᵀZCᵀ(C + DF), γ²L⁻ᵀZCᵀ, BᵀX, −Dᵀ).
//! The returned full controller C = −W1·K∞·W2 is for negative feedback u = C·(r − y), L = P·C.

use crate::error::Result;
use crate::error::RobustError;
use crate::matrix_ops::{balance_states, inv, max_real_eig, spectral_radius, uncontrollable_unstable_mode};
use faer::linalg::solvers::Solve;
use skyloop_linalg::riccati::care;
use skyloop_lti::interconnect::{lft_lower, series};
use skyloop_lti::norms::hinf_norm;
use skyloop_lti::{Mat, StateSpace};

/// Options of [`ncfsyn`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NcfOptions {
    /// The controller is built for γ = `factor`·γ_min (MATLAB's default 1.1); must be > 1.
    pub factor: f64,
    /// Order of the Padé approximants that replace delays of P, W1, W2.
    pub pade_order: usize,
}

impl Default for NcfOptions {
    fn default() -> Self {
        NcfOptions {
            factor: 1.1,
            pade_order: 3,
        }
    }
}

/// The result of [`ncfsyn`].
#[derive(Debug, Clone)]
pub struct NcfSolution {
    /// Full controller C = −W1·K∞·W2 for negative feedback u = C·(r − y).
    pub controller: StateSpace,
    /// K∞ for the shaped plant, positive feedback u = K∞·y (MATLAB's convention for K∞ alone).
    pub k_inf: StateSpace,
    /// The shaped plant Ps = W2·P·W1 (delays replaced by Padé approximants).
    pub shaped_plant: StateSpace,
    /// Optimal γ = sqrt(1 + ρ(XZ)) (1/γ_min is the best NCF stability margin).
    pub gamma_min: f64,
    /// Achieved 4-block norm ‖[I; K∞](I − Ps·K∞)⁻¹[I Ps]‖∞ with the returned K∞.
    pub gamma: f64,
}

/// Loop-shaping design for P with optional weights W1 (input side) and W2 (output side).
///
/// # Errors
/// Weights or plant of the wrong size or not continuous, a shaped plant without states, or Riccati equations without a stabilizing solution.
///
/// # Examples
/// ```
/// use skyloop_lti::expr::parse_model;
/// use skyloop_robust::ncfsyn::{ncfsyn, NcfOptions};
/// // The bicopter paper's Section IV: W2·P·W1 with a 3rd-order Padé of the 32 ms delay gives γ_min = 1.748.
/// let p = parse_model("0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2-s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5)")?;
/// let w1 = parse_model("0.03511*(s+0.3419)/s")?;
/// let w2 = parse_model("307.5*(s+3.816)/((s+11.35)*(s+103.4))")?;
/// let sol = ncfsyn(&p, Some(&w1), Some(&w2), &NcfOptions { factor: 1.1, pade_order: 3 })?;
/// assert!((sol.gamma_min - 1.748).abs() < 5e-4);
/// assert!(sol.gamma <= 1.1 * sol.gamma_min * (1.0 + 1e-6));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn ncfsyn(
    p: &StateSpace,
    w1: Option<&StateSpace>,
    w2: Option<&StateSpace>,
    opts: &NcfOptions,
) -> Result<NcfSolution> {
    if !(opts.factor > 1.0) || !opts.factor.is_finite() {
        return Err(RobustError::InvalidArgument(format!(
            "factor must be a finite number > 1, got {}",
            opts.factor
        )));
    }
    p.validate()?;
    if p.dt != 0.0 {
        return Err(RobustError::Unsupported(
            "ncfsyn works in continuous time; design continuous and discretize the controller".into(),
        ));
    }
    let rational = |s: &StateSpace| -> Result<StateSpace> {
        if s.has_delay() {
            // An order outside 1..=20 is an error, never a silently dropped delay.
            Ok(s.try_pade(opts.pade_order)?)
        } else {
            Ok(s.clone())
        }
    };
    let pr = rational(p)?;
    let w1r = match w1 {
        Some(w) => Some(rational(w)?),
        None => None,
    };
    let w2r = match w2 {
        Some(w) => Some(rational(w)?),
        None => None,
    };
    let mut ps = pr.clone();
    if let Some(w) = &w1r {
        check_weight(w, p.nu(), "W1")?;
        ps = series(w, &ps)?;
    }
    if let Some(w) = &w2r {
        check_weight(w, p.ny(), "W2")?;
        ps = series(&ps, w)?;
    }
    let (k_inf, gamma_min) = ncfsyn_shaped(&ps, opts.factor)?;
    let gamma = four_block_norm(&ps, &k_inf)?;
    if !(gamma <= opts.factor * gamma_min * (1.0 + 1e-3)) {
        return Err(RobustError::Numerical(format!(
            "the central controller misses its level: 4-block norm {gamma:.6} > {:.6} (factor x gamma_min)",
            opts.factor * gamma_min
        )));
    }
    let mut c = k_inf.clone();
    if let Some(w) = &w2r {
        c = series(w, &c)?;
    }
    if let Some(w) = &w1r {
        c = series(&c, w)?;
    }
    let controller = negate(&c)?;
    Ok(NcfSolution {
        controller,
        k_inf,
        shaped_plant: ps,
        gamma_min,
        gamma,
    })
}

fn check_weight(w: &StateSpace, n: usize, name: &str) -> Result<()> {
    if w.nu() != n || w.ny() != n {
        return Err(RobustError::Dimension(format!(
            "{name} must be {n}x{n} to match the plant, is {}x{}",
            w.ny(),
            w.nu()
        )));
    }
    if w.dt != 0.0 {
        return Err(RobustError::Unsupported(format!("{name} must be continuous time")));
    }
    Ok(())
}

/// γ_min of a shaped plant and the central K∞ (positive feedback) at γ = factor·γ_min.
pub fn ncfsyn_shaped(ps: &StateSpace, factor: f64) -> Result<(StateSpace, f64)> {
    ps.validate()?;
    if ps.has_delay() {
        return Err(RobustError::Unsupported(
            "the shaped plant has delays: replace them by Padé approximants".into(),
        ));
    }
    let ps = &balance_states(ps)?;
    let (n, ny, nu) = (ps.nx(), ps.ny(), ps.nu());
    if n == 0 {
        return Err(RobustError::Unsupported("the shaped plant has no states".into()));
    }
    let ct = ps.c.transpose().to_owned();
    let (a, b, c, d) = (&ps.a, &ps.b, &ps.c, &ps.d);
    let s = Mat::<f64>::identity(nu, nu) + d.transpose() * d;
    let r = Mat::<f64>::identity(ny, ny) + d * d.transpose();
    let si = inv(s.as_ref(), "I + D'D")?;
    let ri = inv(r.as_ref(), "I + DD'")?;
    let ar = a - b * &si * d.transpose() * c;
    let qx = c.transpose() * &ri * c;
    let x = match care(ar.as_ref(), b.as_ref(), qx.as_ref(), s.as_ref(), None) {
        Ok(sol) => sol.x,
        Err(e) => return Err(diagnose(ps, "control Riccati equation of the shaped plant", e)),
    };
    let art = ar.transpose().to_owned();
    let qz = b * &si * b.transpose();
    let z = match care(art.as_ref(), ct.as_ref(), qz.as_ref(), r.as_ref(), None) {
        Ok(sol) => sol.x,
        Err(e) => return Err(diagnose(ps, "filter Riccati equation of the shaped plant", e)),
    };
    let xz = &x * &z;
    let gamma_min = (1.0 + spectral_radius(xz.as_ref())?).sqrt();
    let g = factor * gamma_min;
    let g2 = g * g;
    let f = -(&si * (d.transpose() * c + b.transpose() * &x));
    let mut l = xz;
    for i in 0..n {
        l[(i, i)] += 1.0 - g2;
    }
    // L is non-normal and can look ill-conditioned when X and Z differ in scale although its
    // eigenvalues (1 − γ² + λ(XZ)) stay away from 0 for γ > γ_min; the caller verifies the loop.
    let bk = l.transpose().full_piv_lu().solve(&z * c.transpose() * g2);
    if !bk.norm_max().is_finite() {
        return Err(RobustError::Numerical("(1 - gamma^2) I + X Z is singular".into()));
    }
    let ak = a + b * &f + &bk * (c + d * &f);
    let ck = b.transpose() * &x;
    let dk = -d.transpose();
    let k = StateSpace::new(ak, bk, ck, dk.to_owned(), 0.0)?;
    Ok((k, gamma_min))
}

/// Explains a Riccati failure: an unstabilizable or undetectable mode when there is one, else the
/// Riccati failure itself.
fn diagnose(ps: &StateSpace, equation: &'static str, source: skyloop_linalg::LinalgError) -> RobustError {
    let at = ps.a.transpose().to_owned();
    let ct = ps.c.transpose().to_owned();
    if let Ok(Some(mode)) = uncontrollable_unstable_mode(ps.a.as_ref(), ps.b.as_ref()) {
        return RobustError::NotStabilizable {
            system: "the shaped plant (A, B)",
            mode,
        };
    }
    if let Ok(Some(mode)) = uncontrollable_unstable_mode(at.as_ref(), ct.as_ref()) {
        return RobustError::NotDetectable {
            system: "the shaped plant (C, A)",
            mode,
        };
    }
    RobustError::Riccati { equation, source }
}

/// The 4-block system [I; K](I − Ps·K)⁻¹[I Ps] for positive feedback u = K·y, as lft(G, K) of the
/// generalized plant with inputs [w_y; w_u; u], outputs [v; u; v], v = Ps·(u + w_u) + w_y.
pub fn four_block(ps: &StateSpace, k_pos: &StateSpace) -> Result<StateSpace> {
    let (n, ny, nu) = (ps.nx(), ps.ny(), ps.nu());
    if k_pos.ny() != nu || k_pos.nu() != ny {
        return Err(RobustError::Dimension(format!(
            "controller must be {nu}x{ny} for a {ny}x{nu} plant, is {}x{}",
            k_pos.ny(),
            k_pos.nu()
        )));
    }
    let nin = ny + 2 * nu;
    let nout = 2 * ny + nu;
    let mut b = Mat::<f64>::zeros(n, nin);
    b.get_mut(.., ny..ny + nu).copy_from(&ps.b);
    b.get_mut(.., ny + nu..).copy_from(&ps.b);
    let mut c = Mat::<f64>::zeros(nout, n);
    c.get_mut(..ny, ..).copy_from(&ps.c);
    c.get_mut(ny + nu.., ..).copy_from(&ps.c);
    let mut d = Mat::<f64>::zeros(nout, nin);
    for (r0, _) in [(0usize, ()), (ny + nu, ())] {
        d.get_mut(r0..r0 + ny, ..ny).copy_from(Mat::<f64>::identity(ny, ny));
        d.get_mut(r0..r0 + ny, ny..ny + nu).copy_from(&ps.d);
        d.get_mut(r0..r0 + ny, ny + nu..).copy_from(&ps.d);
    }
    d.get_mut(ny..ny + nu, ny + nu..)
        .copy_from(Mat::<f64>::identity(nu, nu));
    let g = StateSpace::new(ps.a.clone(), b, c, d, ps.dt)?;
    Ok(lft_lower(&g, k_pos)?)
}

/// ‖[I; K](I − Ps·K)⁻¹[I Ps]‖∞ for positive feedback K; +∞ when K does not stabilize Ps.
pub fn four_block_norm(ps: &StateSpace, k_pos: &StateSpace) -> Result<f64> {
    // Balanced coordinates: hinf_norm counts poles within 1e-7·‖A‖ of 0 as integrators.
    let cl = balance_states(&four_block(ps, k_pos)?)?;
    if max_real_eig(cl.a.as_ref())? >= 0.0 {
        return Ok(f64::INFINITY);
    }
    Ok(hinf_norm(&cl)?.0)
}

/// Normalized coprime factor stability margin b(P, C) ∈ [0, 1] of the negative-feedback loop
/// u = C·(r − y) (MATLAB's ncfmargin); 0 when C does not stabilize P. Delays are replaced by
/// Padé approximants of order `pade_order`.
pub fn ncfmargin(p: &StateSpace, c: &StateSpace, pade_order: usize) -> Result<f64> {
    let pr = if p.has_delay() {
        p.try_pade(pade_order)?
    } else {
        p.clone()
    };
    let cr = if c.has_delay() {
        c.try_pade(pade_order)?
    } else {
        c.clone()
    };
    let norm = four_block_norm(&pr, &negate(&cr)?)?;
    Ok(if norm.is_finite() { 1.0 / norm } else { 0.0 })
}

/// −sys (outputs negated).
pub(crate) fn negate(sys: &StateSpace) -> Result<StateSpace> {
    let mut s = sys.clone();
    s.c = -&s.c;
    s.d = -&s.d;
    s.validate()?;
    Ok(s)
}
