//! μ-synthesis by DK-iteration (Doyle 1985; Skogestad & Postlethwaite §8.12; Zhou, Doyle & Glover
//! §11.6).
//!
//! Plant convention (MATLAB `musyn` on the `lftdata` of an uncertain plant): P's inputs are
//! [w_Δ; w; u] and its outputs [z_Δ; z; y], where
//! * the first `blocks.m_cols()` inputs w_Δ and `blocks.m_rows()` outputs z_Δ are the channels of
//!   the uncertainty Δ = blkdiag(Δ₁, …) (w_Δ = Δ·z_Δ, every σ̄(Δⱼ) ≤ 1);
//! * the next inputs w and outputs z are the exogenous inputs and weighted performance outputs;
//!   the iteration treats them as one more full complex block Δ_P (`w × z`) of the main loop
//!   theorem, so μ < 1 means ‖F_u(lft(P,K), Δ)‖∞ < 1 for every admissible Δ (robust
//!   performance). Without them (both empty) μ measures robust stability only;
//! * the last `nmeas` outputs y and `ncon` inputs u are the measurements and controls, u = K·y,
//!   as in [`crate::hinfsyn`].
//!
//! Each iteration: K-step — H∞ synthesis on the D-scaled plant diag(D_L, I)·P·diag(D_R⁻¹, I);
//! analysis — μ upper bound of lft(P, K) on the frequency grid (with peak refinement);
//! D-step — the upper bound's scalings at each grid frequency, normalized so the last block's is 1,
//! each scalar fitted by a stable, minimum-phase, biproper d(s) ([`dfit::fit_magnitude`], a
//! spectral factor) and absorbed into the plant. The first K-step uses D = I (plain H∞).
//! Iteration stops after `max_iter` K-steps or when the peak μ improves by less than `tol`
//! (relative) on the best so far; the best iteration's controller is returned.
//! Real scalar blocks: the D-step fits the complex bound's D-scales only (no G-scales, i.e. no
//! D–G–K iteration: the design is conservative), while the μ peaks reported per iteration are the
//! certified mixed (D–G) upper bounds of `mu`.

pub mod dfit;
pub mod scale;

pub use dfit::{fit_magnitude, DFit};
pub use scale::{fit_scaling, scaled_plant, Scalings};

use crate::error::Result;
use crate::error::RobustError;
use crate::hinfsyn::{hinfsyn_with, HinfOptions};
use crate::mu::{mu_frequency_bounds, MuBounds, MuOptions};
use crate::uncertainty::blocks::{BlockKind, BlockStructure};
use faer::c64;
use skyloop_lti::freqresp::FreqEvaluator;
use skyloop_lti::StateSpace;

/// Settings of the DK-iteration.
#[derive(Debug, Clone)]
pub struct MusynOptions {
    /// Largest number of K-steps (iterations), default 6.
    pub max_iter: usize,
    /// Order of the rational fit of each scalar D-scale, default 2.
    pub d_order: usize,
    /// Frequency grid (rad/s, positive, increasing); empty = automatic from the plant's dynamics.
    pub w_rad_s: Vec<f64>,
    /// Stop when the peak μ improves by less than this fraction of the best so far, default 1e-2.
    pub tol: f64,
    /// Options of each K-step's H∞ synthesis.
    pub hinf: HinfOptions,
    /// Reduce every controller to this many states (balanced truncation) when it still stabilizes.
    pub reduce_order: Option<usize>,
    /// Options of the μ upper bound in the analysis/D-step.
    pub mu: MuOptions,
}

impl Default for MusynOptions {
    fn default() -> Self {
        MusynOptions {
            max_iter: 6,
            d_order: 2,
            w_rad_s: Vec::new(),
            tol: 1e-2,
            hinf: HinfOptions::default(),
            reduce_order: None,
            mu: MuOptions {
                rel_tol: 1e-4,
                t_max: 4096.0,
                power_iters: 100,
                random_starts: 1,
            },
        }
    }
}

