//! The design pipeline of a SISO loop, as in the bicopter paper's Section IV: synthesis (Glover–
//! McFarlane loop shaping, mixed sensitivity, or a given controller) → gain boost → controller
//! reduction → Tustin discretization, with γ and margins reported after every step. No plots here;
//! [`report`] draws them from [`DesignResult`].
//!
//! Conventions: C is for negative feedback u = C·(r − y), L = P·C. For ncfsyn, γ after each step is
//! the 4-block norm of the shaped loop (Ps = W2·P·W1, K = −W1⁻¹·C·W2⁻¹), the number MATLAB's
//! `ncfsyn` and the paper report; `ncf_margin` is b(P, C) of the unweighted loop. Margins are read
//! with the plant's exact delays, γ and b(P, C) with its Padé approximant.

pub mod loop_metrics;
pub mod report;
mod steps;
pub mod table;

pub use crate::spec::design::{DesignSpec, SynthesisMethod};
use loop_metrics::{closeness, crossover_limits};
use loop_metrics::{Closeness, CrossoverLimits, LoopMargins};
use serde::Serialize;
use skyloop_lti::error::Result;
use skyloop_lti::sos::Sos;
use skyloop_lti::{LtiError, StateSpace};

/// What one design step produced, as numbers.
#[derive(Debug, Clone, Serialize)]
pub struct StageSummary {
    /// "synthesis", "boost" or "reduction".
    pub stage: String,
    /// Controller states.
    pub order: usize,
    /// ncfsyn: 4-block norm of the shaped loop; mixsyn: the synthesis γ (synthesis step only).
    pub gamma: Option<f64>,
    /// b(P, C) of the unweighted loop (MATLAB ncfmargin, here on the frequency grid of
    /// [`loop_metrics::four_block_norms`]), 0 when unstable.
    pub ncf_margin: f64,
    /// Classic and disk margins of L = P·C.
    pub margins: LoopMargins,
}

/// The Tustin controller compared with the continuous one.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct DiscreteSummary {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// C_d(e^{jωT}) against C(jω) from 0.01 Hz to `analysis.compare_up_to_hz`.
    pub vs_continuous: Closeness,
    /// C_d(e^{jωT}) against C(jω_a), ω_a = (2/T)·tan(ωT/2): Tustin's exact frequency map, so this
    /// is rounding only.
    pub vs_warped: Closeness,
}

/// Everything the pipeline reports (what `skyloop design --json` prints).
#[derive(Debug, Clone, Serialize)]
pub struct DesignSummary {
    /// Design name from the spec.
    pub name: String,
    /// Synthesis method.
    pub method: String,
    /// ncfsyn: optimal γ = sqrt(1 + ρ(XZ)).
    pub gamma_min: Option<f64>,
    /// ncfsyn: the factor of γ_min the controller was built for.
    pub factor: Option<f64>,
    /// Scale applied to the synthesized controller by the boost (1 without boost).
    pub boost_gain: f64,
    /// Controller modes faster than 100× the plant/weight dynamics that were residualized.
    pub fast_modes_removed: usize,
    /// One entry per step that ran.
    pub stages: Vec<StageSummary>,
    /// Hankel singular values of the stable part of the boosted controller (reduction only).
    pub hsv: Vec<f64>,
    /// Balanced-reduction bound on ‖C_full − C_reduced‖∞ (2·Σ discarded σ; reduction only).
    pub reduction_error_bound: Option<f64>,
    /// Reduced against full controller over the crossover band (reduction only).
    pub reduced_vs_full: Option<Closeness>,
    /// Discretization check (discretize only).
    pub discrete: Option<DiscreteSummary>,
    /// Crossover of the final loop against the RHP-zero and delay limits.
    pub limits: CrossoverLimits,
    /// What the pipeline changed in the problem on its own (e.g. a roll-off added to an improper
    /// weight), one sentence each.
    pub notes: Vec<String>,
}

/// The controllers and models of a design, with its summary.
#[derive(Debug, Clone)]
pub struct DesignResult {
    /// The plant with its exact delays.
    pub plant: StateSpace,
    /// The plant with delays replaced by Padé approximants.
    pub plant_rational: StateSpace,
    /// ncfsyn shaping weights W1, W2 (rational), when given.
    pub w1: Option<StateSpace>,
    /// See `w1`.
    pub w2: Option<StateSpace>,
    /// The synthesized controller before the boost.
    pub synthesized: StateSpace,
    /// The boosted full-order controller (equal to `synthesized` without boost).
    pub full: StateSpace,
    /// The reduced controller, when reduction ran.
    pub reduced: Option<StateSpace>,
    /// The discrete controller, when discretization ran.
    pub discrete: Option<StateSpace>,
    /// Second-order sections of the discrete controller.
    pub sos: Option<Sos>,
    /// Numbers.
    pub summary: DesignSummary,
}

