//! `hinfstruct`: an H∞ controller of fixed order for a generalized plant (MATLAB conventions as
//! [`crate::hinfsyn`]: last `nmeas` outputs are y, last `ncon` inputs are u, u = K·y), found by
//! minimizing ‖lft(P, K)‖∞ over the entries of K's realization with nonsmooth BFGS after a
//! stabilization phase, from random starts in parallel (HIFOO's method). At full order the optimum
//! equals hinfsyn's γ_opt, which bounds every fixed-order result from below.

use super::blocks::{Block, Structure};
use super::closed_loop::GenPlant;
use super::nonsmooth::{bfgs, BfgsOptions};
use super::systune::{normal, random_ss};
use crate::error::{Result, RobustError};
use faer::Mat;
use rand::SeedableRng;
use rayon::prelude::*;
use skyloop_linalg::riccati::care;
use skyloop_lti::freqresp::dynamics_range;
use skyloop_lti::StateSpace;

/// A nonsmooth objective of the scaled parameters: its value and a (sub)gradient.
type Objective<'a> = dyn Fn(&[f64]) -> (f64, Vec<f64>) + 'a;

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
            starts: 8,
            seed: 1,
            max_iter: 1500,
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
    /// Starts that reached a stabilizing controller, of [`starts_run`](Self::starts_run).
    pub stabilized_starts: usize,
    /// Starts run: the requested ones plus [`added_starts`](Self::added_starts).
    pub starts_run: usize,
    /// Central-H∞-controller starts added below full order beyond the requested ones.
    pub added_starts: usize,
}

/// The longest run [`hinfstruct`] accepts, by its own estimate, s.
pub const MAX_ESTIMATED_S: f64 = 600.0;

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
pub fn hinfstruct(
    p: &StateSpace,
    nmeas: usize,
    ncon: usize,
    order: usize,
    opts: &HinfstructOptions,
) -> Result<HinfstructSolution> {
    let gp = GenPlant::new(p, nmeas, ncon)?;
    if order > 50 {
        return Err(RobustError::InvalidArgument(format!(
            "controller order {order} is outside 0..=50"
        )));
    }
    if opts.starts == 0 || opts.starts > 1000 {
        return Err(RobustError::InvalidArgument(format!(
            "starts must be in 1..=1000, got {}",
            opts.starts
        )));
    }
    // Cost up front: each start's BFGS takes about n_cl³ per closed-loop norm times the number of
    // controller parameters (measured on a 5-state plant: 0.15 s per start at order 2, 2.5 s at
    // order 16), run two at a time on a 2-core machine. Refuse what would take over 10 minutes.
    let n_cl = (p.nx() + order) as f64;
    let n_par = ((order + ncon) * (order + nmeas)) as f64;
    let est_s = opts.starts as f64 / 2.0 * (0.1 + 1e-6 * n_cl.powi(3) * n_par);
    if est_s > MAX_ESTIMATED_S {
        return Err(RobustError::InvalidArgument(format!(
            "order {order} with {} starts on a {}-state plant would take about {:.0} minutes (estimated; the limit is {:.0}): lower the starts or the order",
            opts.starts,
            p.nx(),
            est_s / 60.0,
            MAX_ESTIMATED_S / 60.0
        )));
    }
    let s = Structure::new(Block::StateSpace {
        order,
        ny: ncon,
        nu: nmeas,
    });
    let (lo, hi) = dynamics_range(p)?;
    let w0 = (lo * hi).sqrt();
    // At full order observer-based controllers stabilize: start 0 is the H2-optimal one for the
    // plant's channels, start 1 the unit-weight LQG one, starts 2 and 3 perturb them; the others
    // (and every start below full order) are random, and the stabilization phase repairs them.
    let mut seeds: Vec<Vec<f64>> = if order == p.nx() {
        [true, false]
            .iter()
            .filter_map(|&w| lqg_start(p, nmeas, ncon, w).ok())
            .collect()
    } else {
        Vec::new()
    };
    // Central H∞ controllers a little above γ_opt, reduced to the order when it is lower: the
    // near-optimal basin the random and LQG starts often miss (a local minimum of the
    // realization's entries far above γ_opt). Several levels, because the controller at γ_opt
    // itself is ill conditioned (its gains grow without bound as γ → γ_opt).
    // At full order they lead the seeds (and their perturbed copies follow); below it they run
    // in addition to the random starts, which a static or low-order problem still needs (a
    // truncated central controller rarely stabilizes at order 0).
    let central = hinfsyn_starts(p, nmeas, ncon, order, w0);
    let extra = if order == p.nx() {
        seeds.splice(0..0, central);
        Vec::new()
    } else {
        central
    };
    let runs: Vec<Option<(f64, Vec<f64>)>> = (0..opts.starts + extra.len())
        .into_par_iter()
        .map(|k| {
            let seed = opts.seed + k as u64;
            let x0 = if k >= opts.starts {
                extra[k - opts.starts].clone()
            } else if k < seeds.len() {
                seeds[k].clone()
            } else if k < 2 * seeds.len() {
                let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
                seeds[k - seeds.len()]
                    .iter()
                    .map(|v| v * (1.0 + 0.3 * normal(&mut rng)))
                    .collect()
            } else {
                random_ss(order, ncon, nmeas, w0, 1.0, seed)
            };
            run(&gp, &s, x0, w0, opts.max_iter)
        })
        .collect();
    let stabilized_starts = runs.iter().filter(|r| r.is_some()).count();
    let starts_run = runs.len();
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
        return Err(RobustError::Numerical(
            "the tuned controller does not stabilize the verified closed loop".into(),
        ));
    }
    Ok(HinfstructSolution {
        controller,
        gamma,
        stabilized_starts,
        starts_run,
        added_starts: starts_run - opts.starts,
    })
}