/// What one DK-iteration achieved.
#[derive(Debug, Clone)]
pub struct MusynIteration {
    /// γ of the K-step: ‖D·lft(P,K)·D⁻¹‖∞ on the scaled plant (an upper bound of `mu_peak`).
    pub gamma: f64,
    /// Peak over frequency of the μ upper bound of lft(P, K) for the full structure (robust
    /// performance when P has performance channels).
    pub mu_peak: f64,
    /// Frequency of that peak (rad/s).
    pub mu_peak_w_rad_s: f64,
    /// Number of controller states.
    pub controller_order: usize,
    /// Peak of the μ upper bound for the uncertainty blocks only (robust stability).
    pub mu_rs_peak: f64,
    /// Peak of the μ lower bound for the full structure (the true μ peak is between the two).
    pub mu_lower_peak: f64,
    /// States of the D-scaled plant the K-step used (P's states plus those of the D-scales).
    pub scaled_plant_order: usize,
    /// μ upper bound for the full structure on the grid ([`MusynSolution::w_rad_s`]).
    pub mu_upper: Vec<f64>,
}

/// The result of [`musyn`].
#[derive(Debug, Clone)]
pub struct MusynSolution {
    /// The best iteration's controller (u = K·y), which stabilizes P.
    pub controller: StateSpace,
    /// Its peak μ upper bound.
    pub mu_peak: f64,
    /// Every iteration in order.
    pub iterations: Vec<MusynIteration>,
    /// Index of the best iteration in `iterations`.
    pub best: usize,
    /// The frequency grid used (rad/s).
    pub w_rad_s: Vec<f64>,
    /// Why the iteration stopped.
    pub stop_reason: String,
}

/// Channel layout of the plant (see the module documentation).
struct Layout {
    /// Δ blocks plus the performance block when there is one.
    full: BlockStructure,
    /// Δ blocks only.
    rs: BlockStructure,
    /// Number of performance outputs z.
    nz: usize,
}

fn layout(p: &StateSpace, blocks: &BlockStructure, nmeas: usize, ncon: usize) -> Result<Layout> {
    let (nzd, nwd) = (blocks.m_rows(), blocks.m_cols());
    if nmeas == 0 || ncon == 0 {
        return Err(RobustError::InvalidArgument(format!(
            "musyn needs at least one measurement and one control (nmeas = {nmeas}, ncon = {ncon})"
        )));
    }
    if p.ny() < nzd + nmeas || p.nu() < nwd + ncon {
        return Err(RobustError::Dimension(format!(
            "the plant is {}x{} but the uncertainty needs {nzd} outputs and {nwd} inputs besides \
             {nmeas} measurements and {ncon} controls",
            p.ny(),
            p.nu()
        )));
    }
    let (nz, nw) = (p.ny() - nzd - nmeas, p.nu() - nwd - ncon);
    if (nz == 0) != (nw == 0) {
        return Err(RobustError::Dimension(format!(
            "{nw} exogenous inputs but {nz} performance outputs: either both or neither must be present"
        )));
    }
    let full = if nz > 0 {
        blocks.with_full_block(nw, nz)?
    } else {
        blocks.clone()
    };
    Ok(Layout {
        full,
        rs: blocks.clone(),
        nz,
    })
}

/// Automatic grid: 15 points per decade from a decade below the slowest to a decade above the
/// fastest dynamics of P (at most 8 decades, at least 3).
fn auto_grid(p: &StateSpace) -> Result<Vec<f64>> {
    let (lo, hi) = skyloop_lti::freqresp::dynamics_range(p)?;
    let (mut a, mut b) = ((lo / 10.0).log10(), (hi * 10.0).log10());
    if b - a > 8.0 {
        a = b - 8.0;
    }
    if b - a < 3.0 {
        let mid = 0.5 * (a + b);
        a = mid - 1.5;
        b = mid + 1.5;
    }
    let n = ((b - a) * 15.0).ceil() as usize + 1;
    Ok(skyloop_lti::freqresp::logspace(a, b, n))
}

