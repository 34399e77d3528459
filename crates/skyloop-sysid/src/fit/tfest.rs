//! Rational transfer-function fit of given orders with a delay (like MATLAB's tfest on frequency
//! data): Sanathanan–Koerner iterations on the linearized error N − G·D weighted by 1/|D_prev|
//! (Sanathanan & Koerner, IEEE TAC 1963) give a start, a delay grid search picks the delay, and
//! Levenberg–Marquardt on the log error polishes all coefficients and the delay together.

use faer::linalg::solvers::SolveLstsq;
use faer::Mat;
use num_complex::Complex64 as C64;
use skyloop_lti::poly::Poly;
use skyloop_lti::tf::TransferFunction;

use super::{lm, FitOptions, Target};
use crate::error::{invalid, Result, SysidError};
use crate::spectral::Frf;

/// How the delay is treated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DelaySpec {
    /// A known delay, s.
    Fixed(f64),
    /// Estimated within [0, max_s].
    Estimate {
        /// Largest delay considered, s.
        max_s: f64,
    },
}

/// A fitted rational model num(s)/den(s)·e^(−delay·s).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TfFit {
    /// Numerator coefficients, descending powers of s.
    pub num: Vec<f64>,
    /// Denominator coefficients, descending powers, monic.
    pub den: Vec<f64>,
    /// Delay, s.
    pub delay_s: f64,
    /// MATLAB-style fit percentage over the fitted points.
    pub fit_percent: f64,
    /// Final weighted cost ½Σr².
    pub cost: f64,
}

impl TfFit {
    /// Value at s (rad/s), with the exact delay.
    pub fn eval(&self, s: C64) -> C64 {
        let p = |c: &[f64]| c.iter().fold(C64::new(0.0, 0.0), |acc, &x| acc * s + x);
        p(&self.num) / p(&self.den) * (-self.delay_s * s).exp()
    }

    /// The model as a skyloop-lti transfer function (delay as its input delay).
    pub fn to_tf(&self) -> Result<TransferFunction> {
        let mut tf = TransferFunction::siso(Poly::new(self.num.clone()), Poly::new(self.den.clone()), 0.0)
            .map_err(|e| SysidError::Numerical(e.to_string()))?;
        tf.input_delay[0] = self.delay_s;
        Ok(tf)
    }
}

/// θ = [b_0..b_nz, a_0..a_{np−1}] in the normalized variable x = s/ω0, a_np = 1; model value at x.
fn model_x(theta: &[f64], nz: usize, x: C64) -> (C64, C64) {
    let num = theta[..=nz]
        .iter()
        .rev()
        .fold(C64::new(0.0, 0.0), |acc, &c| acc * x + c);
    let den = theta[nz + 1..]
        .iter()
        .rev()
        .fold(C64::new(1.0, 0.0), |acc, &c| acc * x + c);
    (num, den)
}

/// Sanathanan–Koerner iterations for data g at normalized points x with weights wt.
fn sk(x: &[C64], g: &[C64], wt: &[f64], nz: usize, np: usize, iters: usize) -> Result<Vec<f64>> {
    let nt = nz + 1 + np;
    let m = x.len();
    let mut theta = vec![0.0; nt];
    let mut dprev = vec![1.0; m];
    for _ in 0..iters {
        let a = Mat::<f64>::from_fn(2 * m, nt, |row, col| {
            let k = row / 2;
            let xk = x[k];
            let v = if col <= nz {
                xk.powi(col as i32)
            } else {
                -g[k] * xk.powi((col - nz - 1) as i32)
            };
            let v = v * (wt[k] / dprev[k]);
            if row % 2 == 0 {
                v.re
            } else {
                v.im
            }
        });
        let b = Mat::<f64>::from_fn(2 * m, 1, |row, _| {
            let k = row / 2;
            let v = g[k] * x[k].powi(np as i32) * (wt[k] / dprev[k]);
            if row % 2 == 0 {
                v.re
            } else {
                v.im
            }
        });
        let sol = a.col_piv_qr().solve_lstsq(&b);
        let new: Vec<f64> = (0..nt).map(|i| sol[(i, 0)]).collect();
        if new.iter().any(|v| !v.is_finite()) {
            return Err(SysidError::Numerical("Sanathanan–Koerner step is singular".into()));
        }
        let change = new
            .iter()
            .zip(&theta)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f64, f64::max);
        theta = new;
        for k in 0..m {
            dprev[k] = model_x(&theta, nz, x[k]).1.norm().max(1e-12);
        }
        if change < 1e-12 * (1.0 + theta.iter().fold(0.0f64, |a, b| a.max(b.abs()))) {
            break;
        }
    }
    Ok(theta)
}

