//! D-step fitting for DK-iteration: a stable, minimum-phase rational d(s) whose magnitude follows
//! D-scale data |d(jω)| on a frequency grid.
//!
//! |d(jω)|² is a rational function of x = ω²: P(x)/Q(x). P and Q (degree `order`, Q(0) = 1) are
//! fitted by the Sanathanan–Koerner iteration on the linearized residual (P − m²Q)/(m²·Q_prev),
//! which converges to a relative (≈ log-magnitude) least-squares fit. The spectral factor is then
//! taken: the roots of P(−s²) and Q(−s²) come in ± pairs, and the left-half-plane ones become the
//! zeros and poles of d(s); the gain is the log-magnitude least-squares optimum. Frequencies are
//! normalized by their geometric mean for conditioning.

use faer::linalg::solvers::SolveLstsq;
use faer::{c64, Mat};
use skyloop_lti::error::Result;
use skyloop_lti::poly::Poly;
use skyloop_lti::tf::TransferFunction;
use skyloop_lti::{LtiError, StateSpace};

/// A fitted scaling d(s) = gain·Π(s − zᵢ)/Π(s − pᵢ).
#[derive(Debug, Clone)]
pub struct DFit {
    /// Zeros (rad/s), all in the open left half plane.
    pub zeros: Vec<c64>,
    /// Poles (rad/s), all in the open left half plane.
    pub poles: Vec<c64>,
    /// Gain.
    pub gain: f64,
    /// Largest |ln|d(jω)| − ln(mag)| over the data (natural-log units).
    pub max_log_error: f64,
    /// State-space realization (continuous time).
    pub ss: StateSpace,
}

impl DFit {
    /// |d(jω)| at ω rad/s.
    pub fn magnitude(&self, w_rad_s: f64) -> f64 {
        let s = c64::new(0.0, w_rad_s);
        let num: c64 = self.zeros.iter().fold(c64::new(self.gain, 0.0), |acc, z| acc * (s - z));
        let den: c64 = self.poles.iter().fold(c64::new(1.0, 0.0), |acc, p| acc * (s - p));
        (num / den).norm()
    }
}

/// Fits a stable minimum-phase d(s) of the given order to magnitudes `mag` (> 0) at `w_rad_s` (> 0).
pub fn fit_magnitude(w_rad_s: &[f64], mag: &[f64], order: usize) -> Result<DFit> {
    let n = w_rad_s.len();
    if mag.len() != n {
        return Err(LtiError::Dimension(format!(
            "{n} frequencies but {} magnitudes",
            mag.len()
        )));
    }
    if n < 2 * order + 1 {
        return Err(LtiError::InvalidArgument(format!(
            "a fit of order {order} needs at least {} frequencies, got {n}",
            2 * order + 1
        )));
    }
    for k in 0..n {
        if !(w_rad_s[k].is_finite() && w_rad_s[k] > 0.0 && mag[k].is_finite() && mag[k] > 0.0) {
            return Err(LtiError::InvalidArgument(format!(
                "D-scale data point {k} (w = {}, mag = {}) must be finite and > 0",
                w_rad_s[k], mag[k]
            )));
        }
    }
    let w0 = (w_rad_s.iter().map(|w| w.ln()).sum::<f64>() / n as f64).exp();
    let x: Vec<f64> = w_rad_s.iter().map(|w| (w / w0) * (w / w0)).collect();
    let m2: Vec<f64> = mag.iter().map(|m| m * m).collect();
    // Unknowns: p₀..p_order, q₁..q_order (ascending powers of x).
    let nun = 2 * order + 1;
    let mut p = vec![0.0; order + 1];
    let mut q = vec![0.0; order + 1];
    q[0] = 1.0;
    let polyval = |c: &[f64], x: f64| c.iter().rev().fold(0.0, |acc, ci| acc * x + ci);
    let mut qprev: Vec<f64> = vec![1.0; n];
    for _iter in 0..30 {
        let mut a = Mat::<f64>::zeros(n, nun);
        let mut b = Mat::<f64>::zeros(n, 1);
        for k in 0..n {
            let r = 1.0 / (m2[k] * qprev[k]);
            let mut xp = 1.0;
            for i in 0..=order {
                a[(k, i)] = r * xp;
                if i >= 1 {
                    a[(k, order + i)] = -r * m2[k] * xp;
                }
                xp *= x[k];
            }
            b[(k, 0)] = r * m2[k];
        }
        // Column equilibration: powers of x span many decades.
        let scale: Vec<f64> = (0..nun)
            .map(|j| {
                let s = (0..n).map(|k| a[(k, j)] * a[(k, j)]).sum::<f64>().sqrt();
                if s > 0.0 {
                    s
                } else {
                    1.0
                }
            })
            .collect();
        for (j, sj) in scale.iter().enumerate() {
            for k in 0..n {
                a[(k, j)] /= sj;
            }
        }
        let sol = a.col_piv_qr().solve_lstsq(&b);
        let mut change = 0.0_f64;
        for i in 0..=order {
            let v = sol[(i, 0)] / scale[i];
            change = change.max((v - p[i]).abs() / (1.0 + v.abs()));
            p[i] = v;
            if i >= 1 {
                let v = sol[(order + i, 0)] / scale[order + i];
                change = change.max((v - q[i]).abs() / (1.0 + v.abs()));
                q[i] = v;
            }
        }
        if p.iter().chain(&q).any(|v| !v.is_finite()) {
            return Err(LtiError::Numerical("the D-scale fit diverged".into()));
        }
        for k in 0..n {
            // Q must stay positive on the data; a sign change means a poor fit, keep the weight sane.
            qprev[k] = polyval(&q, x[k]).abs().max(1e-300);
        }
        if change < 1e-10 {
            break;
        }
    }
    let zeros = lhp_factor(&p)?;
    let poles = lhp_factor(&q)?;
    // Back to rad/s: s = w0·s̃.
    let zeros: Vec<c64> = zeros.iter().map(|z| z * w0).collect();
    let poles: Vec<c64> = poles.iter().map(|z| z * w0).collect();
    let shape = |w: f64| {
        let s = c64::new(0.0, w);
        let num: c64 = zeros.iter().fold(c64::new(1.0, 0.0), |acc, z| acc * (s - z));
        let den: c64 = poles.iter().fold(c64::new(1.0, 0.0), |acc, p| acc * (s - p));
        (num / den).norm()
    };
    let log_gain = (0..n).map(|k| mag[k].ln() - shape(w_rad_s[k]).ln()).sum::<f64>() / n as f64;
    let gain = log_gain.exp();
    let max_log_error = (0..n)
        .map(|k| (log_gain + shape(w_rad_s[k]).ln() - mag[k].ln()).abs())
        .fold(0.0, f64::max);
    let num = Poly::from_roots(&zeros).scale(gain);
    let den = Poly::from_roots(&poles);
    let ss = skyloop_lti::convert::tf_to_ss(&TransferFunction::siso(num, den, 0.0)?)?;
    Ok(DFit {
        zeros,
        poles,
        gain,
        max_log_error,
        ss,
    })
}

