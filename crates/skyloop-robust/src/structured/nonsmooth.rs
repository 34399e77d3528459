//! BFGS for nonsmooth, locally Lipschitz functions with the weak Wolfe line search of Lewis &
//! Overton ("Nonsmooth optimization via quasi-Newton methods", Math. Programming 141, 2013; the
//! method of HANSO/HIFOO). The functions minimized here (a max of H∞ norms, a spectral abscissa)
//! are smooth almost everywhere and their minimizers sit on kinks; BFGS's inverse Hessian then
//! becomes ill conditioned along the nonsmooth directions, which is what lets it converge there.
//!
//! The line search brackets a step t with the Armijo condition f(x + t·d) ≤ f(x) + c1·t·gᵀd and the
//! weak curvature condition g(x + t·d)ᵀd ≥ c2·gᵀd, doubling until an upper bound is found and then
//! bisecting; an infinite f (an unstable closed loop) simply shrinks the step.

/// Options of [`bfgs`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BfgsOptions {
    /// Most iterations.
    pub max_iter: usize,
    /// Stop when f falls to or below this value (e.g. a stabilization target).
    pub target: f64,
    /// Stop when f decreased by less than `ftol`·max(1, |f|) over `stall` consecutive iterations.
    pub ftol: f64,
    /// See `ftol`.
    pub stall: usize,
}

impl Default for BfgsOptions {
    fn default() -> Self {
        BfgsOptions {
            max_iter: 200,
            target: f64::NEG_INFINITY,
            ftol: 1e-7,
            stall: 8,
        }
    }
}