fn check_options(o: &MusynOptions) -> Result<()> {
    if o.max_iter == 0 {
        return Err(RobustError::InvalidArgument("max_iter must be at least 1".into()));
    }
    if !(o.tol.is_finite() && o.tol >= 0.0) {
        return Err(RobustError::InvalidArgument(format!(
            "tol must be finite and >= 0, got {}",
            o.tol
        )));
    }
    for (k, &w) in o.w_rad_s.iter().enumerate() {
        if !(w.is_finite() && w > 0.0) || (k > 0 && w <= o.w_rad_s[k - 1]) {
            return Err(RobustError::InvalidArgument(
                "the frequency grid must be positive, finite and strictly increasing".into(),
            ));
        }
    }
    if !o.w_rad_s.is_empty() && o.w_rad_s.len() < 2 * o.d_order + 1 {
        return Err(RobustError::InvalidArgument(format!(
            "a D-fit of order {} needs at least {} frequencies, got {}",
            o.d_order,
            2 * o.d_order + 1,
            o.w_rad_s.len()
        )));
    }
    Ok(())
}

/// The μ analysis of one controller: the closed loop must be stable.
struct Analysis {
    mu_peak: f64,
    mu_peak_w: f64,
    mu_lower_peak: f64,
    mu_rs_peak: f64,
    mu_upper: Vec<f64>,
    bounds: Vec<MuBounds>,
}

fn analyse(p: &StateSpace, k: &StateSpace, lay: &Layout, w: &[f64], o: &MuOptions) -> Result<Analysis> {
    let cl = skyloop_lti::interconnect::lft_lower(p, k)?;
    let cl = crate::matrix_ops::balance_states(&cl)?;
    let growth = crate::matrix_ops::max_real_eig(cl.a.as_ref())?;
    if growth >= 0.0 {
        return Err(RobustError::Numerical(format!(
            "the controller does not stabilize the plant (closed-loop pole with real part {growth:.3e})"
        )));
    }
    let ev = FreqEvaluator::new(&cl)?;
    let (sweep, bounds) = mu_frequency_bounds(|x| ev.eval(c64::new(0.0, x)), w, &lay.full, o)?;
    let (nzd, nwd) = (lay.rs.m_rows(), lay.rs.m_cols());
    let rs = if lay.nz > 0 {
        let sub = |x: f64| -> Result<faer::Mat<c64>> {
            let m = ev.eval(c64::new(0.0, x))?;
            Ok(m.as_ref().submatrix(0, 0, nzd, nwd).to_owned())
        };
        crate::mu::mu_frequency(sub, w, &lay.rs, o)?.peak.upper
    } else {
        sweep.peak.upper
    };
    Ok(Analysis {
        mu_peak: sweep.peak.upper,
        mu_peak_w: sweep.peak.w_rad_s,
        mu_lower_peak: sweep.peak.lower,
        mu_rs_peak: rs,
        mu_upper: sweep.upper,
        bounds,
    })
}

/// Fits the D-scales of a sweep: one SISO d(s) per scaling channel of `lay.full`, the last block's
/// normalized to 1.
fn fit_dscales(lay: &Layout, w: &[f64], bounds: &[MuBounds], order: usize) -> Result<Vec<StateSpace>> {
    let s = &lay.full;
    let counts = scale::block_channels(s);
    let nb = s.len();
    // Magnitude of channel (block j, index p) at each frequency.
    let mag = |b: &MuBounds, j: usize, p: usize| -> f64 {
        let dj = &b.d.per_block[j];
        match s.blocks()[j] {
            BlockKind::Full { .. } => dj[(0, 0)].norm(),
            _ => dj[(p, p)].norm(),
        }
    };
    let mut out = Vec::new();
    for (j, &count) in counts.iter().enumerate() {
        for p in 0..count {
            if j + 1 == nb && p == 0 {
                out.push(StateSpace::gain(faer::Mat::<f64>::identity(1, 1), 0.0)?);
                continue;
            }
            let data: Vec<f64> = bounds
                .iter()
                .map(|b| {
                    let r = mag(b, j, p) / mag(b, nb - 1, 0);
                    if r.is_finite() {
                        r.clamp(1e-8, 1e8)
                    } else {
                        1.0
                    }
                })
                .collect();
            out.push(fit_scaling(w, &data, order)?);
        }
    }
    Ok(out)
}

