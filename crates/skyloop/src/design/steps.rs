//! The steps of the design pipeline: synthesis (ncfsyn, mixsyn with improper weights rolled off,
//! or a given controller), reduction, the gain boost, the analysis of every step and the Tustin
//! discretization.

use super::loop_metrics::{closeness, closeness_warped, four_block_norms, loop_gain_at, loop_margins};
use super::{rational, DesignSpec, DiscreteSummary, StageSummary, SynthesisMethod};
use crate::spec::design::DiscretizeSpec;
use rayon::prelude::*;
use skyloop_lti::discretize::{c2d, Method as C2dMethod};
use skyloop_lti::error::Result;
use skyloop_lti::feedthrough::drop_negligible_feedthrough;
use skyloop_lti::reduce::{balred, Reduced};
use skyloop_lti::sos::{to_sos, Sos};
use skyloop_lti::{LtiError, StateSpace};
use skyloop_robust::mixsyn::mixsyn;
use skyloop_robust::ncfsyn::{ncfsyn, NcfOptions};
use std::f64::consts::PI;

/// What the synthesis step produced.
pub(super) struct Synthesis {
    /// The controller as synthesized (or given).
    pub controller: StateSpace,
    /// The γ the synthesis achieved (None for a given controller).
    pub gamma: Option<f64>,
    /// ncfsyn: the optimal γ.
    pub gamma_min: Option<f64>,
    /// ncfsyn: the factor above γ_min the controller was built at.
    pub factor: Option<f64>,
    /// ncfsyn: the loop-shaping weights, Padé-rational.
    pub w1: Option<StateSpace>,
    /// ncfsyn: the output weight, Padé-rational.
    pub w2: Option<StateSpace>,
}

/// Step 1: the synthesis the spec asks for.
///
/// # Errors
/// A weight or controller that does not load, a synthesis that fails, a given controller that is
/// not SISO or has delays.
pub(super) fn synthesize(
    spec: &DesignSpec,
    plant: &StateSpace,
    plant_rational: &StateSpace,
    notes: &mut Vec<String>,
) -> crate::error::Result<Synthesis> {
    let syn = &spec.synthesis;
    let pade = spec.plant.pade_order;
    let load = |key: &str, text: &Option<String>| -> Result<Option<StateSpace>> {
        text.as_deref().map(|t| spec.load_model(key, t)).transpose()
    };
    let none = |controller, gamma| Synthesis {
        controller,
        gamma,
        gamma_min: None,
        factor: None,
        w1: None,
        w2: None,
    };
    Ok(match syn.method {
        SynthesisMethod::Ncfsyn => {
            let w1m = load("synthesis.w1", &syn.w1)?;
            let w2m = load("synthesis.w2", &syn.w2)?;
            let opts = NcfOptions {
                factor: syn.factor.unwrap_or(NcfOptions::default().factor),
                pade_order: pade,
            };
            let sol = ncfsyn(plant, w1m.as_ref(), w2m.as_ref(), &opts)?;
            Synthesis {
                controller: sol.controller,
                gamma: Some(sol.gamma),
                gamma_min: Some(sol.gamma_min),
                factor: Some(opts.factor),
                w1: w1m.map(|w| rational(&w, pade)),
                w2: w2m.map(|w| rational(&w, pade)),
            }
        }
        SynthesisMethod::Mixsyn => {
            let ws = proper_weight(spec, plant_rational, "synthesis.ws", &syn.ws, notes)?;
            let wks = proper_weight(spec, plant_rational, "synthesis.wks", &syn.wks, notes)?;
            let wt = proper_weight(spec, plant_rational, "synthesis.wt", &syn.wt, notes)?;
            let sol = mixsyn(
                plant_rational,
                ws.as_ref(),
                wks.as_ref(),
                wt.as_ref(),
                &Default::default(),
            )?;
            none(sol.controller, Some(sol.gamma))
        }
        SynthesisMethod::Given => {
            let c = load("synthesis.controller", &syn.controller)?
                .ok_or_else(|| LtiError::InvalidArgument("synthesis.controller: missing".into()))?;
            if c.ny() != 1 || c.nu() != 1 {
                return Err(LtiError::Dimension("synthesis.controller: must be SISO".into()).into());
            }
            if c.has_delay() {
                return Err(LtiError::Unsupported("synthesis.controller: must not have delays".into()).into());
            }
            none(c, None)
        }
    })
}

