//! What [`identify`](super::identify) found, as a value, as JSON and as a figure.

use std::collections::{BTreeMap, HashMap};

use num_complex::Complex64 as C64;
use skyloop_plot::bode::BodeData;
use skyloop_plot::frf::{plot_frf, FrfEstimate};
use skyloop_sysid::fit::{FitResult, TfFit};
use skyloop_sysid::logs::Span;
use skyloop_sysid::spectral::Frf;

use super::{Uncertainty, Validation, COHERENT};
use crate::error::Result;

/// Units of the identified quantities (with `--axis`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Units {
    /// Plant input, e.g. "PID unit".
    pub input: String,
    /// Plant output, e.g. "deg/s".
    pub output: String,
    /// Each parameter of the default model: K "deg/s² per PID unit", tau and Td "s".
    pub params: BTreeMap<String, String>,
}

/// What [`identify`](super::identify) found.
#[derive(Debug, Clone)]
pub struct Identification {
    /// "input → output", the plot's title.
    pub title: String,
    /// Plant input column used.
    pub input: String,
    /// Plant output column used.
    pub output: String,
    /// Instrument (excitation) column, `None` for an open-loop estimate.
    pub instrument: Option<String>,
    /// Measured disturbance conditioned out of the spectra (the throttle), `None` for none.
    pub disturbance: Option<String>,
    /// Firmware and axis when `--axis` chose the channels, e.g. ("Betaflight", "roll").
    pub preset: Option<(String, String)>,
    /// Units, with `--axis`.
    pub units: Option<Units>,
    /// The spans of the log the estimate used, s.
    pub segments: Vec<Span>,
    /// The selected span cut into stretches used or not, each with its reason (`segments` are the
    /// used ones).
    pub timeline: Vec<super::airborne::SegmentVerdict>,
    /// The frequency-response estimate with coherence and confidence.
    pub frf: Frf,
    /// The coherence-supported band (see [`coherent_band`](super::coherent_band)), Hz.
    pub coherent_band_hz: Option<(f64, f64)>,
    /// The band the fit used, Hz: `--fmin-hz`/`--fmax-hz`, or with `--axis` the one
    /// [`supported_band`](super::supported_band) chose; `None` when the fit used every point.
    pub fit_band_hz: Option<(f64, f64)>,
    /// The flight controller's clock at log time 0, s: a segment's `from_s` as the firmware's clock
    /// (the `time_s` of `skyloop log export`) is `from_s + clock_origin_s`.
    pub clock_origin_s: f64,
    /// The parametric fit of `--model` with its parsed expression; its `stderr` is the larger of the
    /// model-based and the jackknife error.
    pub fit: Option<(skyloop_lti::expr::Expr, FitResult)>,
    /// The two error estimates behind the fit's reported `stderr`.
    pub uncertainty: Option<Uncertainty>,
    /// The held-out validation of the fit.
    pub validation: Option<Validation>,
    /// The rational fit of `--tf`.
    pub tf: Option<TfFit>,
    /// What the workflow chose on the user's behalf (segments, the band).
    pub notes: Vec<String>,
    /// What the user should act on: an open-loop estimate of closed-loop data, a fit that did not
    /// converge or ended on a bound, a channel logged too slowly for the band.
    pub warnings: Vec<String>,
}

/// Warnings for a fit that stopped at the iteration limit, ended on a bound or has undetermined errors.
pub(crate) fn fit_warnings(r: &FitResult, warnings: &mut Vec<String>) {
    if !r.converged {
        warnings.push(format!(
            "the fit did not converge ({} iterations, limit reached): its parameters are not a minimum",
            r.iterations
        ));
    }
    if !r.at_bounds.is_empty() {
        warnings.push(format!(
            "the fit ended on a bound for {}: the data do not determine it within the bounds",
            r.at_bounds.join(", ")
        ));
    }
    let nan: Vec<&str> = r
        .stderr
        .iter()
        .filter(|(_, s)| !s.is_finite())
        .map(|(k, _)| k.as_str())
        .collect();
    if !nan.is_empty() || r.params.values().any(|v| !v.is_finite()) {
        warnings.push(format!(
            "the fit's standard errors are undetermined for {}: the data do not constrain them",
            if nan.is_empty() {
                "some parameters".to_string()
            } else {
                nan.join(", ")
            }
        ));
    }
}

