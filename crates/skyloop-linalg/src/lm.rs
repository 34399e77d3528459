//! Levenberg–Marquardt least squares with box bounds (Marquardt's diagonal scaling, Nielsen's damping
//! update; Madsen, Nielsen & Tingleff, "Methods for non-linear least squares problems", 2004, §3.2).

use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::Mat;

use crate::error::LinalgError;

/// Stopping rules.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmOptions {
    /// Maximum number of accepted or rejected steps.
    pub max_iter: usize,
    /// Relative step size below which the iteration stops.
    pub xtol: f64,
    /// Relative cost decrease below which an accepted step counts as converged.
    pub ftol: f64,
}

impl Default for LmOptions {
    fn default() -> LmOptions {
        LmOptions {
            max_iter: 300,
            xtol: 1e-10,
            ftol: 1e-14,
        }
    }
}

/// The minimizer and what is needed for its statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct LmResult {
    /// Parameters at the minimum.
    pub x: Vec<f64>,
    /// Residuals there.
    pub residuals: Vec<f64>,
    /// ½‖r‖².
    pub cost: f64,
    /// Jacobian ∂r/∂x there (m rows × n columns).
    pub jacobian: Mat<f64>,
    /// Steps taken.
    pub iterations: usize,
    /// Whether a stopping tolerance (not the iteration limit) ended the search.
    pub converged: bool,
}

fn cost(r: &[f64]) -> f64 {
    0.5 * r.iter().map(|v| v * v).sum::<f64>()
}

/// Central-difference Jacobian, one-sided at a bound.
fn jacobian<E, F: Fn(&[f64]) -> Result<Vec<f64>, E>>(
    f: &F,
    x: &[f64],
    r0: &[f64],
    lo: &[f64],
    hi: &[f64],
) -> Result<Mat<f64>, E> {
    let (m, n) = (r0.len(), x.len());
    let mut j = Mat::<f64>::zeros(m, n);
    let mut xp = x.to_vec();
    for c in 0..n {
        let h = 1e-6 * x[c].abs().max(1e-6);
        let (a, b) = ((x[c] - h).max(lo[c]), (x[c] + h).min(hi[c]));
        if b <= a {
            continue;
        }
        xp[c] = b;
        let rb = if b > x[c] { f(&xp)? } else { r0.to_vec() };
        xp[c] = a;
        let ra = if a < x[c] { f(&xp)? } else { r0.to_vec() };
        xp[c] = x[c];
        for i in 0..m {
            j[(i, c)] = (rb[i] - ra[i]) / (b - a);
        }
    }
    Ok(j)
}

