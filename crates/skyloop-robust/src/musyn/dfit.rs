//! D-step fitting for DK-iteration: a stable, minimum-phase rational d(s) whose magnitude follows
//! D-scale data |d(jω)| on a frequency grid.
//!
//! |d(jω)|² is a rational function of x = ω²: P(x)/Q(x). P and Q (degree `order`, Q(0) = 1) are
//! fitted by the Sanathanan–Koerner iteration on the linearized residual (P − m²Q)/(m²·Q_prev),
//! which converges to a relative (≈ log-magnitude) least-squares fit. The spectral factor is then
//! taken: the roots of P(−s²) and Q(−s²) come in ± pairs, and the left-half-plane ones become the
//! zeros and poles of d(s). That linearized fit can fail (poles pushed onto the axis, lost degree),
//! so its roots only start a Levenberg–Marquardt minimization of the log-magnitude error over
//! second-order sections with ω, ζ > 0 (stable and minimum phase by construction); the gain is the
//! log-magnitude least-squares optimum. Frequencies are normalized by their geometric mean.

use crate::error::Result;
use crate::error::RobustError;
use faer::linalg::solvers::SolveLstsq;
use faer::{c64, Mat};
use skyloop_linalg::lm::{self, LmOptions};
use skyloop_linalg::LinalgError;
use skyloop_lti::poly::Poly;
use skyloop_lti::tf::TransferFunction;
use skyloop_lti::StateSpace;

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
        return Err(RobustError::Dimension(format!(
            "{n} frequencies but {} magnitudes",
            mag.len()
        )));
    }
    if n < 2 * order + 1 {
        return Err(RobustError::InvalidArgument(format!(
            "a fit of order {order} needs at least {} frequencies, got {n}",
            2 * order + 1
        )));
    }
    for k in 0..n {
        if !(w_rad_s[k].is_finite() && w_rad_s[k] > 0.0 && mag[k].is_finite() && mag[k] > 0.0) {
            return Err(RobustError::InvalidArgument(format!(
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
            return Err(RobustError::Numerical("the D-scale fit diverged".into()));
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
    let (zeros, poles, gain, max_log_error) = refine(w_rad_s, mag, order, &zeros, &poles);
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

/// Stable, minimum-phase factors of d(s): second-order sections s² + 2ζω s + ω² (ζ, ω > 0) and at
/// most one first-order factor s + ω, so every parameter value is admissible.
#[derive(Debug, Clone)]
struct Sections {
    /// (ln ω, ln ζ) per section.
    second: Vec<(f64, f64)>,
    /// ln ω of the first-order factor.
    first: Option<f64>,
}

impl Sections {
    /// Sections of `order` roots from LHP roots (padded with −pad when there are fewer).
    fn from_roots(roots: &[c64], order: usize, pad: f64) -> Self {
        let mut cplx: Vec<c64> = roots.iter().filter(|r| r.im > 1e-12 * r.norm()).copied().collect();
        let mut real: Vec<f64> = roots
            .iter()
            .filter(|r| r.im.abs() <= 1e-12 * r.norm())
            .map(|r| (-r.re).max(1e-300))
            .collect();
        cplx.truncate(order / 2);
        while 2 * cplx.len() + real.len() < order {
            real.push(pad);
        }
        real.truncate(order - 2 * cplx.len());
        let mut second: Vec<(f64, f64)> = cplx
            .iter()
            .map(|r| (r.norm().ln(), (-r.re / r.norm()).max(1e-6).ln()))
            .collect();
        while real.len() >= 2 {
            let (a, b) = (real.pop().unwrap_or(pad), real.pop().unwrap_or(pad));
            let wn = (a * b).sqrt();
            second.push((wn.ln(), ((a + b) / (2.0 * wn)).ln()));
        }
        Sections {
            second,
            first: real.first().map(|a| a.ln()),
        }
    }
    fn len(&self) -> usize {
        2 * self.second.len() + usize::from(self.first.is_some())
    }
    fn to_vec(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.second.iter().flat_map(|&(a, b)| [a, b]).collect();
        v.extend(self.first);
        v
    }
    fn set(&mut self, v: &[f64]) {
        for (k, sec) in self.second.iter_mut().enumerate() {
            *sec = (v[2 * k], v[2 * k + 1]);
        }
        if let Some(f) = self.first.as_mut() {
            *f = v[2 * self.second.len()];
        }
    }
    /// ln|Π factors(jω)|.
    fn log_mag(&self, w: f64) -> f64 {
        let mut acc = 0.0;
        for &(lw, lz) in &self.second {
            let (wn, z) = (lw.exp(), lz.exp());
            let re = wn * wn - w * w;
            let im = 2.0 * z * wn * w;
            acc += 0.5 * (re * re + im * im).ln();
        }
        if let Some(lw) = self.first {
            let wn = lw.exp();
            acc += 0.5 * (wn * wn + w * w).ln();
        }
        acc
    }
    fn roots(&self) -> Vec<c64> {
        let mut out = Vec::new();
        for &(lw, lz) in &self.second {
            let (wn, z) = (lw.exp(), lz.exp());
            if z < 1.0 {
                let im = wn * (1.0 - z * z).sqrt();
                out.push(c64::new(-z * wn, im));
                out.push(c64::new(-z * wn, -im));
            } else {
                let d = wn * (z * z - 1.0).sqrt();
                out.push(c64::new(-z * wn + d, 0.0));
                out.push(c64::new(-z * wn - d, 0.0));
            }
        }
        if let Some(lw) = self.first {
            out.push(c64::new(-lw.exp(), 0.0));
        }
        out
    }
}

/// Levenberg–Marquardt on the log-magnitude error from the Sanathanan–Koerner roots (which need not
/// be accurate: the linearized fit can put poles on the axis or lose degree). Natural frequencies
/// stay within a decade of the data's frequency range, which keeps the scaled plant's dynamics
/// within the range it is analysed on. Returns zeros, poles, gain and the max log error.
fn refine(w: &[f64], mag: &[f64], order: usize, zeros: &[c64], poles: &[c64]) -> (Vec<c64>, Vec<c64>, f64, f64) {
    let (wmin, wmax) = w
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(a, b), &x| (a.min(x), b.max(x)));
    let (lo, hi) = ((wmin / 10.0).ln(), (wmax * 10.0).ln());
    let target: Vec<f64> = mag.iter().map(|m| m.ln()).collect();
    let n = w.len();
    let mut best: Option<(f64, Sections, Sections, f64)> = None;
    // Starts: the SK roots, and roots spread log-uniformly over the data range.
    let spread = |k: usize, m: usize, shift: f64| -> Vec<c64> {
        (0..m)
            .map(|i| {
                let t = (i as f64 + 0.5 + shift) / m as f64;
                c64::new(-(wmin.ln() + t * (wmax.ln() - wmin.ln())).exp(), 0.0) * (1.0 + 0.1 * k as f64)
            })
            .collect()
    };
    let starts: Vec<(Vec<c64>, Vec<c64>)> = vec![
        (zeros.to_vec(), poles.to_vec()),
        (spread(0, order, 0.0), spread(0, order, 0.25)),
        (spread(0, order, 0.25), spread(0, order, 0.0)),
    ];
    let pad = (wmin * wmax).sqrt();
    for (z0, p0) in starts {
        let mut zs = Sections::from_roots(&z0, order, pad);
        let mut ps = Sections::from_roots(&p0, order, pad);
        let (nz, np) = (zs.len(), ps.len());
        let (zsec, psec) = (zs.second.len(), ps.second.len());
        // Box: damping logs of second-order sections in [−8, 4], natural-frequency logs within a
        // decade of the data.
        let bounds = |secs: usize, len: usize| -> (Vec<f64>, Vec<f64>) {
            (0..len)
                .map(|k| {
                    if k < 2 * secs && k % 2 == 1 {
                        (-8.0, 4.0)
                    } else {
                        (lo, hi)
                    }
                })
                .unzip()
        };
        let (zlo, zhi) = bounds(zsec, nz);
        let (plo, phi) = bounds(psec, np);
        let (blo, bhi): (Vec<f64>, Vec<f64>) = (
            zlo.iter().chain(&plo).copied().collect(),
            zhi.iter().chain(&phi).copied().collect(),
        );
        // Residuals with the optimal gain (mean log error) eliminated.
        let resid = |zs: &Sections, ps: &Sections| -> (Vec<f64>, f64) {
            let shape: Vec<f64> = w.iter().map(|&x| zs.log_mag(x) - ps.log_mag(x)).collect();
            let lg = (0..n).map(|k| target[k] - shape[k]).sum::<f64>() / n as f64;
            ((0..n).map(|k| lg + shape[k] - target[k]).collect(), lg)
        };
        let theta0: Vec<f64> = zs
            .to_vec()
            .into_iter()
            .chain(ps.to_vec())
            .enumerate()
            .map(|(k, x)| x.clamp(blo[k], bhi[k]))
            .collect();
        zs.set(&theta0[..nz]);
        ps.set(&theta0[nz..]);
        if nz + np > 0 {
            let f = |t: &[f64]| {
                let (mut zt, mut pt) = (zs.clone(), ps.clone());
                zt.set(&t[..nz]);
                pt.set(&t[nz..]);
                Ok::<_, LinalgError>(resid(&zt, &pt).0)
            };
            let opts = LmOptions {
                max_iter: 200,
                ..LmOptions::default()
            };
            // A start the minimizer rejects (non-finite model) competes as it is.
            if let Ok(res) = lm::minimize(f, &theta0, &blo, &bhi, &opts) {
                zs.set(&res.x[..nz]);
                ps.set(&res.x[nz..]);
            }
        }
        let (r, lg) = resid(&zs, &ps);
        let maxe = r.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        if best.as_ref().is_none_or(|b| maxe < b.0) {
            best = Some((maxe, zs, ps, lg));
        }
    }
    match best {
        Some((maxe, zs, ps, lg)) => (zs.roots(), ps.roots(), lg.exp(), maxe),
        None => (Vec::new(), Vec::new(), 1.0, f64::INFINITY),
    }
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
