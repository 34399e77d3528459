//! Why a synthesis failed, said about the models the user gave: a Riccati solver that reports a
//! singular invariant subspace or non-finite entries is reporting a property of the plant or the
//! weights (entries beyond the range the solvers resolve, dynamics spread over too many decades,
//! poles on the imaginary axis of a generalized plant), and that property, with what to change, is
//! the first line of the message; the solver's own words follow on a second line.

use skyloop_lti::StateSpace;
use skyloop_robust::RobustError;

/// Largest entry magnitude (and smallest nonzero one, inverted) the Riccati solvers resolve: their
/// Hamiltonians square the entries, and 1e±150 squared leaves the floating-point range.
const ENTRY_RANGE: f64 = 1e100;

/// Largest ratio of the largest to the smallest nonzero entry: D12's rank, for one, is judged
/// against 1e-10 of the largest entry, so a 0.1 control weight beside a 1e75 entry reads as zero.
/// (Realization rounding leaves entries near 1e-16 of the largest, well inside.)
const ENTRY_SPREAD: f64 = 1e20;

/// Most decades the poles of one model may span before the Riccati equations, which mix the
/// fastest and slowest modes in one matrix, lose the slow ones to rounding.
const POLE_DECADES: f64 = 10.0;

/// Which synthesis the models feed: a generalized plant (hinfsyn, musyn) may not have poles on the
/// imaginary axis; loop shaping's shaped plant may (its normalized coprime factors handle them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Synthesis {
    /// H∞ or μ synthesis of a generalized plant.
    Generalized,
    /// Glover–McFarlane loop shaping of a shaped plant.
    LoopShaping,
}

/// The property of one model that explains a numerical failure, with what to change; None when
/// the model looks well posed. `name` says which model it is ("the shaped plant W2·P·W1").
pub fn model_problem(name: &str, sys: &StateSpace, kind: Synthesis) -> Option<String> {
    let mats = [("A", &sys.a), ("B", &sys.b), ("C", &sys.c), ("D", &sys.d)];
    let (mut hi, mut lo) = (0.0f64, f64::INFINITY);
    for (m, x) in mats {
        for i in 0..x.nrows() {
            for j in 0..x.ncols() {
                let v = x[(i, j)].abs();
                if !v.is_finite() {
                    return Some(format!(
                        "{name} has a NaN or infinite entry in {m} (row {}, column {})",
                        i + 1,
                        j + 1
                    ));
                }
                if v > 0.0 {
                    hi = hi.max(v);
                    lo = lo.min(v);
                }
            }
        }
    }
    if hi > ENTRY_RANGE || lo < 1.0 / ENTRY_RANGE || hi / lo > ENTRY_SPREAD {
        return Some(format!(
            "{name} has state-space entries from {lo:.1e} to {hi:.1e}: the synthesis judges ranks and Riccati \
             solutions relative to the largest entry, and entries more than {:.0} decades apart or beyond 1e±100 \
             are not resolved; rescale its units (a gain of 1e150 is a unit error) or its weights",
            ENTRY_SPREAD.log10()
        ));
    }
    let poles = skyloop_lti::poles_zeros::poles(sys).ok()?;
    let mags: Vec<f64> = poles.iter().map(|p| p.norm()).filter(|m| *m > 0.0).collect();
    let (pmin, pmax) = mags
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), m| (a.min(*m), b.max(*m)));
    if pmax > 0.0 && (pmax / pmin).log10() > POLE_DECADES {
        return Some(format!(
            "{name} has poles from {pmin:.2e} to {pmax:.2e} rad/s ({:.0} decades): the Riccati equations mix both \
             ends and lose the slow modes beyond ~{POLE_DECADES:.0} decades; remove the fastest or slowest \
             dynamics (skyloop reduce, or a simpler weight) or rescale time",
            (pmax / pmin).log10()
        ));
    }
    if kind == Synthesis::Generalized {
        let scale = pmax.max(1.0);
        if let Some(p) = poles.iter().find(|p| p.re.abs() <= 1e-9 * scale) {
            return Some(format!(
                "{name} has a pole on the imaginary axis at {:.4}{:+.4}i: H∞ and μ synthesis need none there \
                 (move a weight's integrator to s + ε, e.g. 1/(s+0.001) instead of 1/s)",
                p.re, p.im
            ));
        }
    }
    None
}