/// Fits num/den of `nzeros`/`npoles` (nzeros ≤ npoles) and the delay to `frf`.
pub fn fit_tf(frf: &Frf, nzeros: usize, npoles: usize, delay: DelaySpec, o: &FitOptions) -> Result<TfFit> {
    if npoles == 0 || nzeros > npoles {
        return Err(invalid(format!(
            "orders must satisfy 0 ≤ zeros ≤ poles, 1 ≤ poles; got {nzeros}/{npoles}"
        )));
    }
    let t = Target::new(frf, o)?;
    let nt = nzeros + 1 + npoles;
    if 2 * t.w.len() < nt + 1 {
        return Err(SysidError::NotEnoughData(format!(
            "{} frequencies for {} coefficients",
            t.w.len(),
            nt
        )));
    }
    let w0 = t.w.iter().fold(0.0f64, |a, &b| a.max(b));
    let x: Vec<C64> = t.w.iter().map(|w| C64::new(0.0, w / w0)).collect();
    let (fixed, max_td) = match delay {
        DelaySpec::Fixed(td) if td.is_finite() && td >= 0.0 => (Some(td), td),
        DelaySpec::Estimate { max_s } if max_s.is_finite() && max_s >= 0.0 => (None, max_s),
        _ => return Err(invalid("the delay must be a finite, non-negative number of seconds")),
    };
    let kind = o.error;
    let resid = |theta: &[f64], td: f64| -> Vec<f64> {
        let m: Vec<C64> = x
            .iter()
            .zip(&t.w)
            .map(|(xk, w)| {
                let (n, d) = model_x(theta, nzeros, *xk);
                n / d * C64::new(0.0, -w * td).exp()
            })
            .collect();
        t.residuals(&m, kind)
    };
    let start_for = |td: f64| -> Result<(Vec<f64>, f64)> {
        let g: Vec<C64> =
            t.g.iter()
                .zip(&t.w)
                .map(|(g, w)| g * C64::new(0.0, w * td).exp())
                .collect();
        let th = sk(&x, &g, &t.weight, nzeros, npoles, 30)?;
        let c = 0.5 * resid(&th, td).iter().map(|v| v * v).sum::<f64>();
        Ok((th, c))
    };
    let (theta0, td0) = match fixed {
        Some(td) => (start_for(td)?.0, td),
        None => {
            let steps = 40;
            let mut best: Option<(Vec<f64>, f64, f64)> = None;
            for i in 0..=steps {
                let td = max_td * i as f64 / steps as f64;
                if let Ok((th, c)) = start_for(td) {
                    if c.is_finite() && best.as_ref().is_none_or(|b| c < b.2) {
                        best = Some((th, td, c));
                    }
                }
            }
            let (th, td, _) = best.ok_or_else(|| SysidError::Numerical("no delay gave a finite start".into()))?;
            (th, td)
        }
    };
    // Polish: LM over θ (and the delay when estimated).
    let mut p0 = theta0.clone();
    let (mut lo, mut hi) = (vec![f64::NEG_INFINITY; nt], vec![f64::INFINITY; nt]);
    if fixed.is_none() {
        p0.push(td0);
        lo.push(0.0);
        hi.push(max_td);
    }
    let f = |p: &[f64]| -> Result<Vec<f64>> {
        let td = if fixed.is_none() { p[nt] } else { td0 };
        Ok(resid(&p[..nt], td))
    };
    let res = lm::minimize(f, &p0, &lo, &hi, &o.lm)?;
    let theta = &res.x[..nt];
    let td = if fixed.is_none() { res.x[nt] } else { td0 };
    // Back to s: multiply num and den by ω0^np so that den is monic in s.
    let num: Vec<f64> = (0..=nzeros)
        .rev()
        .map(|i| theta[i] * w0.powi((npoles - i) as i32))
        .collect();
    let mut den: Vec<f64> = vec![1.0];
    den.extend(
        (0..npoles)
            .rev()
            .map(|i| theta[nzeros + 1 + i] * w0.powi((npoles - i) as i32)),
    );
    let mut fit = TfFit {
        num,
        den,
        delay_s: td,
        fit_percent: 0.0,
        cost: res.cost,
    };
    let m: Vec<C64> = t.w.iter().map(|w| fit.eval(C64::new(0.0, *w))).collect();
    fit.fit_percent = t.fit_percent(&m);
    Ok(fit)
}