/// The left-half-plane roots of c(−s²) for c ascending in x = ω² (half of them; roots on the
/// imaginary axis, where c changes sign, are moved just left of it).
fn lhp_factor(c: &[f64]) -> Result<Vec<c64>> {
    let mut deg = c.len() - 1;
    while deg > 0 && c[deg].abs() <= 1e-14 * c.iter().fold(0.0_f64, |a, v| a.max(v.abs())) {
        deg -= 1;
    }
    if deg == 0 {
        return Ok(Vec::new());
    }
    // c(−s²) in descending powers of s: coefficient of s^{2i} is c_i (−1)^i.
    let mut desc = vec![0.0; 2 * deg + 1];
    for (i, ci) in c.iter().enumerate().take(deg + 1) {
        desc[2 * deg - 2 * i] = if i % 2 == 0 { *ci } else { -*ci };
    }
    let mut roots = Poly::new(desc).roots()?;
    roots.sort_by(|a, b| a.re.total_cmp(&b.re));
    let mut out: Vec<c64> = roots.into_iter().take(deg).collect();
    for r in out.iter_mut() {
        if r.re > -1e-9 * r.norm().max(1e-300) {
            r.re = -1e-6 * r.norm().max(1e-12);
        }
    }
    // Keep conjugate pairs exact so the polynomial is real.
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_rational_scaling() {
        // Data from d(s) = 2 (s+1)(s+5) / ((s+0.5)(s+20)) (stable, minimum phase): an order-2 fit
        // must reproduce it (zeros −1, −5, poles −0.5, −20, gain 2).
        let w: Vec<f64> = (0..60).map(|k| 10f64.powf(-2.0 + 5.0 * k as f64 / 59.0)).collect();
        let d = |w: f64| {
            let s = c64::new(0.0, w);
            (2.0 * (s + 1.0) * (s + 5.0) / ((s + 0.5) * (s + 20.0))).norm()
        };
        let mag: Vec<f64> = w.iter().map(|&x| d(x)).collect();
        let f = fit_magnitude(&w, &mag, 2).expect("fit");
        assert!(f.max_log_error < 1e-8, "max log error {}", f.max_log_error);
        let mut z: Vec<f64> = f.zeros.iter().map(|z| z.re).collect();
        z.sort_by(f64::total_cmp);
        let mut p: Vec<f64> = f.poles.iter().map(|z| z.re).collect();
        p.sort_by(f64::total_cmp);
        assert!((z[0] + 5.0).abs() < 1e-6 && (z[1] + 1.0).abs() < 1e-6, "{z:?}");
        assert!((p[0] + 20.0).abs() < 1e-6 && (p[1] + 0.5).abs() < 1e-6, "{p:?}");
        assert!((f.gain - 2.0).abs() < 1e-6);
        assert!((f.magnitude(3.0) - d(3.0)).abs() < 1e-8);
        assert_eq!(f.ss.nx(), 2);
    }

    #[test]
    fn smooth_data_gives_stable_minimum_phase_fits() {
        // Non-rational data √(1 + ω): higher order must not fit worse, and every fit is stable and
        // minimum phase.
        let w: Vec<f64> = (0..50).map(|k| 10f64.powf(-2.0 + 4.0 * k as f64 / 49.0)).collect();
        let mag: Vec<f64> = w.iter().map(|x| (1.0 + x).sqrt()).collect();
        let mut prev = f64::INFINITY;
        for order in 0..=3 {
            let f = fit_magnitude(&w, &mag, order).expect("fit");
            assert!(f.zeros.iter().chain(&f.poles).all(|r| r.re < 0.0));
            assert!(
                f.max_log_error <= prev * 1.05 + 1e-12,
                "order {order}: {}",
                f.max_log_error
            );
            prev = f.max_log_error;
        }
        assert!(prev < 0.05, "order 3 error {prev}");
        assert!(fit_magnitude(&w, &mag[..10], 1).is_err());
        assert!(fit_magnitude(&w[..3], &mag[..3], 2).is_err());
        let mut bad = mag.clone();
        bad[3] = -1.0;
        assert!(fit_magnitude(&w, &bad, 1).is_err());
    }
}