impl DesignResult {
    /// The final continuous controller: reduced when reduction ran, else the full one.
    pub fn final_continuous(&self) -> &StateSpace {
        self.reduced.as_ref().unwrap_or(&self.full)
    }
}

fn scaled(c: &StateSpace, k: f64) -> StateSpace {
    let mut s = c.clone();
    s.c *= faer::Scale(k);
    s.d *= faer::Scale(k);
    s
}

/// Residualizes (singular perturbation, DC contribution kept) the modes of `c` faster than `w_max`
/// rad/s; returns the controller and the number of modes removed.
///
/// Why: the central loop-shaping controller at γ = factor·γ_min has one mode that runs off to
/// infinity as factor → 1 (the optimal controller has one state fewer, McFarlane & Glover 1990).
/// Left in, it is a nearly static path that costs nothing in the loop but makes every frequency
/// sweep of a delayed loop span its bandwidth. In Schur coordinates ẋ₁ = T₁₁x₁ + T₁₂x₂ + B₁u,
/// ẋ₂ = T₂₂x₂ + B₂u; setting ẋ₂ = 0 gives B₁ − T₁₂T₂₂⁻¹B₂ and D − C₂T₂₂⁻¹B₂. The error at ω is of
/// order ω/|λ| relative to that mode's contribution.
fn residualize_fast_modes(c: &StateSpace, w_max: f64) -> Result<(StateSpace, usize)> {
    use faer::linalg::solvers::Solve;
    let n = c.nx();
    if n == 0 {
        return Ok((c.clone(), 0));
    }
    let mut sch = skyloop_linalg::schur::real_schur(c.a.as_ref())?;
    let n1 = skyloop_linalg::schur::reorder_schur(&mut sch, |l| l.norm() <= w_max)?;
    if n1 == n {
        return Ok((c.clone(), 0));
    }
    let (t, q) = (&sch.t, &sch.q);
    let b = q.transpose() * &c.b;
    let cc = &c.c * q;
    let t22 = t.get(n1.., n1..).to_owned();
    let lu = t22.full_piv_lu();
    let x = lu.solve(b.get(n1.., ..));
    if !x.norm_max().is_finite() {
        return Err(LtiError::Numerical(
            "residualizing fast controller modes: singular block".into(),
        ));
    }
    let a1 = t.get(..n1, ..n1).to_owned();
    let b1 = b.get(..n1, ..) - t.get(..n1, n1..) * &x;
    let c1 = cc.get(.., ..n1).to_owned();
    let d1 = &c.d - cc.get(.., n1..) * &x;
    let out = StateSpace::new(a1, b1, c1, d1, c.dt)?;
    Ok((out, n - n1))
}

fn rational(sys: &StateSpace, order: usize) -> StateSpace {
    if sys.has_delay() {
        sys.pade(order)
    } else {
        sys.clone()
    }
}

