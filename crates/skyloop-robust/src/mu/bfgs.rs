//! Quasi-Newton pieces shared by the D-scaling (σ̄) and D–G (mixed) upper bounds: both minimize a
//! smoothed maximum eigenvalue by BFGS on the scalings' generators, in stages of growing sharpness.

/// The n×n identity as rows (the inverse-Hessian start).
pub(super) fn identity(n: usize) -> Vec<Vec<f64>> {
    (0..n)
        .map(|i| (0..n).map(|k| if i == k { 1.0 } else { 0.0 }).collect())
        .collect()
}

/// BFGS update of the inverse Hessian H with step s and gradient change y (sᵀy > 0).
pub(super) fn bfgs_update(h: &mut [Vec<f64>], s: &[f64], y: &[f64], sy: f64) {
    let n = s.len();
    let hy: Vec<f64> = (0..n).map(|i| (0..n).map(|k| h[i][k] * y[k]).sum()).collect();
    let yhy: f64 = y.iter().zip(&hy).map(|(a, b)| a * b).sum();
    let rho = 1.0 / sy;
    for i in 0..n {
        for k in 0..n {
            h[i][k] += -rho * (hy[i] * s[k] + s[i] * hy[k]) + (rho * rho * yhy + rho) * s[i] * s[k];
        }
    }
}

/// The quasi-Newton direction p = −H·g, its slope pᵀg and the first step length, or None once
/// ‖g‖ < `gtol`. H is reset to the identity when p is not a descent direction. The first step is
/// capped so that no generator moves by more than 3 (no scale changes by more than e³ at once).
pub(super) fn descent(h: &mut Vec<Vec<f64>>, g: &[f64], gtol: f64) -> Option<(Vec<f64>, f64, f64)> {
    let gnorm = g.iter().map(|v| v * v).sum::<f64>().sqrt();
    if gnorm < gtol {
        return None;
    }
    let n = g.len();
    let mut p: Vec<f64> = (0..n).map(|i| -(0..n).map(|k| h[i][k] * g[k]).sum::<f64>()).collect();
    let mut slope: f64 = p.iter().zip(g).map(|(a, b)| a * b).sum();
    if slope >= 0.0 {
        *h = identity(n);
        p = g.iter().map(|v| -v).collect();
        slope = -gnorm * gnorm;
    }
    let pmax = p.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    let alpha = if pmax > 3.0 { 3.0 / pmax } else { 1.0 };
    Some((p, slope, alpha))
}

/// Scales the inverse Hessian: the kink's curvature grows like the smoothing sharpness t, so H
/// shrinks by the factor t grew.
pub(super) fn scale(h: &mut [Vec<f64>], f: f64) {
    for row in h.iter_mut() {
        for v in row.iter_mut() {
            *v *= f;
        }
    }
}
