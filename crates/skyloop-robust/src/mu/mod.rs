//! The structured singular value μ: bounds for one matrix, frequency sweeps with peak refinement,
//! robust stability margins and robust performance by the main loop theorem. With real scalar
//! blocks the upper bound is the certified D–G (mixed-μ) bound of [`mixed`].

mod bfgs;
pub mod lower;
pub mod mixed;
pub mod sweep;
pub mod upper;

pub use lower::{lower_bound, lower_bound_vectors, LowerBound};
pub use mixed::{mixed_upper_bound, MixedUpper};
pub use sweep::{
    mu_frequency, mu_frequency_bounds, mu_sweep, mu_system, robust_performance, robust_stability, MuPeak, MuSweep,
    StabilityMargin,
};
pub use upper::{osborne, upper_bound, upper_bound_from, DScales, UpperBound, UpperOptions};

use crate::error::Result;
use crate::uncertainty::blocks::BlockStructure;
use faer::{c64, Mat, MatRef};
use rand::{Rng, SeedableRng};

/// Accuracy and effort settings for μ bounds.
#[derive(Debug, Clone, Copy)]
pub struct MuOptions {
    /// Stop refining the upper bound once (upper − lower) ≤ rel_tol·lower.
    pub rel_tol: f64,
    /// Largest smoothing exponent of the upper-bound surrogate (accuracy ≈ ln 2 / (2 t_max)).
    pub t_max: f64,
    /// Power-iteration steps per start.
    pub power_iters: usize,
    /// Extra pseudo-random power-iteration starts (deterministic seed) besides the D-scaled
    /// singular vectors.
    pub random_starts: usize,
}

impl Default for MuOptions {
    fn default() -> Self {
        MuOptions {
            rel_tol: 1e-6,
            t_max: 65536.0,
            power_iters: 200,
            random_starts: 2,
        }
    }
}

/// Upper and lower bounds of μ for one matrix, with the scales and the perturbation that prove them.
#[derive(Debug, Clone)]
pub struct MuBounds {
    /// Upper bound: σ̄(D_L M D_R⁻¹), or for structures with real scalar blocks the certified D–G
    /// bound ([`mixed_upper_bound`]) when it is smaller.
    pub upper: f64,
    /// Lower bound ρ(QM) of a structured Q in the unit ball.
    pub lower: f64,
    /// The D-scales of the complex upper bound σ̄(D_L M D_R⁻¹) (also the D–G bound's start).
    pub d: DScales,
    /// Structured Δ (M cols × M rows) with σ̄(Δ) = 1/lower and det(I − MΔ) = 0 (zeros if lower = 0).
    pub delta: Mat<c64>,
    /// Final power-iteration vectors (b, w) behind `lower` (empty if none): the lower-bound start at
    /// a neighbouring frequency.
    pub lower_start: (Vec<c64>, Vec<c64>),
    /// The upper-bound optimizer's final inverse Hessian and smoothing exponent
    /// (`UpperBound::curvature`): its start at a neighbouring frequency.
    pub upper_curvature: (Vec<f64>, f64),
}

/// μ bounds of M for the structure with default options.
///
/// # Errors
/// A matrix that does not fit the structure, or non-finite entries.
///
/// # Examples
/// ```
/// use skyloop_lti::{c64, Mat};
/// use skyloop_robust::{mu::mu, uncertainty::BlockStructure};
/// // Two scalar blocks on a diagonal matrix: μ is the largest diagonal modulus.
/// let m = Mat::from_fn(2, 2, |i, j| if i == j { c64::new([2.0, 0.5][i], 0.0) } else { c64::new(0.0, 0.0) });
/// let b = mu(m.as_ref(), &BlockStructure::parse("c1x1,c1x1")?)?;
/// assert!((b.upper - 2.0).abs() < 1e-6 && (b.lower - 2.0).abs() < 1e-6);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn mu(m: MatRef<c64>, s: &BlockStructure) -> Result<MuBounds> {
    mu_with(m, s, &MuOptions::default(), None)
}

/// μ bounds of M; `warm` D-scales (e.g. from the previous frequency) replace Osborne's start.
pub fn mu_with(m: MatRef<c64>, s: &BlockStructure, opts: &MuOptions, warm: Option<&DScales>) -> Result<MuBounds> {
    mu_warm(m, s, opts, warm, None, None)
}

/// μ bounds of M warm-started from a neighbouring frequency's bounds: its D-scales start the upper
/// bound and its power-iteration vectors replace the pseudo-random lower-bound starts.
pub fn mu_from(m: MatRef<c64>, s: &BlockStructure, opts: &MuOptions, prev: &MuBounds) -> Result<MuBounds> {
    let lower = (!prev.lower_start.0.is_empty()).then_some(&prev.lower_start);
    let curvature = (!prev.upper_curvature.0.is_empty()).then_some(&prev.upper_curvature);
    mu_warm(m, s, opts, Some(&prev.d), lower, curvature)
}

