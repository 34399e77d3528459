//! μ over frequency: sweeps with warm-started D-scales, refinement of the peak between grid
//! points, the robust stability margin and robust performance (main loop theorem).

use super::{mu_from, mu_with, MuBounds, MuOptions};
use crate::error::Result;
use crate::error::RobustError;
use crate::uncertainty::blocks::BlockStructure;
use faer::{c64, Mat};

/// The worst frequency of a sweep.
#[derive(Debug, Clone)]
pub struct MuPeak {
    /// Frequency of the largest upper bound (rad/s), after refinement.
    pub w_rad_s: f64,
    /// Largest upper bound found over the grid and the refinement.
    pub upper: f64,
    /// Largest lower bound found over the grid and the refinement (a lower bound on the peak).
    pub lower: f64,
    /// Frequency (rad/s) where that lower bound was found.
    pub w_lower_rad_s: f64,
    /// The perturbation proving `lower`: σ̄(Δ) = 1/lower, det(I − M(jω)Δ) = 0 at `w_lower_rad_s`.
    pub delta: Mat<c64>,
}

/// μ bounds over a frequency grid.
#[derive(Debug, Clone)]
pub struct MuSweep {
    /// The grid (rad/s), as given.
    pub w_rad_s: Vec<f64>,
    /// Upper bound at each grid frequency.
    pub upper: Vec<f64>,
    /// Lower bound at each grid frequency.
    pub lower: Vec<f64>,
    /// The refined peak.
    pub peak: MuPeak,
}

/// μ bounds for a list of matrices (one per frequency), each warm-started from the previous bounds
/// (D-scales and lower-bound vectors).
pub fn mu_sweep(responses: &[Mat<c64>], s: &BlockStructure, opts: &MuOptions) -> Result<Vec<MuBounds>> {
    let mut out: Vec<MuBounds> = Vec::with_capacity(responses.len());
    for m in responses {
        let b = match out.last() {
            Some(prev) => mu_from(m.as_ref(), s, opts, prev)?,
            None => mu_with(m.as_ref(), s, opts, None)?,
        };
        out.push(b);
    }
    Ok(out)
}

/// μ bounds of M(jω) on the grid `w_rad_s` (positive, increasing), then a golden-section refinement
/// of the upper-bound peak between the neighbours of the worst grid point. `eval` returns M(jω).
pub fn mu_frequency<F, E>(eval: F, w_rad_s: &[f64], s: &BlockStructure, opts: &MuOptions) -> Result<MuSweep>
where
    F: Fn(f64) -> std::result::Result<Mat<c64>, E>,
    RobustError: From<E>,
{
    Ok(mu_frequency_bounds(eval, w_rad_s, s, opts)?.0)
}

/// As [`mu_frequency`], also returning the bounds (with their D-scales and perturbations) at each
/// grid frequency, which the D-step of μ-synthesis fits.
pub fn mu_frequency_bounds<F, E>(
    eval: F,
    w_rad_s: &[f64],
    s: &BlockStructure,
    opts: &MuOptions,
) -> Result<(MuSweep, Vec<MuBounds>)>
where
    F: Fn(f64) -> std::result::Result<Mat<c64>, E>,
    RobustError: From<E>,
{
    if w_rad_s.is_empty() {
        return Err(RobustError::InvalidArgument("the frequency grid is empty".into()));
    }
    for (k, &w) in w_rad_s.iter().enumerate() {
        if !(w.is_finite() && w >= 0.0) {
            return Err(RobustError::InvalidArgument(format!(
                "frequency {w} is not finite and >= 0"
            )));
        }
        if k > 0 && w <= w_rad_s[k - 1] {
            return Err(RobustError::InvalidArgument(
                "frequencies must be strictly increasing".into(),
            ));
        }
    }
    let ms = w_rad_s
        .iter()
        .map(|&w| eval(w))
        .collect::<std::result::Result<Vec<_>, E>>()?;
    let bounds = mu_sweep(&ms, s, opts)?;
    let upper: Vec<f64> = bounds.iter().map(|b| b.upper).collect();
    let lower: Vec<f64> = bounds.iter().map(|b| b.lower).collect();
    let k = argmax(&upper);
    let kl = argmax(&lower);
    let mut peak = MuPeak {
        w_rad_s: w_rad_s[k],
        upper: upper[k],
        lower: lower[kl],
        w_lower_rad_s: w_rad_s[kl],
        delta: bounds[kl].delta.clone(),
    };
    if w_rad_s.len() > 1 {
        let lo = w_rad_s[k.saturating_sub(1)];
        let hi = w_rad_s[(k + 1).min(w_rad_s.len() - 1)];
        refine_peak(&eval, lo, hi, s, opts, &bounds[k], &mut peak)?;
    }
    Ok((
        MuSweep {
            w_rad_s: w_rad_s.to_vec(),
            upper,
            lower,
            peak,
        },
        bounds,
    ))
}