/// Where an unstabilizable or undetectable mode comes from: the models (plant, weights) that have a
/// pole there, and those with a zero there (a pole of one cancelled by a zero of the next in the
/// series connection is the usual cause: the shaped plant keeps the mode but cannot reach or see
/// it), and whether that is a cancellation or a hidden mode (the cause itself) rather than only a
/// pole; None for another error or a mode no model names.
fn mode_origin(e: &RobustError, models: &[(&str, &StateSpace)]) -> Option<(String, bool)> {
    let (mode, verb) = match e {
        RobustError::NotStabilizable { mode, .. } => (*mode, "no input can move"),
        RobustError::NotDetectable { mode, .. } => (*mode, "no output sees"),
        _ => return None,
    };
    let near = |z: &skyloop_lti::c64| (z - mode).norm() <= 1e-6 * mode.norm().max(1.0);
    // Rounding-level parts print as 0, not −0.000000.
    let tidy = |x: f64| if x.abs() < 5e-7 * mode.norm().max(1.0) { 0.0 } else { x };
    let with = |f: fn(&StateSpace) -> skyloop_lti::error::Result<Vec<skyloop_lti::c64>>| -> Vec<&str> {
        models
            .iter()
            .filter(|(_, m)| f(m).is_ok_and(|v| v.iter().any(near)))
            .map(|(n, _)| *n)
            .filter(|n| !n.starts_with("the shaped plant"))
            .collect()
    };
    let (poles, mut zeros) = (
        with(skyloop_lti::poles_zeros::poles),
        with(skyloop_lti::poles_zeros::zeros),
    );
    // A model with a pole and a zero at the mode holds it hidden in its own realization (an
    // input-decoupling or output-decoupling zero), not cancelled by another model.
    let own: Vec<&str> = poles.iter().copied().filter(|n| zeros.contains(n)).collect();
    if !own.is_empty() {
        return Some((format!(
            "the mode at s = {:.6}{:+.6}i ({:.4} Hz) is a hidden mode of {}'s own realization (a pole that {verb}): remove it (minreal) or give that model a realization without it",
            tidy(mode.re),
            tidy(mode.im),
            mode.norm() / (2.0 * std::f64::consts::PI),
            own.join(" and ")
        ), true));
    }
    zeros.retain(|n| !poles.contains(n));
    let at = format!(
        "the mode at s = {:.6}{:+.6}i ({:.4} Hz)",
        tidy(mode.re),
        tidy(mode.im),
        mode.norm() / (2.0 * std::f64::consts::PI)
    );
    let strong = !poles.is_empty() && !zeros.is_empty();
    let named = match (poles.is_empty(), zeros.is_empty()) {
        (true, true) => return None,
        (false, true) => format!("{at} is a pole of {}", poles.join(" and ")),
        (true, false) => format!("{at} is a zero of {}", zeros.join(" and ")),
        (false, false) => format!(
            "{at} is a pole of {} cancelled by a zero of {} in the series connection",
            poles.join(" and "),
            zeros.join(" and ")
        ),
    };
    Some((
        format!(
            "{named}: the shaped plant keeps it, but {verb} it, so no stabilizing Riccati solution exists; move that pole or zero off the point (or off the imaginary axis), or drop the weight's dynamics there"
        ),
        strong,
    ))
}