/// Minimizes ½‖f(x)‖² over lo ≤ x ≤ hi from x0 (clamped into the box). `f`'s own errors pass through;
/// the minimizer's (bad bounds, fewer residuals than parameters, non-finite model) are [`LinalgError`]s.
pub fn minimize<E: From<LinalgError>, F: Fn(&[f64]) -> Result<Vec<f64>, E>>(
    f: F,
    x0: &[f64],
    lo: &[f64],
    hi: &[f64],
    opts: &LmOptions,
) -> Result<LmResult, E> {
    let n = x0.len();
    if lo.len() != n || hi.len() != n || (0..n).any(|i| !(lo[i] <= hi[i])) {
        return Err(LinalgError::InvalidArgument("bounds must have lower ≤ upper for every parameter".into()).into());
    }
    let clamp = |x: &mut [f64]| (0..n).for_each(|i| x[i] = x[i].clamp(lo[i], hi[i]));
    let mut x = x0.to_vec();
    clamp(&mut x);
    let mut r = f(&x)?;
    if r.iter().any(|v| !v.is_finite()) {
        return Err(LinalgError::InvalidArgument("the model is not finite at the initial parameters".into()).into());
    }
    let m = r.len();
    if m < n {
        return Err(LinalgError::Dimension(format!("{m} residuals for {n} parameters")).into());
    }
    let mut c = cost(&r);
    let mut j = jacobian(&f, &x, &r, lo, hi)?;
    let normal = |j: &Mat<f64>, r: &[f64]| {
        let a = j.transpose() * j;
        let g = Mat::<f64>::from_fn(n, 1, |i, _| (0..m).map(|k| j[(k, i)] * r[k]).sum());
        (a, g)
    };
    let (mut a, mut g) = normal(&j, &r);
    let amax = (0..n).map(|i| a[(i, i)]).fold(0.0f64, f64::max).max(1e-300);
    let mut mu = 1e-3;
    let mut nu = 2.0;
    let mut converged = false;
    let mut it = 0;
    while it < opts.max_iter {
        it += 1;
        // Active set: a parameter on a bound whose descent direction points out of the box stays put.
        let free: Vec<bool> = (0..n)
            .map(|i| !((x[i] <= lo[i] && g[(i, 0)] > 0.0) || (x[i] >= hi[i] && g[(i, 0)] < 0.0)))
            .collect();
        let gmax = (0..n)
            .filter(|&i| free[i])
            .map(|i| g[(i, 0)].abs())
            .fold(0.0f64, f64::max);
        if gmax <= 1e-15 * (1.0 + c) {
            converged = true;
            break;
        }
        let mut lhs = Mat::<f64>::from_fn(n, n, |i, k| if free[i] && free[k] { a[(i, k)] } else { 0.0 });
        for i in 0..n {
            lhs[(i, i)] = if free[i] {
                a[(i, i)] + mu * a[(i, i)].max(1e-12 * amax)
            } else {
                1.0
            };
        }
        let neg_g = Mat::<f64>::from_fn(n, 1, |i, _| if free[i] { -g[(i, 0)] } else { 0.0 });
        let step = lhs.partial_piv_lu().solve(&neg_g);
        let mut xn: Vec<f64> = (0..n).map(|i| x[i] + step[(i, 0)]).collect();
        clamp(&mut xn);
        let d: Vec<f64> = (0..n).map(|i| xn[i] - x[i]).collect();
        let dnorm = d.iter().map(|v| v * v).sum::<f64>().sqrt();
        let xnorm = x.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !d.iter().all(|v| v.is_finite()) {
            return Err(LinalgError::Singular("normal equations (a parameter has no effect?)".into()).into());
        }
        if dnorm <= opts.xtol * (xnorm + opts.xtol) {
            converged = true;
            break;
        }
        // Predicted decrease of the local quadratic model for the (clamped) step.
        let ad: Vec<f64> = (0..n).map(|i| (0..n).map(|k| a[(i, k)] * d[k]).sum()).collect();
        let pred = -(0..n).map(|i| g[(i, 0)] * d[i] + 0.5 * d[i] * ad[i]).sum::<f64>();
        let rn = match f(&xn) {
            Ok(v) if v.iter().all(|x| x.is_finite()) => v,
            _ => {
                mu *= nu;
                nu *= 2.0;
                continue;
            }
        };
        let cn = cost(&rn);
        let rho = if pred > 0.0 { (c - cn) / pred } else { -1.0 };
        if rho > 0.0 && cn < c {
            let rel = (c - cn) / c.max(1e-300);
            x = xn;
            r = rn;
            c = cn;
            j = jacobian(&f, &x, &r, lo, hi)?;
            (a, g) = normal(&j, &r);
            mu *= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
            nu = 2.0;
            if rel < opts.ftol {
                converged = true;
                break;
            }
        } else {
            mu *= nu;
            nu *= 2.0;
            if mu > 1e30 {
                converged = true;
                break;
            }
        }
    }
    Ok(LmResult {
        x,
        residuals: r,
        cost: c,
        jacobian: j,
        iterations: it,
        converged,
    })
}

/// Standard errors s·√diag((JᵀJ)⁻¹) with s² = ‖r‖²/(m − n); NaN for a parameter the data do not
/// determine (singular JᵀJ).
pub fn standard_errors(res: &LmResult) -> Vec<f64> {
    standard_errors_correlated(res, &[])
}