impl Identification {
    /// `{"frf": {freq_hz, mag, phase_deg, coherence, dof, rel_std}, "fit": {params, stderr, fit_percent, converged,
    /// at_bounds, units}, "tf": {num, den, delay_s, fit_percent}, "segments": [{from_s, to_s,
    /// from_clock_s, to_clock_s}], "clock_origin_s", "instrument", "disturbance", "input", "output",
    /// "coherent_band_hz": [lo, hi], "fit_band_hz": [lo, hi], "uncertainty", "validation":
    /// {fit_percent, frf_residual, ..}, "converged", "at_bounds", "warnings"}`, as `skyloop identify
    /// --json` prints it (a non-finite number is null). Segment times are log seconds (`from_s`,
    /// `to_s`, the time axis of `log plot`) and the flight controller's clock (`*_clock_s`, the
    /// `time_s` of `log export`); `clock_origin_s` is their difference.
    pub fn to_json(&self) -> serde_json::Value {
        let num = |x: f64| {
            if x.is_finite() {
                serde_json::json!(x)
            } else {
                serde_json::Value::Null
            }
        };
        let map = |m: &BTreeMap<String, f64>| {
            m.iter()
                .map(|(k, s)| (k.clone(), num(*s)))
                .collect::<serde_json::Map<_, _>>()
        };
        let frf = &self.frf;
        let mut v = serde_json::json!({
            "frf": {
                "freq_hz": frf.freq_hz,
                "mag": frf.mag(),
                "phase_deg": frf.phase_deg(),
                "coherence": frf.coherence,
                "dof": frf.dof,
                "rel_std": frf.rel_std(),
            },
            "input": self.input,
            "output": self.output,
            "instrument": self.instrument,
            "disturbance": self.disturbance,
            "segments": self
                .segments
                .iter()
                .map(|s| serde_json::json!({
                    "from_s": s.from_s,
                    "to_s": s.to_s,
                    "from_clock_s": s.from_s + self.clock_origin_s,
                    "to_clock_s": s.to_s + self.clock_origin_s,
                }))
                .collect::<Vec<_>>(),
            "timeline": self.timeline,
            "clock_origin_s": self.clock_origin_s,
            "fit_band_hz": self.fit_band_hz.map(|(a, b)| [a, b]),
            "coherent_band_hz": self.coherent_band_hz.map(|(a, b)| [a, b]),
            "coherence_threshold": COHERENT,
            "warnings": self.warnings,
        });
        if let Some((firmware, axis)) = &self.preset {
            v["firmware"] = serde_json::json!(firmware);
            v["axis"] = serde_json::json!(axis);
        }
        if let Some(u) = &self.units {
            v["units"] = serde_json::json!(u);
        }
        if let Some((_, r)) = &self.fit {
            v["fit"] = serde_json::json!({
                "params": map(&r.params),
                "stderr": map(&r.stderr),
                "fit_percent": num(r.fit_percent),
                "converged": r.converged,
                "at_bounds": r.at_bounds,
            });
            v["converged"] = serde_json::json!(r.converged && r.stderr.values().all(|s| s.is_finite()));
            v["at_bounds"] = serde_json::json!(r.at_bounds);
        }
        if let Some(u) = &self.uncertainty {
            v["uncertainty"] = serde_json::json!({
                "model_stderr": map(&u.model_stderr),
                "jackknife_stderr": map(&u.jackknife_stderr),
                "blocks": u.blocks,
                "blocks_used": u.blocks_used,
            });
        }
        if let Some(val) = &self.validation {
            v["validation"] = serde_json::json!({
                "train_blocks": val.train_blocks,
                "test_blocks": val.test_blocks,
                "train_fit_percent": num(val.train_fit_percent),
                "fit_percent": num(val.fit_percent),
                "frf_residual": num(val.frf_residual),
                "weighted_fit_percent": num(val.weighted_fit_percent),
            });
        }
        if let Some(t) = &self.tf {
            v["tf"] =
                serde_json::json!({"num": t.num, "den": t.den, "delay_s": t.delay_s, "fit_percent": t.fit_percent});
        }
        v
    }
}

/// Plots the measured FRF with its 95 % band and the fitted models (SVG or PNG by extension).
///
/// # Errors
/// A model that cannot be evaluated on the grid, or a file that cannot be written.
pub fn plot_identification(path: &std::path::Path, id: &Identification) -> Result<()> {
    let (frf, fit, tf) = (&id.frf, id.fit.as_ref(), id.tf.as_ref());
    let est = FrfEstimate {
        freq_hz: frf.freq_hz.clone(),
        mag_db: frf.mag_db(),
        phase_deg: frf.phase_deg(),
        mag_band_db: frf.mag_band_db(1.96),
        phase_band_deg: frf.phase_band_deg(1.96),
        coherence: frf.coherence.clone(),
        fit_band_hz: id.fit_band_hz,
    };
    let mut fits = Vec::new();
    let s_of = |f: f64| C64::new(0.0, 2.0 * std::f64::consts::PI * f);
    let bode = |label: String, g: Vec<C64>| BodeData {
        label,
        freq_hz: frf.freq_hz.clone(),
        mag_db: g.iter().map(|g| 20.0 * g.norm().log10()).collect(),
        phase_deg: skyloop_sysid::spectral::unwrap_deg(g.iter().map(|g| g.arg().to_degrees())),
    };
    if let Some((expr, r)) = fit {
        let params: HashMap<String, f64> = r.params.iter().map(|(k, v)| (k.clone(), *v)).collect();
        let g = frf
            .freq_hz
            .iter()
            .map(|f| expr.eval(s_of(*f), &params))
            .collect::<std::result::Result<Vec<_>, _>>()?;
        fits.push(bode(format!("fit ({:.1} %)", r.fit_percent), g));
    }
    if let Some(t) = tf {
        fits.push(bode(
            format!("tf fit ({:.1} %)", t.fit_percent),
            frf.freq_hz.iter().map(|f| t.eval(s_of(*f))).collect(),
        ));
    }
    plot_frf(path, &id.title, &est, &fits)?;
    Ok(())
}