/// The message for a failed synthesis: the first model problem found, then the solver's words on a
/// second line; the solver's words alone when the failure is a statement about the problem itself
/// (infeasible γ, a rank-deficient D12/D21, bad arguments) or no model explains it.
pub fn explain(what: &str, e: &RobustError, models: &[(&str, &StateSpace)], kind: Synthesis) -> String {
    let numerical = matches!(
        e,
        RobustError::Riccati { .. }
            | RobustError::Numerical(_)
            | RobustError::Lti(_)
            | RobustError::NotStabilizable { .. }
            | RobustError::NotDetectable { .. }
    ) || matches!(e, RobustError::RankDeficient { sigma_min, .. } if *sigma_min > 1e-6);
    // (A D12 or D21 whose smallest singular value is not small was judged deficient against the
    // plant's other, out-of-range entries: the scaling is the cause.)
    let problem = numerical
        .then(|| {
            // A cancellation or a hidden mode is the cause itself; a mode that is merely some
            // model's pole is explained better by that model's problem (a spread, a scaling) when
            // it has one.
            let origin = mode_origin(e, models);
            let strong = origin.as_ref().filter(|(_, strong)| *strong).map(|(t, _)| t.clone());
            strong
                .or_else(|| models.iter().find_map(|(n, m)| model_problem(n, m, kind)))
                .or_else(|| origin.map(|(t, _)| t))
        })
        .flatten();
    match problem {
        Some(p) => format!("{what}: {p}\n  (solver: {e})"),
        None => format!("{what}: {e}"),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn m(e: &str) -> StateSpace {
        crate::model::load_model(e).unwrap()
    }

    #[test]
    fn problems_are_named_for_the_model() {
        let p = model_problem("the plant P", &m("1/((1e-8*s+1)*(1e8*s+1))"), Synthesis::LoopShaping).unwrap();
        assert!(
            p.starts_with("the plant P has poles from") && p.contains("16 decades"),
            "{p}"
        );
        let p = model_problem("W1", &m("1e200/(s+1)"), Synthesis::LoopShaping).unwrap();
        assert!(p.contains("rescale its units"), "{p}");
        let p = model_problem("P", &m("1/(s*(s+1))"), Synthesis::Generalized).unwrap();
        assert!(p.contains("imaginary axis") && p.contains("s+0.001"), "{p}");
        assert!(model_problem("P", &m("1/(s*(s+1))"), Synthesis::LoopShaping).is_none());
        assert!(model_problem("P", &m("10/((s+1)*(0.01*s+1))"), Synthesis::Generalized).is_none());
    }

    #[test]
    fn an_unreachable_mode_is_traced_to_the_weight_and_the_plant() {
        // W1 has poles at ±2j (1/(s²+4)) and P zeros there: the series connection cancels them.
        let e = RobustError::NotDetectable {
            system: "the shaped plant (C, A)",
            mode: skyloop_lti::c64::new(0.0, 2.0),
        };
        let t = explain(
            "ncfsyn",
            &e,
            &[
                ("the plant P", &m("(s^2+4)/(s+1)^3")),
                ("the weight W1", &m("1/(s^2+4)")),
            ],
            Synthesis::LoopShaping,
        );
        assert!(
            t.contains("is a pole of the weight W1 cancelled by a zero of the plant P") && t.contains("0.3183 Hz"),
            "{t}"
        );
        assert!(t.contains("(solver:"), "{t}");
    }

    #[test]
    fn infeasibility_is_not_reexplained() {
        let e = RobustError::Infeasible {
            gamma: 1.0,
            reason: "coupling".into(),
        };
        let t = explain("hinfsyn", &e, &[("P", &m("1/(s*(s+1))"))], Synthesis::Generalized);
        assert_eq!(t, format!("hinfsyn: {e}"));
        let e = RobustError::Numerical("care: U11 singular".into());
        let t = explain(
            "hinfsyn",
            &e,
            &[("the generalized plant P", &m("1/(s*(s+1))"))],
            Synthesis::Generalized,
        );
        assert!(
            t.starts_with("hinfsyn: the generalized plant P has a pole") && t.contains("\n  (solver: "),
            "{t}"
        );
    }
}