/// Runs the whole pipeline of a checked spec: synthesis (ncfsyn, mixsyn or a given controller) →
/// gain boost → balanced reduction → Tustin, with γ, b(P,C) and classic and disk margins after each
/// step ([`DesignSummary::stages`]).
///
/// # Errors
/// A synthesis that fails (no stabilizing Riccati solution, γ infeasible), a boost or reduction that
/// destabilizes the loop, or a model the spec names that cannot be evaluated.
///
/// # Examples
/// The bicopter paper's Section IV design (`examples/bicopter.toml`): γ_min = 1.748 with a
/// 3rd-order Padé, and a 5th-order controller with PM 65.9° and GM 7.25 dB after boost and reduction.
/// ```
/// use skyloop::design::{design, DesignSpec};
///
/// let text = include_str!("../../../../examples/bicopter.toml");
/// let spec = DesignSpec::from_toml_str(text, std::path::Path::new("."))?;
/// let r = design(&spec)?;
/// assert!((r.summary.gamma_min.expect("ncfsyn") - 1.748).abs() < 5e-4);
/// let last = r.summary.stages.last().expect("stages");
/// assert_eq!(last.order, 5);
/// assert!((last.margins.phase_margin_deg - 65.9).abs() < 0.1);
/// assert!((last.margins.gain_margin_db - 7.25).abs() < 0.01);
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn design(spec: &DesignSpec) -> crate::error::Result<DesignResult> {
    let plant = spec.load_model("plant.model", &spec.plant.model)?;
    if plant.ny() != 1 || plant.nu() != 1 {
        return Err(LtiError::Dimension(format!(
            "plant.model: the design pipeline handles SISO loops, the plant is {}x{}",
            plant.ny(),
            plant.nu()
        ))
        .into());
    }
    let pade = spec.plant.pade_order;
    let plant_rational = rational(&plant, pade);
    let syn = &spec.synthesis;

    // Step 1: synthesis.
    let mut notes: Vec<String> = Vec::new();
    let s = steps::synthesize(spec, &plant, &plant_rational, &mut notes)?;
    let is_ncf = syn.method == SynthesisMethod::Ncfsyn;
    // Modes beyond 100x the fastest dynamics of the plant and weights are numerical artefacts of
    // γ near γ_opt (see residualize_fast_modes); 100x keeps the change ≤ 1% up to those dynamics.
    let mut fast_modes_removed = 0;
    let synthesized = if syn.method == SynthesisMethod::Given {
        s.controller
    } else {
        let mut hi = skyloop_lti::freqresp::dynamics_range(&plant_rational)?.1;
        for w in [&s.w1, &s.w2].into_iter().flatten() {
            hi = hi.max(skyloop_lti::freqresp::dynamics_range(w)?.1);
        }
        let (c, k) = residualize_fast_modes(&s.controller, 100.0 * hi)?;
        fast_modes_removed = k;
        c
    };

    // Step 3 before step 2: reduction (balanced truncation and SPA) is linear in a scalar gain,
    // balred(k·C) = k·balred(C), so the unboosted controller is reduced once and the boost can
    // target the crossover of the loop that will actually fly (the reduced one, as the paper reports).
    let reduced0 = steps::reduce(spec, &synthesized, &mut notes)?;
    // Step 2: gain boost (paper: K∞ scaled up until the crossover is as high as the plant allows).
    let target = reduced0.as_ref().map(|r| &r.sys).unwrap_or(&synthesized);
    let boost_gain = steps::boost_gain(spec, &plant, target)?;
    let full = scaled(&synthesized, boost_gain);
    let mut hsv = Vec::new();
    let mut reduction_error_bound = None;
    let reduced = reduced0.map(|red| {
        hsv = red.hsv.iter().map(|h| h * boost_gain).collect();
        reduction_error_bound = Some(red.error_bound * boost_gain);
        scaled(&red.sys, boost_gain)
    });

    // Analysis of every step. The synthesis step's γ is ncfsyn's exact one; after boost and
    // reduction C is no longer W1·K∞·W2 with the synthesized K∞, so γ is the 4-block norm on a
    // grid (see loop_metrics::shaped_gamma).
    let mut controllers: Vec<steps::Stage> = vec![("synthesis", &synthesized, s.gamma, false)];
    if spec.boost.is_some() {
        controllers.push(("boost", &full, None, is_ncf));
    }
    if let Some(r) = &reduced {
        controllers.push(("reduction", r, None, is_ncf));
    }
    let weights = (s.w1.as_ref(), s.w2.as_ref());
    let stages = steps::analyse(&plant, &plant_rational, weights, &controllers)?;
    let mut reduced_vs_full = None;
    if let (Some(r), Some(st)) = (&reduced, stages.last()) {
        let fc = st.margins.crossover_hz;
        if fc.is_finite() && fc > 0.0 {
            let band = spec.analysis.crossover_band;
            reduced_vs_full = Some(closeness(r, &full, fc / band, fc * band)?);
        }
    }

    // Step 4: Tustin discretization of the final controller.
    let final_c = reduced.as_ref().unwrap_or(&full);
    let (discrete, sos, dsum) = match &spec.discretize {
        Some(d) => {
            let (cd, sos, ds) = steps::discretize(d, final_c, spec.analysis.compare_up_to_hz)?;
            (Some(cd), Some(sos), Some(ds))
        }
        None => (None, None, None),
    };

    let last = stages.last().map(|s| s.margins.crossover_hz).unwrap_or(f64::NAN);
    let limits = crossover_limits(&plant, last)?;
    let summary = DesignSummary {
        name: spec.name.clone(),
        method: format!("{:?}", syn.method).to_lowercase(),
        gamma_min: s.gamma_min,
        factor: s.factor,
        boost_gain,
        fast_modes_removed,
        notes,
        stages,
        hsv,
        reduction_error_bound,
        reduced_vs_full,
        discrete: dsum,
        limits,
    };
    Ok(DesignResult {
        plant,
        plant_rational,
        w1: s.w1,
        w2: s.w2,
        synthesized,
        full,
        reduced,
        discrete,
        sos,
        summary,
    })
}