fn argmax(v: &[f64]) -> usize {
    v.iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map_or(0, |(i, _)| i)
}

/// Golden-section search of the upper bound on [lo, hi] (in log frequency when lo > 0).
fn refine_peak<F, E>(
    eval: &F,
    lo: f64,
    hi: f64,
    s: &BlockStructure,
    opts: &MuOptions,
    seed: &MuBounds,
    peak: &mut MuPeak,
) -> Result<()>
where
    F: Fn(f64) -> std::result::Result<Mat<c64>, E>,
    RobustError: From<E>,
{
    let log = lo > 0.0;
    let (to, from) = (
        |w: f64| if log { w.ln() } else { w },
        |x: f64| if log { x.exp() } else { x },
    );
    let (mut a, mut b) = (to(lo), to(hi));
    let g = 0.5 * (5.0_f64.sqrt() - 1.0);
    let at = |x: f64, peak: &mut MuPeak| -> Result<f64> {
        let w = from(x);
        let r = mu_with(eval(w)?.as_ref(), s, opts, Some(&seed.d))?;
        if r.upper > peak.upper {
            peak.upper = r.upper;
            peak.w_rad_s = w;
        }
        if r.lower > peak.lower {
            peak.lower = r.lower;
            peak.w_lower_rad_s = w;
            peak.delta = r.delta.clone();
        }
        Ok(r.upper)
    };
    let mut x1 = b - g * (b - a);
    let mut x2 = a + g * (b - a);
    let mut f1 = at(x1, peak)?;
    let mut f2 = at(x2, peak)?;
    for _ in 0..30 {
        if (b - a).abs() <= 1e-7 * (1.0 + a.abs()) {
            break;
        }
        if f1 > f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - g * (b - a);
            f1 = at(x1, peak)?;
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + g * (b - a);
            f2 = at(x2, peak)?;
        }
    }
    Ok(())
}

/// Robust stability margin from a μ sweep of the uncertainty channel: the system is stable for all
/// structured Δ with σ̄(Δ) < `lower`, and `delta` (σ̄ = `upper`) destabilizes it.
#[derive(Debug, Clone)]
pub struct StabilityMargin {
    /// Guaranteed margin 1/peak μ upper bound.
    pub lower: f64,
    /// 1/peak μ lower bound (∞ when no destabilizing Δ was found).
    pub upper: f64,
    /// Frequency (rad/s) of the destabilizing perturbation.
    pub w_rad_s: f64,
    /// Destabilizing structured perturbation with σ̄(Δ) = `upper`.
    pub delta: Mat<c64>,
}

/// The robust stability margin (1/peak μ) and the destabilizing perturbation from a sweep.
pub fn robust_stability(sweep: &MuSweep) -> StabilityMargin {
    let inv = |x: f64| if x > 0.0 { 1.0 / x } else { f64::INFINITY };
    StabilityMargin {
        lower: inv(sweep.peak.upper),
        upper: inv(sweep.peak.lower),
        w_rad_s: sweep.peak.w_lower_rad_s,
        delta: sweep.peak.delta.clone(),
    }
}

/// Robust performance by the main loop theorem: N(jω) has the uncertainty channels first and the
/// performance channels last (`n_perf_out` outputs z, `n_perf_in` inputs w); the structure is
/// augmented with a full `n_perf_in × n_perf_out` block Δ_P, and robust performance (‖F_u(N,Δ)‖∞ < 1
/// for all σ̄(Δ) ≤ 1) holds iff the returned μ stays below 1 (given nominal stability).
pub fn robust_performance<F, E>(
    eval: F,
    w_rad_s: &[f64],
    s: &BlockStructure,
    n_perf_out: usize,
    n_perf_in: usize,
    opts: &MuOptions,
) -> Result<MuSweep>
where
    F: Fn(f64) -> std::result::Result<Mat<c64>, E>,
    RobustError: From<E>,
{
    let aug = s.with_full_block(n_perf_in, n_perf_out)?;
    mu_frequency(eval, w_rad_s, &aug, opts)
}

/// μ bounds of a model's frequency response on `w_rad_s` (exact with delays), with peak refinement.
pub fn mu_system(
    sys: &skyloop_lti::StateSpace,
    w_rad_s: &[f64],
    s: &BlockStructure,
    opts: &MuOptions,
) -> Result<MuSweep> {
    s.check_matrix(sys.ny(), sys.nu())?;
    let ev = skyloop_lti::freqresp::FreqEvaluator::new(sys)?;
    mu_frequency(|w| ev.eval(c64::new(0.0, w)), w_rad_s, s, opts)
}