/// One start: stabilize (spectral abscissa below −1e-3·w0), then minimize the H∞ norm in rounds
/// of BFGS. Each round's variables are the parameters divided by their current magnitudes
/// (systune's diagonal scaling) and starts from a fresh inverse Hessian: the minimizer is a kink,
/// where the inverse Hessian of a long run becomes too ill conditioned to make progress.
fn run(gp: &GenPlant, s: &Structure, th0: Vec<f64>, w0: f64, max_iter: usize) -> Option<(f64, Vec<f64>)> {
    let opts = BfgsOptions {
        max_iter: max_iter.clamp(1, 300),
        ..Default::default()
    };
    let scaled = |th: &[f64]| -> Vec<f64> {
        let big = th.iter().map(|v| v.abs()).fold(0.0, f64::max).max(1e-12);
        th.iter().map(|v| v.abs().max(1e-3 * big)).collect()
    };
    let absc = |th: &[f64]| match (s.realize(th), s.realize_grad(th)) {
        (Ok(k), Ok(dk)) => match gp.spectral_abscissa(&k, &dk) {
            Ok((v, g)) if v.is_finite() => (v, g),
            _ => (f64::INFINITY, Vec::new()),
        },
        _ => (f64::INFINITY, Vec::new()),
    };
    let norm = |th: &[f64]| match (s.realize(th), s.realize_grad(th)) {
        (Ok(k), Ok(dk)) => match gp.hinf(&k, &dk) {
            Ok((v, _, g)) if v.is_finite() && g.len() == th.len() => (v, g),
            _ => (f64::INFINITY, Vec::new()),
        },
        _ => (f64::INFINITY, Vec::new()),
    };
    // BFGS on x = θ/scale.
    let round = |f: &Objective, th: &[f64], o: &BfgsOptions| -> (f64, Vec<f64>) {
        let sc = scaled(th);
        let x0: Vec<f64> = th.iter().zip(&sc).map(|(a, b)| a / b).collect();
        let r = bfgs(
            |x| {
                let t: Vec<f64> = x.iter().zip(&sc).map(|(a, b)| a * b).collect();
                let (v, g) = f(&t);
                (v, g.iter().zip(&sc).map(|(a, b)| a * b).collect())
            },
            &x0,
            o,
        );
        (r.f, r.x.iter().zip(&sc).map(|(a, b)| a * b).collect())
    };
    let target = -1e-3 * w0;
    let mut th = th0;
    if !(absc(&th).0 < target) {
        let (f, t) = round(&absc, &th, &BfgsOptions { target, ..opts });
        if !(f < 0.0) {
            return None;
        }
        th = t;
    }
    let mut best = norm(&th).0;
    if !best.is_finite() {
        return None;
    }
    let rounds = max_iter.div_ceil(opts.max_iter).max(1);
    for _ in 0..rounds {
        let (f, t) = round(
            &norm,
            &th,
            &BfgsOptions {
                ftol: 1e-9,
                stall: 20,
                ..opts
            },
        );
        let gain = (best - f) / best;
        if f < best {
            best = f;
            th = t;
        }
        if gain < 1e-5 {
            break;
        }
    }
    Some((best, th))
}

