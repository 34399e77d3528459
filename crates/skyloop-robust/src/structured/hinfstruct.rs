//! `hinfstruct`: an H∞ controller of fixed order for a generalized plant (MATLAB conventions as
//! [`crate::hinfsyn`]: last `nmeas` outputs are y, last `ncon` inputs are u, u = K·y), found by
//! minimizing ‖lft(P, K)‖∞ over the entries of K's realization with nonsmooth BFGS after a
//! stabilization phase, from random starts in parallel (HIFOO's method). At full order the optimum
//! equals hinfsyn's γ_opt, which bounds every fixed-order result from below.

use super::blocks::{Block, Structure};
use super::closed_loop::GenPlant;
use super::nonsmooth::{bfgs, BfgsOptions};
use super::systune::random_ss;
use crate::error::{Result, RobustError};
use rayon::prelude::*;
use skyloop_lti::freqresp::dynamics_range;
use skyloop_lti::StateSpace;

/// Options of [`hinfstruct`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HinfstructOptions {
    /// Number of random starts, run in parallel (start k uses seed + k).
    pub starts: usize,
    /// Seed of the random starts.
    pub seed: u64,
    /// Most BFGS iterations per phase and start.
    pub max_iter: usize,
}

impl Default for HinfstructOptions {
    fn default() -> Self {
        HinfstructOptions {
            starts: 6,
            seed: 1,
            max_iter: 400,
        }
    }
}

/// The result of [`hinfstruct`].
#[derive(Debug, Clone)]
pub struct HinfstructSolution {
    /// Controller u = K·y of the requested order.
    pub controller: StateSpace,
    /// ‖lft(P, K)‖∞ recomputed with skyloop-lti's `lft_lower` and `hinf_norm`.
    pub gamma: f64,
    /// Starts that reached a stabilizing controller.
    pub stabilized_starts: usize,
}

/// Fixed-order H∞ synthesis (see the module documentation).
///
/// # Errors
/// Delays or discrete time, channel counts that leave no performance channel, an order above
/// 50, no start that stabilizes the loop ([`RobustError::Infeasible`]).
///
/// # Examples
/// ```
/// use skyloop_lti::expr::parse_model;
/// use skyloop_robust::mixsyn::augw;
/// use skyloop_robust::structured::hinfstruct::{hinfstruct, HinfstructOptions};
/// let g = parse_model("10/(s+1)")?;
/// let p = augw(&g, Some(&parse_model("(0.5*s+2)/(s+0.02)")?), Some(&parse_model("0.1")?), None)?;
/// let opt = skyloop_robust::hinfsyn::hinfsyn(&p, 1, 1)?.gamma;
/// let sol = hinfstruct(&p, 1, 1, 2, &HinfstructOptions { starts: 2, ..Default::default() })?;
/// assert!(sol.gamma >= opt * (1.0 - 1e-3) && sol.gamma <= opt * 1.05);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn hinfstruct(p: &StateSpace, nmeas: usize, ncon: usize, order: usize, opts: &HinfstructOptions) -> Result<HinfstructSolution> {
    let gp = GenPlant::new(p, nmeas, ncon)?;
    if order > 50 {
        return Err(RobustError::InvalidArgument(format!("controller order {order} is outside 0..=50")));
    }
    if opts.starts == 0 || opts.starts > 1000 {
        return Err(RobustError::InvalidArgument(format!("starts must be in 1..=1000, got {}", opts.starts)));
    }
    let s = Structure::new(Block::StateSpace {
        order,
        ny: ncon,
        nu: nmeas,
    });
    let (lo, hi) = dynamics_range(p)?;
    let w0 = (lo * hi).sqrt();
    let runs: Vec<Option<(f64, Vec<f64>)>> = (0..opts.starts)
        .into_par_iter()
        .map(|k| run(&gp, &s, random_ss(order, ncon, nmeas, w0, 1.0, opts.seed + k as u64), w0, opts.max_iter))
        .collect();
    let stabilized_starts = runs.iter().filter(|r| r.is_some()).count();
    let best = runs
        .into_iter()
        .flatten()
        .fold(None::<(f64, Vec<f64>)>, |a, b| match a {
            Some(a) if a.0 <= b.0 => Some(a),
            _ => Some(b),
        })
        .ok_or_else(|| RobustError::Infeasible {
            gamma: f64::INFINITY,
            reason: format!("no start found a stabilizing controller of order {order}"),
        })?;
    let controller = s.realize(&best.1)?;
    // Independent re-verification with skyloop-lti's interconnection and norm.
    let cl = skyloop_lti::interconnect::lft_lower(p, &controller)?;
    let (gamma, _) = skyloop_lti::norms::hinf_norm(&cl)?;
    if !gamma.is_finite() {
        return Err(RobustError::Numerical("the tuned controller does not stabilize the verified closed loop".into()));
    }
    Ok(HinfstructSolution {
        controller,
        gamma,
        stabilized_starts,
    })
}

/// One start: stabilize (spectral abscissa below −1e-3·w0), then minimize the H∞ norm.
fn run(gp: &GenPlant, s: &Structure, x0: Vec<f64>, w0: f64, max_iter: usize) -> Option<(f64, Vec<f64>)> {
    let opts = BfgsOptions {
        max_iter,
        ..Default::default()
    };
    let target = -1e-3 * w0;
    let absc = |x: &[f64]| match (s.realize(x), s.realize_grad(x)) {
        (Ok(k), Ok(dk)) => match gp.spectral_abscissa(&k, &dk) {
            Ok((v, g)) if v.is_finite() => (v, g),
            _ => (f64::INFINITY, Vec::new()),
        },
        _ => (f64::INFINITY, Vec::new()),
    };
    let mut x = x0;
    if !(absc(&x).0 < target) {
        let r = bfgs(absc, &x, &BfgsOptions { target, ..opts });
        if !(r.f < 0.0) {
            return None;
        }
        x = r.x;
    }
    let norm = |x: &[f64]| match (s.realize(x), s.realize_grad(x)) {
        (Ok(k), Ok(dk)) => match gp.hinf(&k, &dk) {
            Ok((v, _, g)) if v.is_finite() && g.len() == x.len() => (v, g),
            _ => (f64::INFINITY, Vec::new()),
        },
        _ => (f64::INFINITY, Vec::new()),
    };
    let r = bfgs(norm, &x, &BfgsOptions { ftol: 1e-9, stall: 20, ..opts });
    r.f.is_finite().then_some((r.f, r.x))
}