/// A mixsyn weight, loaded. An improper weight (W_T = s/ω_T is the textbook one) gets the roll-off
/// MATLAB's users add by hand, two decades above the plant's fastest dynamics, and a note says so.
fn proper_weight(
    spec: &DesignSpec,
    plant_rational: &StateSpace,
    key: &str,
    text: &Option<String>,
    notes: &mut Vec<String>,
) -> Result<Option<StateSpace>> {
    let Some(t) = text.as_deref() else { return Ok(None) };
    match spec.load_model(key, t) {
        Err(e) if e.to_string().contains("improper") => {
            let roll_w = 100.0 * skyloop_lti::freqresp::dynamics_range(plant_rational)?.1;
            for k in 1..=4 {
                let rolled = format!("({t})/(s/{roll_w:.6e}+1)^{k}");
                if let Ok(m) = spec.load_model(key, &rolled) {
                    notes.push(format!(
                        "{key} = \"{t}\" is improper; synthesized with {key} = \"{rolled}\" (a roll-off of order {k} at {roll_w:.4e} rad/s, two decades above the plant's fastest dynamics; give a proper weight to choose it yourself)"
                    ));
                    return Ok(Some(m));
                }
            }
            Err(e)
        }
        r => r.map(Some),
    }
}

/// Step 3: the spec's reduction of the (unboosted) controller; None without one, or when the
/// order asked for is not below the controller's (as MATLAB's balred: not an error, a note).
///
/// # Errors
/// An unknown reduction method or a reduction that fails.
pub(super) fn reduce(spec: &DesignSpec, synthesized: &StateSpace, notes: &mut Vec<String>) -> Result<Option<Reduced>> {
    let Some(r) = &spec.reduction else { return Ok(None) };
    let method = r
        .method
        .parse()
        .map_err(|e| LtiError::InvalidArgument(format!("reduction.method: {e}")))?;
    if r.order >= synthesized.nx() {
        notes.push(format!(
            "reduction.order {} is not below the controller order {}: nothing to reduce, the controller is kept as synthesized",
            r.order,
            synthesized.nx()
        ));
        return Ok(None);
    }
    let mut red =
        balred(synthesized, r.order, method).map_err(|e| LtiError::InvalidArgument(format!("reduction: {e}")))?;
    // Singular perturbation gives a strictly proper controller a feedthrough D + C₂A₂₂⁻¹B₂ that
    // may be rounding (−7·10⁻⁸ for the bicopter): dropped where it is below 1e-4 of the response up
    // to two decades above the controller's dynamics, so the printed zpk, the files and the C
    // header show no zero at |CB|/|D| (3.4·10⁸ rad/s there) that the controller does not have.
    let trimmed = drop_negligible_feedthrough(&red.sys, 1e-4)?;
    for (i, j, d, share) in &trimmed.dropped {
        notes.push(format!(
            "reduction: feedthrough D[{i},{j}] = {d:.3e} dropped as negligible (before the gain boost; at most {share:.1e} of the reduced controller's response up to {:.3e} Hz); it only put a zero near {:.2e} rad/s",
            trimmed.up_to_rad_s / (2.0 * std::f64::consts::PI),
            zero_of_feedthrough(&red.sys, *i, *j, *d),
        ));
    }
    red.sys = trimmed.sys;
    Ok(Some(red))
}

