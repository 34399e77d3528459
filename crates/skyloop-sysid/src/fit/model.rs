//! Fitting an expression model with named parameters, such as the bicopter's
//! `K*exp(-Td*s)/(tau*s+1) * (z^2 - s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5)`, to a measured response.

use std::collections::{BTreeMap, HashMap};

use num_complex::Complex64 as C64;
use skyloop_lti::expr::Expr;

use super::{lm, FitOptions, FitResult, Target};
use crate::error::{invalid, Result, SysidError};
use crate::spectral::Frf;

/// One parameter: its name, initial value and bounds.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSpec {
    /// Name as in the expression.
    pub name: String,
    /// Initial value.
    pub init: f64,
    /// Lower bound (−∞ for none).
    pub lower: f64,
    /// Upper bound (+∞ for none).
    pub upper: f64,
}

impl ParamSpec {
    /// An unbounded parameter.
    pub fn new(name: &str, init: f64) -> ParamSpec {
        ParamSpec {
            name: name.to_string(),
            init,
            lower: f64::NEG_INFINITY,
            upper: f64::INFINITY,
        }
    }
}

/// How well a model with given parameters matches a measured response.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Evaluation {
    /// 100·(1 − ‖G_data − G_model‖/‖G_data − mean G_data‖), percent (MATLAB's NRMSE fit).
    pub fit_percent: f64,
    /// Root mean square of |ln(G_model/G_data)| over the points (unweighted; 0.1 is about 0.9 dB or
    /// 5.7° of combined magnitude and phase error).
    pub log_residual_rms: f64,
    /// Number of points compared.
    pub points: usize,
    /// 100·(1 − ‖W·ln(G_model/G_data)‖/‖W·(ln G_data − mean)‖), percent: the share of the measured
    /// response's variation in log magnitude and unwrapped phase the model explains, each point
    /// weighted by its inverse variance (the fit's own weights). Unlike [`Self::fit_percent`], which
    /// large low-frequency points dominate, a noisy point counts as little as it does in the fit.
    pub weighted_fit_percent: f64,
}

/// Compares `model` at `params` with `frf` on the points [`FitOptions`] selects (its band; weights
/// are not used).
///
/// # Errors
/// No point in the band, or a model that cannot be evaluated.
pub fn evaluate(frf: &Frf, model: &Expr, params: &BTreeMap<String, f64>, o: &FitOptions) -> Result<Evaluation> {
    let target = Target::new(frf, o)?;
    let map: HashMap<String, f64> = params.iter().map(|(k, v)| (k.clone(), *v)).collect();
    let m = target
        .w
        .iter()
        .map(|w| {
            model
                .eval(C64::new(0.0, *w), &map)
                .map_err(|e| SysidError::InvalidArgument(e.to_string()))
        })
        .collect::<Result<Vec<_>>>()?;
    let n = m.len();
    let ss: f64 = m.iter().zip(&target.g).map(|(gm, gd)| (gm / gd).ln().norm_sqr()).sum();
    Ok(Evaluation {
        fit_percent: target.fit_percent(&m),
        log_residual_rms: (ss / n as f64).sqrt(),
        points: n,
        weighted_fit_percent: target.weighted_log_fit_percent(&m),
    })
}

/// Fits `model`'s parameters to `frf`; every parameter of the expression needs a [`ParamSpec`].
pub fn fit_expr(frf: &Frf, model: &Expr, params: &[ParamSpec], o: &FitOptions) -> Result<FitResult> {
    let names = model.params();
    let missing: Vec<&String> = names.iter().filter(|n| !params.iter().any(|p| &p.name == *n)).collect();
    if !missing.is_empty() {
        return Err(invalid(format!(
            "no initial value for parameter(s) {} of the model",
            missing.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
        )));
    }
    if let Some(p) = params.iter().find(|p| !names.contains(&p.name)) {
        return Err(invalid(format!(
            "'{}' is not a parameter of the model (its parameters: {})",
            p.name,
            names.join(", ")
        )));
    }
    for p in params {
        if !p.init.is_finite() || p.lower.is_nan() || p.upper.is_nan() || p.lower > p.upper {
            return Err(invalid(format!(
                "parameter {}: initial value {} or bounds [{}, {}] invalid",
                p.name, p.init, p.lower, p.upper
            )));
        }
        if p.init < p.lower || p.init > p.upper {
            return Err(invalid(format!(
                "parameter {}: initial value {} outside its bounds [{}, {}]",
                p.name, p.init, p.lower, p.upper
            )));
        }
    }
    let target = Target::new(frf, o)?;
    let eval_all = |x: &[f64]| -> Result<Vec<C64>> {
        let map: HashMap<String, f64> = params.iter().zip(x).map(|(p, v)| (p.name.clone(), *v)).collect();
        target
            .w
            .iter()
            .map(|w| {
                model
                    .eval(C64::new(0.0, *w), &map)
                    .map_err(|e| SysidError::InvalidArgument(e.to_string()))
            })
            .collect()
    };
    let f = |x: &[f64]| -> Result<Vec<f64>> { Ok(target.residuals(&eval_all(x)?, o.error)) };
    let x0: Vec<f64> = params.iter().map(|p| p.init).collect();
    let lo: Vec<f64> = params.iter().map(|p| p.lower).collect();
    let hi: Vec<f64> = params.iter().map(|p| p.upper).collect();
    let res = lm::minimize(f, &x0, &lo, &hi, &o.lm)?;
    let se = lm::standard_errors_correlated(&res, &target.residual_correlation());
    let fit = target.fit_percent(&eval_all(&res.x)?);
    let at_bounds = params
        .iter()
        .zip(&res.x)
        .filter(|(p, x)| **x <= p.lower || **x >= p.upper)
        .map(|(p, _)| p.name.clone())
        .collect();
    Ok(FitResult {
        params: params
            .iter()
            .zip(&res.x)
            .map(|(p, v)| (p.name.clone(), *v))
            .collect::<BTreeMap<_, _>>(),
        stderr: params
            .iter()
            .zip(&se)
            .map(|(p, v)| (p.name.clone(), *v))
            .collect::<BTreeMap<_, _>>(),
        fit_percent: fit,
        cost: res.cost,
        iterations: res.iterations,
        converged: res.converged,
        at_bounds,
    })
}
