//! Parametric models fitted to a measured frequency response: an expression with named parameters and
//! exact delays (`skyloop_lti::expr`), or a rational transfer function of given orders with a delay.
//!
//! The residual at each frequency is the complex log error ln(G_model/G_data) (real part: log
//! magnitude error, imaginary part: phase error in rad; nearly the dB/degree cost of CIFER), or the
//! relative complex error (G_model − G_data)/|G_data|; each frequency is weighted by the coherence
//! weight W_γ = [1.58·(1 − e^(−γ²))]² of Tischler & Remple (Aircraft and Rotorcraft System
//! Identification, eq. 11.4), unless weighting is off.

pub use skyloop_linalg::lm;
pub mod model;
pub mod tfest;

pub use model::{evaluate, fit_expr, Evaluation, ParamSpec};
pub use tfest::{fit_tf, DelaySpec, TfFit};

use std::collections::BTreeMap;

use num_complex::Complex64 as C64;

use crate::error::{invalid, Result, SysidError};
use crate::spectral::Frf;

/// Residual form.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// ln(G_model/G_data) (principal branch).
    Log,
    /// (G_model − G_data)/|G_data|.
    Complex,
}

/// How each measured frequency is weighted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Weighting {
    /// Every point weight 1.
    None,
    /// CIFER's W_γ = [1.58·(1 − e^(−γ²))]² (Tischler & Remple, eq. 11.4).
    Coherence,
    /// The inverse variance of the log error, 2νγ²/(1 − γ²) (Bendat & Piersol eq. 9.90), with γ²
    /// capped at 0.999: maximum likelihood for independent points.
    InverseVariance,
}

/// Options of both fits.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Residual form.
    pub error: ErrorKind,
    /// Weight of each frequency.
    pub weighting: Weighting,
    /// Lowest frequency used, Hz.
    pub fmin_hz: Option<f64>,
    /// Highest frequency used, Hz.
    pub fmax_hz: Option<f64>,
    /// Levenberg–Marquardt settings.
    pub lm: lm::LmOptions,
}

impl Default for FitOptions {
    fn default() -> FitOptions {
        FitOptions {
            error: ErrorKind::Log,
            weighting: Weighting::InverseVariance,
            fmin_hz: None,
            fmax_hz: None,
            lm: lm::LmOptions::default(),
        }
    }
}

/// A fitted expression model.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FitResult {
    /// Parameter values.
    pub params: BTreeMap<String, f64>,
    /// Standard errors from the Jacobian at the optimum (NaN when undetermined).
    pub stderr: BTreeMap<String, f64>,
    /// 100·(1 − ‖G_data − G_model‖/‖G_data − mean G_data‖) over the fitted points (MATLAB's NRMSE fit).
    pub fit_percent: f64,
    /// Final weighted cost ½Σr².
    pub cost: f64,
    /// Levenberg–Marquardt steps.
    pub iterations: usize,
    /// Whether LM met a tolerance (false: iteration limit).
    pub converged: bool,
    /// Names of parameters that ended on a bound.
    pub at_bounds: Vec<String>,
}

/// The measured points a fit uses: (ω rad/s, G, weight).
pub(crate) struct Target {
    pub w: Vec<f64>,
    /// Smoothing-kernel width of each point's estimate, Hz (see [`Frf::bandwidth_hz`]).
    pub bandwidth_hz: Vec<f64>,
    pub g: Vec<C64>,
    pub weight: Vec<f64>,
}

impl Target {
    pub fn new(frf: &Frf, o: &FitOptions) -> Result<Target> {
        let lo = o.fmin_hz.unwrap_or(0.0);
        let hi = o.fmax_hz.unwrap_or(f64::INFINITY);
        if hi <= lo {
            return Err(invalid(format!("fit frequency range [{lo}, {hi}] Hz is empty")));
        }
        let mut t = Target {
            w: vec![],
            bandwidth_hz: vec![],
            g: vec![],
            weight: vec![],
        };
        for i in 0..frf.freq_hz.len() {
            let f = frf.freq_hz[i];
            let g = frf.response[i];
            if f < lo || f > hi || f <= 0.0 || g.norm() == 0.0 || !g.norm().is_finite() {
                continue;
            }
            let c = frf.coherence.get(i).copied().unwrap_or(1.0).clamp(0.0, 1.0);
            let nu = frf.dof.get(i).copied().unwrap_or(1.0).max(1.0);
            let wt = match o.weighting {
                Weighting::None => 1.0,
                Weighting::Coherence => (1.58 * (1.0 - (-c).exp())).powi(2),
                Weighting::InverseVariance => 2.0 * nu * c.min(0.999) / (1.0 - c.min(0.999)),
            };
            t.w.push(2.0 * std::f64::consts::PI * f);
            t.bandwidth_hz.push(frf.bandwidth_hz.get(i).copied().unwrap_or(0.0));
            t.g.push(g);
            t.weight.push(wt.sqrt());
        }
        if t.w.is_empty() {
            return Err(SysidError::NotEnoughData(format!(
                "no measured frequency within [{lo}, {hi}] Hz"
            )));
        }
        Ok(t)
    }