/// Standard errors when residual rows are correlated: the sandwich covariance
/// s²·(JᵀJ)⁻¹·(JᵀRJ)·(JᵀJ)⁻¹, R the residuals' correlation matrix with unit diagonal and the
/// off-diagonal entries `corr` = (row i, row j, ρᵢⱼ), each pair listed once. Overlapping spectral
/// estimates make neighbouring residuals correlated; treating them as independent would overstate
/// the information in the data.
pub fn standard_errors_correlated(res: &LmResult, corr: &[(usize, usize, f64)]) -> Vec<f64> {
    let (m, n) = (res.jacobian.nrows(), res.jacobian.ncols());
    if m <= n {
        return vec![f64::NAN; n];
    }
    let j = &res.jacobian;
    let s2 = 2.0 * res.cost / (m - n) as f64;
    let a = j.transpose() * j;
    let inv = a.partial_piv_lu().inverse();
    let mut meat = a.clone();
    for &(r, q, rho) in corr {
        if r >= m || q >= m || r == q {
            continue;
        }
        for p in 0..n {
            for l in 0..n {
                meat[(p, l)] += rho * (j[(r, p)] * j[(q, l)] + j[(q, p)] * j[(r, l)]);
            }
        }
    }
    let cov = &inv * &meat * &inv;
    (0..n)
        .map(|i| {
            let v = cov[(i, i)] * s2;
            if v.is_finite() && v >= 0.0 {
                v.sqrt()
            } else {
                f64::NAN
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rosenbrock as residuals (10(x2 − x1²), 1 − x1): minimum at (1, 1) with zero cost (closed form).
    #[test]
    fn rosenbrock() {
        let f = |x: &[f64]| Ok::<_, LinalgError>(vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]);
        let r = minimize(f, &[-1.2, 1.0], &[-5.0, -5.0], &[5.0, 5.0], &LmOptions::default()).unwrap();
        assert!((r.x[0] - 1.0).abs() < 1e-8 && (r.x[1] - 1.0).abs() < 1e-8, "{:?}", r.x);
        assert!(r.converged);
    }

    /// With a bound at x1 ≤ 0.5 the minimum moves onto the bound: x1 = 0.5, x2 = 0.25.
    #[test]
    fn bounds_are_respected() {
        let f = |x: &[f64]| Ok::<_, LinalgError>(vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]);
        let r = minimize(f, &[-1.2, 1.0], &[-5.0, -5.0], &[0.5, 5.0], &LmOptions::default()).unwrap();
        assert!((r.x[0] - 0.5).abs() < 1e-9 && (r.x[1] - 0.25).abs() < 1e-6, "{:?}", r.x);
    }

    /// Straight-line fit: the standard errors equal the textbook OLS formula s·√((XᵀX)⁻¹)ᵢᵢ.
    #[test]
    fn line_standard_errors() {
        let t: Vec<f64> = (0..10).map(|i| i as f64).collect();
        let y: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, t)| 1.0 + 2.0 * t + if i % 2 == 0 { 0.1 } else { -0.1 })
            .collect();
        let f = |p: &[f64]| Ok::<_, LinalgError>(t.iter().zip(&y).map(|(t, y)| p[0] + p[1] * t - y).collect());
        let r = minimize(f, &[0.0, 0.0], &[-1e9; 2], &[1e9; 2], &LmOptions::default()).unwrap();
        let se = standard_errors(&r);
        // Closed form: Sxx = Σ(t − t̄)² = 82.5; s² = SSR/(n − 2); se(slope) = s/√Sxx.
        let tm = 4.5;
        let sxx: f64 = t.iter().map(|t| (t - tm) * (t - tm)).sum();
        let ssr: f64 = t.iter().zip(&y).map(|(t, y)| (r.x[0] + r.x[1] * t - y).powi(2)).sum();
        let s = (ssr / 8.0).sqrt();
        assert!((se[1] - s / sxx.sqrt()).abs() < 1e-6 * se[1]);
        assert!((se[0] - s * (1.0 / 10.0 + tm * tm / sxx).sqrt()).abs() < 1e-6 * se[0]);
    }

    /// Every residual listed twice with correlation 1: the data carry no more information than once,
    /// so the sandwich gives the single-copy errors, up to the residual variance's degrees of freedom:
    /// se_dup = se·√(2(m − n)/(2m − n)) (closed form: JᵀJ doubles, the middle term quadruples).
    #[test]
    fn fully_correlated_duplicates_add_no_information() {
        let t: Vec<f64> = (0..12).map(|i| i as f64 * 0.5).collect();
        let y: Vec<f64> = t.iter().map(|t| 0.3 - 1.5 * t + 0.2 * (3.0 * t).sin()).collect();
        let single = |p: &[f64]| Ok::<_, LinalgError>(t.iter().zip(&y).map(|(t, y)| p[0] + p[1] * t - y).collect());
        let double =
            |p: &[f64]| Ok::<_, LinalgError>(t.iter().zip(&y).flat_map(|(t, y)| [p[0] + p[1] * t - y; 2]).collect());
        let o = LmOptions::default();
        let r1 = minimize(single, &[0.0, 0.0], &[-1e9; 2], &[1e9; 2], &o).unwrap();
        let r2 = minimize(double, &[0.0, 0.0], &[-1e9; 2], &[1e9; 2], &o).unwrap();
        let pairs: Vec<(usize, usize, f64)> = (0..t.len()).map(|i| (2 * i, 2 * i + 1, 1.0)).collect();
        let (se1, se2) = (standard_errors(&r1), standard_errors_correlated(&r2, &pairs));
        let (m, n) = (t.len() as f64, 2.0);
        let k = (2.0 * (m - n) / (2.0 * m - n)).sqrt();
        for i in 0..2 {
            assert!((se2[i] - se1[i] * k).abs() < 1e-6 * se1[i], "{se1:?} {se2:?}");
        }
        // Ignoring the correlation would claim √2 less uncertainty.
        assert!(standard_errors(&r2)[1] < 0.8 * se2[1]);
    }
}