fn mu_warm(
    m: MatRef<c64>,
    s: &BlockStructure,
    opts: &MuOptions,
    warm: Option<&DScales>,
    warm_lower: Option<&(Vec<c64>, Vec<c64>)>,
    warm_curvature: Option<&(Vec<f64>, f64)>,
) -> Result<MuBounds> {
    s.check_matrix(m.nrows(), m.ncols())?;
    if let (Some(d0), Some(st)) = (warm, warm_lower) {
        if st.0.len() == m.ncols() && st.1.len() == m.ncols() {
            return mu_neighbour(m, s, opts, d0, st, warm_curvature);
        }
    }
    let quick = UpperOptions {
        rel_tol: opts.rel_tol,
        t_max: if warm.is_some() { 1024.0 } else { 16.0_f64 }.min(opts.t_max),
        iters_per_stage: 20,
        // A warm start (the previous frequency's optimum) is already past the coarse stages.
        t_start: if warm.is_some() { 1024.0 } else { 4.0 },
    };
    let ub0 = upper_bound(m, s, warm, 0.0, &quick)?;
    let mut starts = vec![start_from(m, &ub0)];
    let mut rng = rand::rngs::StdRng::seed_from_u64(0x6d75);
    let n_random = match warm_lower {
        Some(st) if st.0.len() == m.ncols() && st.1.len() == m.ncols() => {
            starts.push(st.clone());
            0
        }
        _ => opts.random_starts,
    };
    for _ in 0..n_random {
        let mut r = || c64::new(rng.gen::<f64>() - 0.5, rng.gen::<f64>() - 0.5);
        let b: Vec<c64> = (0..m.ncols()).map(|_| r()).collect();
        let w: Vec<c64> = (0..m.ncols()).map(|_| r()).collect();
        starts.push((b, w));
    }
    let (lb, lb_start) = lower_bound_vectors(m, s, &starts, opts.power_iters)?;
    let full = UpperOptions {
        rel_tol: opts.rel_tol,
        t_max: opts.t_max,
        iters_per_stage: 40,
        // Continue from the quick pass's scales where its last stage ended.
        t_start: 4.0 * quick.t_start.max(quick.t_max),
    };
    let mut ub = upper_bound(m, s, Some(&ub0.d), lb.value, &full)?;
    if ub0.value < ub.value {
        ub = ub0;
    }
    finish(m, s, opts, ub, (lb, lb_start))
}

/// μ bounds from a neighbouring frequency's optimum: the lower bound first (the previous power-iteration
/// vectors usually land on the same branch at once), so that the upper bound, started from the previous
/// D-scales at a sharp smoothing stage, can stop as soon as it meets it.
fn mu_neighbour(
    m: MatRef<c64>,
    s: &BlockStructure,
    opts: &MuOptions,
    d0: &DScales,
    st: &(Vec<c64>, Vec<c64>),
    curvature: Option<&(Vec<f64>, f64)>,
) -> Result<MuBounds> {
    let (lb, lb_start) = lower_bound_vectors(m, s, std::slice::from_ref(st), opts.power_iters)?;
    let up = UpperOptions {
        rel_tol: opts.rel_tol,
        t_max: opts.t_max,
        iters_per_stage: 40,
        t_start: 1024.0_f64.min(opts.t_max),
    };
    let ub = upper_bound_from(m, s, Some(d0), curvature, lb.value, &up)?;
    finish(m, s, opts, ub, (lb, lb_start))
}

/// Completes μ bounds from an upper bound and a lower bound with its power-iteration vectors: when they
/// are apart, one more power iteration starts from the upper bound's singular vectors; real blocks then
/// get the D–G bound.
fn finish(
    m: MatRef<c64>,
    s: &BlockStructure,
    opts: &MuOptions,
    ub: UpperBound,
    (mut lb, mut lb_start): (LowerBound, (Vec<c64>, Vec<c64>)),
) -> Result<MuBounds> {
    if ub.value > lb.value * (1.0 + opts.rel_tol) {
        let (again, again_start) = lower_bound_vectors(m, s, &[start_from(m, &ub)], opts.power_iters)?;
        if again.value > lb.value {
            lb = again;
            lb_start = again_start;
        }
    }
    let upper = with_real_blocks(m, s, opts, &ub, lb.value)?;
    Ok(MuBounds {
        upper,
        // Both are computed independently in floating point; a lower bound above the upper one can
        // only be rounding, so it is clipped (the Δ still proves the unclipped value to rounding).
        lower: lb.value.min(upper),
        d: ub.d,
        delta: lb.delta,
        lower_start: lb_start,
        upper_curvature: ub.curvature,
    })
}

/// The upper bound to report: the complex one, or with real scalar blocks the certified D–G bound
/// started from its D-scales if that is smaller (all-complex structures take no extra step).
fn with_real_blocks(m: MatRef<c64>, s: &BlockStructure, opts: &MuOptions, ub: &UpperBound, lower: f64) -> Result<f64> {
    if !s.has_real() || ub.value <= lower * (1.0 + opts.rel_tol) {
        return Ok(ub.value);
    }
    Ok(match mixed_upper_bound(m, s, &ub.d, ub.value, lower, opts.rel_tol)? {
        Some(mx) if mx.value < ub.value => mx.value,
        _ => ub.value,
    })
}

/// Power-iteration start from the top singular pair of the D-scaled matrix: b = D_R⁻¹ v, w = Mᴴ D_Lᴴ u.
fn start_from(m: MatRef<c64>, ub: &UpperBound) -> (Vec<c64>, Vec<c64>) {
    let n = m.ncols();
    let ri = &ub.d.right_inv;
    let b: Vec<c64> = (0..n)
        .map(|i| (0..n).fold(c64::new(0.0, 0.0), |acc, k| acc + ri[(i, k)] * ub.v[k]))
        .collect();
    let l = &ub.d.left;
    let nr = m.nrows();
    let z: Vec<c64> = (0..nr)
        .map(|i| (0..nr).fold(c64::new(0.0, 0.0), |acc, k| acc + l[(k, i)].conj() * ub.u[k]))
        .collect();
    let w: Vec<c64> = (0..n)
        .map(|j| (0..nr).fold(c64::new(0.0, 0.0), |acc, i| acc + m[(i, j)].conj() * z[i]))
        .collect();
    (b, w)
}