    /// Weighted residuals [Re, Im] per point for model values `m`.
    pub fn residuals(&self, m: &[C64], kind: ErrorKind) -> Vec<f64> {
        let mut r = Vec::with_capacity(2 * m.len());
        for ((gm, gd), w) in m.iter().zip(&self.g).zip(&self.weight) {
            let e = match kind {
                ErrorKind::Log => (gm / gd).ln(),
                ErrorKind::Complex => (gm - gd) / gd.norm(),
            };
            r.push(w * e.re);
            r.push(w * e.im);
        }
        r
    }

    /// Correlated pairs of residual rows (Re with Re, Im with Im of two points whose smoothing kernels
    /// overlap), as [`lm::standard_errors_correlated`] takes them.
    pub fn residual_correlation(&self) -> Vec<(usize, usize, f64)> {
        let mut out = Vec::new();
        let hz = |i: usize| self.w[i] / (2.0 * std::f64::consts::PI);
        for i in 0..self.w.len() {
            for k in i + 1..self.w.len() {
                let d = hz(k) - hz(i);
                // The points are sorted by frequency: once past both half widths, none further overlaps.
                if d >= 0.5 * (self.bandwidth_hz[i] + self.bandwidth_hz[k]) && d >= self.bandwidth_hz[i] {
                    break;
                }
                let rho = crate::spectral::kernel_correlation(d, self.bandwidth_hz[i], self.bandwidth_hz[k]);
                if rho > 1e-6 {
                    out.push((2 * i, 2 * k, rho));
                    out.push((2 * i + 1, 2 * k + 1, rho));
                }
            }
        }
        out
    }

    /// The inverse-variance weighted log-domain fit percentage of model values `m` (see
    /// [`model::Evaluation::weighted_fit_percent`]): the data's phase is unwrapped along frequency so
    /// that its variation is the response's, not a wrap at ±180°.
    pub fn weighted_log_fit_percent(&self, m: &[C64]) -> f64 {
        let mut logs = Vec::with_capacity(self.g.len());
        let mut prev: Option<f64> = None;
        for g in &self.g {
            let mut ph = g.arg();
            if let Some(p) = prev {
                ph -= std::f64::consts::TAU * ((ph - p) / std::f64::consts::TAU).round();
            }
            prev = Some(ph);
            logs.push(C64::new(g.norm().ln(), ph));
        }
        let w2: Vec<f64> = self.weight.iter().map(|w| w * w).collect();
        let sw: f64 = w2.iter().sum();
        if !(sw > 0.0) {
            return f64::NAN;
        }
        let mean: C64 = logs.iter().zip(&w2).map(|(l, w)| l * w).sum::<C64>() / sw;
        let den: f64 = logs.iter().zip(&w2).map(|(l, w)| w * (l - mean).norm_sqr()).sum();
        let num: f64 = self
            .g
            .iter()
            .zip(m)
            .zip(&w2)
            .map(|((d, m), w)| w * (m / d).ln().norm_sqr())
            .sum();
        if den > 0.0 {
            100.0 * (1.0 - (num / den).sqrt())
        } else {
            f64::NAN
        }
    }

    /// MATLAB-style fit percentage of model values `m`.
    pub fn fit_percent(&self, m: &[C64]) -> f64 {
        let mean: C64 = self.g.iter().sum::<C64>() / self.g.len() as f64;
        let num: f64 = self
            .g
            .iter()
            .zip(m)
            .map(|(d, m)| (d - m).norm_sqr())
            .sum::<f64>()
            .sqrt();
        let den: f64 = self.g.iter().map(|d| (d - mean).norm_sqr()).sum::<f64>().sqrt();
        if den > 0.0 {
            100.0 * (1.0 - num / den)
        } else {
            f64::NAN
        }
    }
}