/// The zero a feedthrough d puts on entry (i, j): where |c_i·b_j|/ω reaches |d|, |c_i·b_j|/|d| rad/s
/// (the first Markov parameter; infinity when it vanishes).
fn zero_of_feedthrough(sys: &StateSpace, i: usize, j: usize, d: f64) -> f64 {
    let cb: f64 = (0..sys.nx()).map(|k| sys.c[(i, k)] * sys.b[(k, j)]).sum();
    cb.abs() / d.abs()
}

/// Step 2: the boost gain, 1 without a `[boost]`: the given gain, or the one that puts the
/// crossover of P·`target` at `boost.crossover_hz`.
///
/// # Errors
/// A loop gain at the asked crossover that is zero or not finite.
pub(super) fn boost_gain(spec: &DesignSpec, plant: &StateSpace, target: &StateSpace) -> Result<f64> {
    let Some(b) = &spec.boost else { return Ok(1.0) };
    Ok(match (b.crossover_hz, b.gain) {
        (Some(f), _) => {
            let g = loop_gain_at(plant, target, 2.0 * PI * f)?;
            if !(g > 0.0 && g.is_finite()) {
                return Err(LtiError::Numerical(format!(
                    "boost.crossover_hz: the loop gain at {f} Hz is {g}, cannot scale it to 1"
                )));
            }
            1.0 / g
        }
        (None, Some(g)) => g,
        (None, None) => 1.0,
    })
}

/// A step to analyse: its name, its controller, its known γ, and whether γ is to be read as the
/// 4-block norm on the grid instead.
pub(super) type Stage<'a> = (&'a str, &'a StateSpace, Option<f64>, bool);

/// γ, b(P, C) and the margins of every step; the steps are independent, so they run in parallel.
///
/// # Errors
/// A loop whose norms or margins cannot be evaluated.
pub(super) fn analyse(
    plant: &StateSpace,
    plant_rational: &StateSpace,
    (w1, w2): (Option<&StateSpace>, Option<&StateSpace>),
    steps: &[Stage],
) -> Result<Vec<StageSummary>> {
    steps
        .par_iter()
        .map(|&(name, c, gamma, grid)| -> Result<StageSummary> {
            let (first, margins) = rayon::join(
                || -> Result<(f64, Option<f64>)> {
                    let (g, inv_b) = four_block_norms(plant_rational, w1, w2, c)?;
                    let b = if inv_b.is_finite() { 1.0 / inv_b } else { 0.0 };
                    Ok((b, if grid { Some(g) } else { gamma }))
                },
                || loop_margins(plant, c),
            );
            let (ncf_margin, gamma) = first?;
            Ok(StageSummary {
                stage: name.into(),
                order: c.nx(),
                gamma,
                ncf_margin,
                margins: margins?,
            })
        })
        .collect()
}

/// Step 4: the Tustin discretization of `c` with its second-order sections and its closeness to
/// the continuous controller up to `compare_up_to_hz`.
///
/// # Errors
/// A controller that cannot be discretized or factored.
pub(super) fn discretize(
    d: &DiscretizeSpec,
    c: &StateSpace,
    compare_up_to_hz: f64,
) -> Result<(StateSpace, Sos, DiscreteSummary)> {
    let dt = 1.0 / d.rate_hz;
    let prewarp_rad_s = d.prewarp_hz.map(|f| 2.0 * PI * f);
    let cd = c2d(c, dt, C2dMethod::Tustin { prewarp_rad_s })?;
    let sos = to_sos(&cd)?;
    let vs_continuous = closeness(&cd, c, 0.01, compare_up_to_hz)?;
    // Tustin with effective period T' maps e^{jωT} to s = j(2/T')·tan(ωT/2).
    let t_eff = match prewarp_rad_s {
        Some(w) => 2.0 * (w * dt / 2.0).tan() / w,
        None => dt,
    };
    let vs_warped = closeness_warped(&cd, c, 0.01, compare_up_to_hz, |w| 2.0 / t_eff * (w * dt / 2.0).tan())?;
    let ds = DiscreteSummary {
        rate_hz: d.rate_hz,
        vs_continuous,
        vs_warped,
    };
    Ok((cd, sos, ds))
}