/// The outcome of [`bfgs`].
#[derive(Debug, Clone, PartialEq)]
pub struct BfgsResult {
    /// Best point found.
    pub x: Vec<f64>,
    /// f at `x`.
    pub f: f64,
    /// Iterations done.
    pub iterations: usize,
    /// Function evaluations done.
    pub evaluations: usize,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Minimizes `f` (returning the value and a gradient, which may be empty when the value is
/// infinite) from `x0`. `x0` must have a finite value.
pub fn bfgs(mut f: impl FnMut(&[f64]) -> (f64, Vec<f64>), x0: &[f64], opts: &BfgsOptions) -> BfgsResult {
    let n = x0.len();
    let mut x = x0.to_vec();
    let (mut fx, mut g) = f(&x);
    let mut evals = 1;
    let mut h = identity(n);
    let mut first = true;
    let mut stalled = 0;
    let mut it = 0;
    if !fx.is_finite() || g.len() != n {
        return BfgsResult {
            x,
            f: fx,
            iterations: 0,
            evaluations: evals,
        };
    }
    while it < opts.max_iter && fx > opts.target {
        it += 1;
        let mut d: Vec<f64> = (0..n).map(|i| -dot(&h[i], &g)).collect();
        if dot(&d, &g) >= 0.0 {
            h = identity(n);
            d = g.iter().map(|v| -v).collect();
        }
        let gd = dot(&g, &d);
        if gd.abs() < 1e-300 {
            break;
        }
        let Some((xn, fnew, gnew, used)) = wolfe(&mut f, &x, fx, gd, &d) else {
            evals += 40;
            break;
        };
        evals += used;
        let s: Vec<f64> = (0..n).map(|i| xn[i] - x[i]).collect();
        let y: Vec<f64> = (0..n).map(|i| gnew[i] - g[i]).collect();
        let sy = dot(&s, &y);
        if sy > 0.0 {
            if first {
                // Scale the initial inverse Hessian to the curvature seen (Nocedal & Wright 6.20).
                let scale = sy / dot(&y, &y);
                for (i, row) in h.iter_mut().enumerate() {
                    row.iter_mut().for_each(|v| *v = 0.0);
                    row[i] = scale;
                }
                first = false;
            }
            update(&mut h, &s, &y, sy);
        }
        let decrease = fx - fnew;
        x = xn;
        fx = fnew;
        g = gnew;
        if decrease <= opts.ftol * fx.abs().max(1.0) {
            stalled += 1;
            if stalled >= opts.stall {
                break;
            }
        } else {
            stalled = 0;
        }
        if s.iter()
            .all(|v| v.abs() <= 1e-14 * (1.0 + x.iter().map(|v| v.abs()).fold(0.0, f64::max)))
        {
            break;
        }
    }
    BfgsResult {
        x,
        f: fx,
        iterations: it,
        evaluations: evals,
    }
}

fn identity(n: usize) -> Vec<Vec<f64>> {
    (0..n)
        .map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect())
        .collect()
}

/// H ← (I − ρsyᵀ)H(I − ρysᵀ) + ρssᵀ, ρ = 1/(sᵀy).
fn update(h: &mut [Vec<f64>], s: &[f64], y: &[f64], sy: f64) {
    let n = s.len();
    let rho = 1.0 / sy;
    let hy: Vec<f64> = (0..n).map(|i| dot(&h[i], y)).collect();
    let yhy = dot(y, &hy);
    for i in 0..n {
        for j in 0..n {
            h[i][j] += -rho * (hy[i] * s[j] + s[i] * hy[j]) + (rho * rho * yhy + rho) * s[i] * s[j];
        }
    }
}

/// Weak Wolfe step along d; `None` when no step decreases f (then x is taken as converged).
fn wolfe(
    f: &mut impl FnMut(&[f64]) -> (f64, Vec<f64>),
    x: &[f64],
    fx: f64,
    gd: f64,
    d: &[f64],
) -> Option<(Vec<f64>, f64, Vec<f64>, usize)> {
    const C1: f64 = 1e-4;
    const C2: f64 = 0.5;
    let (mut lo, mut hi, mut t) = (0.0, f64::INFINITY, 1.0);
    let mut best: Option<(Vec<f64>, f64, Vec<f64>)> = None;
    for k in 1..=40 {
        let xt: Vec<f64> = x.iter().zip(d).map(|(a, b)| a + t * b).collect();
        let (ft, gt) = f(&xt);
        let armijo = ft.is_finite() && gt.len() == x.len() && ft <= fx + C1 * t * gd;
        if !armijo {
            hi = t;
        } else {
            if best.as_ref().is_none_or(|b| ft < b.1) {
                best = Some((xt.clone(), ft, gt.clone()));
            }
            if dot(&gt, d) < C2 * gd {
                lo = t;
            } else {
                return Some((xt, ft, gt, k));
            }
        }
        t = if hi.is_finite() { 0.5 * (lo + hi) } else { 2.0 * lo };
        if hi.is_finite() && hi - lo < 1e-14 * hi {
            break;
        }
    }
    // Armijo without curvature (a kink): accept the best decrease seen.
    best.map(|(x, f, g)| (x, f, g, 40))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimizes_a_nonsmooth_max_of_quadratics() {
        // f = max(|x0 − 1| + 2|x1|, x0² + x1²/10) ... a kink at the minimizer: the minimizer of
        // max(x0 + x1, x0 − x1, −x0/2 + 1) + (x0² + x1²)/100 lies at x1 = 0, x0 = 2/3 (where the
        // first two planes and the third meet).
        let f = |x: &[f64]| {
            let p = [x[0] + x[1], x[0] - x[1], -0.5 * x[0] + 1.0];
            let (k, v) = p
                .iter()
                .enumerate()
                .fold((0, f64::NEG_INFINITY), |a, (i, &v)| if v > a.1 { (i, v) } else { a });
            let mut g = match k {
                0 => vec![1.0, 1.0],
                1 => vec![1.0, -1.0],
                _ => vec![-0.5, 0.0],
            };
            g[0] += x[0] / 50.0;
            g[1] += x[1] / 50.0;
            (v + (x[0] * x[0] + x[1] * x[1]) / 100.0, g)
        };
        let r = bfgs(
            f,
            &[3.0, 2.0],
            &BfgsOptions {
                max_iter: 500,
                ..Default::default()
            },
        );
        assert!((r.x[0] - 2.0 / 3.0).abs() < 1e-3 && r.x[1].abs() < 1e-3, "{:?}", r);
    }

    #[test]
    fn smooth_rosenbrock_converges() {
        let f = |x: &[f64]| {
            let (a, b) = (x[0], x[1]);
            (
                (1.0 - a).powi(2) + 100.0 * (b - a * a).powi(2),
                vec![-2.0 * (1.0 - a) - 400.0 * a * (b - a * a), 200.0 * (b - a * a)],
            )
        };
        let r = bfgs(
            f,
            &[-1.2, 1.0],
            &BfgsOptions {
                max_iter: 500,
                ftol: 0.0,
                stall: 1000,
                ..Default::default()
            },
        );
        assert!((r.x[0] - 1.0).abs() < 1e-5 && (r.x[1] - 1.0).abs() < 1e-5, "{:?}", r);
    }
}