/// Parameter vectors of central H∞ controllers built at 1.001, 1.01, 1.05 and 1.2 times
/// hinfsyn's γ, each reduced by balanced truncation to `order` (or padded with decoupled poles at
/// −w0 when shorter); the levels hinfsyn cannot build, or whose reduction fails, are skipped.
fn hinfsyn_starts(p: &StateSpace, nmeas: usize, ncon: usize, order: usize, w0: f64) -> Vec<Vec<f64>> {
    let Ok(opt) = crate::hinfsyn::hinfsyn(p, nmeas, ncon) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for c in [1.001, 1.01, 1.05, 1.2] {
        let o = crate::hinfsyn::HinfOptions {
            gamma_range: (opt.gamma * c, f64::INFINITY),
            ..Default::default()
        };
        let Ok(sol) = crate::hinfsyn::hinfsyn_with(p, nmeas, ncon, &o) else {
            continue;
        };
        let k = &sol.controller;
        let k = if k.nx() > order {
            match skyloop_lti::reduce::balred(k, order, skyloop_lti::reduce::Method::Balanced) {
                Ok(r) => r.sys,
                Err(_) => continue,
            }
        } else {
            k.clone()
        };
        out.push(ss_params(&k, order, w0));
    }
    out
}

/// θ of a full state-space block (A row-major, B, C, D) holding `k`, padded to `order` states
/// with uncoupled poles at −w0.
fn ss_params(k: &StateSpace, order: usize, w0: f64) -> Vec<f64> {
    let (nk, ny, nu) = (k.nx().min(order), k.ny(), k.nu());
    let mut th = Vec::new();
    for i in 0..order {
        for j in 0..order {
            th.push(if i < nk && j < nk {
                k.a[(i, j)]
            } else if i == j {
                -w0
            } else {
                0.0
            });
        }
    }
    for i in 0..order {
        for j in 0..nu {
            th.push(if i < nk { k.b[(i, j)] } else { 0.0 });
        }
    }
    for i in 0..ny {
        for j in 0..order {
            th.push(if j < nk { k.c[(i, j)] } else { 0.0 });
        }
    }
    for i in 0..ny {
        for j in 0..nu {
            th.push(k.d[(i, j)]);
        }
    }
    th
}

/// The H2-optimal (LQG) observer-based controller u = −F·x̂ for the plant's own performance and
/// noise channels: F from the CARE with (C1ᵀC1, D12ᵀD12, C1ᵀD12), L from the filter CARE with
/// (B1B1ᵀ, D21D21ᵀ, B1D21ᵀ), regularized by 1e-8·I so a singular D12/D21 still gives a start.
/// As the parameter vector of a full-order state-space block: A_K = A − B2·F − L·C2 + L·D22·F,
/// B_K = L, C_K = −F, D_K = 0.
fn lqg_start(p: &StateSpace, nmeas: usize, ncon: usize, weighted: bool) -> Result<Vec<f64>> {
    let n = p.nx();
    let (p1, m1) = (p.ny() - nmeas, p.nu() - ncon);
    let b1 = p.b.get(.., ..m1).to_owned();
    let b2 = p.b.get(.., m1..).to_owned();
    let c1 = p.c.get(..p1, ..).to_owned();
    let c2 = p.c.get(p1.., ..).to_owned();
    let d12 = p.d.get(..p1, m1..).to_owned();
    let d21 = p.d.get(p1.., ..m1).to_owned();
    let d22 = p.d.get(p1.., m1..).to_owned();
    let reg = |m: Mat<f64>| {
        let k = m.nrows();
        if !weighted {
            return Mat::<f64>::identity(k, k);
        }
        let sc = m.norm_max().max(1.0);
        &m + Mat::<f64>::identity(k, k) * (1e-8 * sc)
    };
    let q = reg(c1.transpose() * &c1);
    let r = reg(d12.transpose() * &d12);
    let sx = c1.transpose() * &d12 * if weighted { 1.0 } else { 0.0 };
    let f = care(p.a.as_ref(), b2.as_ref(), q.as_ref(), r.as_ref(), Some(sx.as_ref()))?.k;
    let at = p.a.transpose().to_owned();
    let c2t = c2.transpose().to_owned();
    let qy = reg(&b1 * b1.transpose());
    let ry = reg(&d21 * d21.transpose());
    let sy = &b1 * d21.transpose() * if weighted { 1.0 } else { 0.0 };
    let l = care(at.as_ref(), c2t.as_ref(), qy.as_ref(), ry.as_ref(), Some(sy.as_ref()))?
        .k
        .transpose()
        .to_owned();
    let ak = &p.a - &b2 * &f - &l * &c2 + &l * &d22 * &f;
    let ck = -&f;
    let mut th = Vec::new();
    for (m, r, c) in [(&ak, n, n), (&l, n, nmeas), (&ck, ncon, n)] {
        for i in 0..r {
            for j in 0..c {
                th.push(m[(i, j)]);
            }
        }
    }
    th.extend(std::iter::repeat_n(0.0, ncon * nmeas));
    Ok(th)
}