/// Reduces K by balanced truncation when asked and when the reduced K still stabilizes P.
fn maybe_reduce(p: &StateSpace, k: StateSpace, order: Option<usize>) -> StateSpace {
    let Some(n) = order else { return k };
    if k.nx() <= n {
        return k;
    }
    let Ok(r) = skyloop_lti::reduce::balred(&k, n, skyloop_lti::reduce::Method::Balanced) else {
        return k;
    };
    let stable = skyloop_lti::interconnect::lft_lower(p, &r.sys)
        .map_err(RobustError::from)
        .and_then(|cl| crate::matrix_ops::balance_states(&cl))
        .and_then(|cl| crate::matrix_ops::max_real_eig(cl.a.as_ref()))
        .is_ok_and(|g| g < 0.0);
    if stable {
        r.sys
    } else {
        k
    }
}

/// μ-synthesis by DK-iteration (see the module documentation for the plant convention).
pub fn musyn(
    p: &StateSpace,
    blocks: &BlockStructure,
    nmeas: usize,
    ncon: usize,
    opts: &MusynOptions,
) -> Result<MusynSolution> {
    p.validate()?;
    if p.dt != 0.0 || p.has_delay() {
        return Err(RobustError::Unsupported(
            "musyn needs a continuous-time rational plant (discretize afterwards; Padé for delays)".into(),
        ));
    }
    check_options(opts)?;
    let lay = layout(p, blocks, nmeas, ncon)?;
    let w = if opts.w_rad_s.is_empty() {
        auto_grid(p)?
    } else {
        opts.w_rad_s.clone()
    };
    let mut iterations: Vec<MusynIteration> = Vec::new();
    let mut best: Option<(usize, StateSpace)> = None;
    let mut pd = p.clone();
    let mut stop = String::new();
    for it in 0..opts.max_iter {
        let sol = match hinfsyn_with(&pd, nmeas, ncon, &opts.hinf) {
            Ok(s) => s,
            // A later K-step can fail on a badly fitted scaling; the best controller so far stands.
            Err(e) if best.is_some() => {
                stop = format!("K-step {} failed: {e}", it + 1);
                break;
            }
            Err(e) => return Err(e),
        };
        let k = maybe_reduce(p, sol.controller, opts.reduce_order);
        let an = match analyse(p, &k, &lay, &w, &opts.mu) {
            Ok(a) => a,
            Err(e) if best.is_some() => {
                stop = format!("analysis {} failed: {e}", it + 1);
                break;
            }
            Err(e) => return Err(e),
        };
        iterations.push(MusynIteration {
            gamma: sol.gamma,
            mu_peak: an.mu_peak,
            mu_peak_w_rad_s: an.mu_peak_w,
            controller_order: k.nx(),
            mu_rs_peak: an.mu_rs_peak,
            mu_lower_peak: an.mu_lower_peak,
            scaled_plant_order: pd.nx(),
            mu_upper: an.mu_upper.clone(),
        });
        let improved = match &best {
            None => true,
            Some((b, _)) => an.mu_peak < iterations[*b].mu_peak * (1.0 - opts.tol),
        };
        let better = match &best {
            None => true,
            Some((b, _)) => an.mu_peak < iterations[*b].mu_peak,
        };
        if better {
            best = Some((it, k));
        }
        if !improved {
            stop = format!("peak mu improved by less than {} (relative)", opts.tol);
            break;
        }
        if it + 1 == opts.max_iter {
            stop = format!("reached max_iter = {}", opts.max_iter);
            break;
        }
        let ds = match fit_dscales(&lay, &w, &an.bounds, opts.d_order) {
            Ok(d) => d,
            Err(e) => {
                stop = format!("D-scale fit {} failed: {e}", it + 1);
                break;
            }
        };
        let sc = scale::expand(&lay.full, &ds)?;
        pd = scaled_plant(p, &sc, nmeas, ncon)?;
    }
    let (bi, controller) = best.ok_or_else(|| RobustError::Numerical("no DK-iteration succeeded".into()))?;
    Ok(MusynSolution {
        controller,
        mu_peak: iterations[bi].mu_peak,
        iterations,
        best: bi,
        w_rad_s: w,
        stop_reason: stop,
    })
}
