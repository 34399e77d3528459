//! Scalar root finding and maximization on an interval (Brent's zeroin, golden-section search).

/// A root of `f` in [a, b] where f(a) and f(b) have opposite signs (Brent 1973, "Algorithms for
/// minimization without derivatives", ch. 4), to an absolute tolerance `tol` (plus 4·eps·|x|).
pub fn brent_root(mut f: impl FnMut(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    let (mut a, mut b) = (a, b);
    let (mut fa, mut fb) = (f(a), f(b));
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    let (mut c, mut fc) = (a, fa);
    let mut d = b - a;
    let mut e = d;
    for _ in 0..200 {
        if (fb > 0.0) == (fc > 0.0) {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol1 = 2.0 * f64::EPSILON * b.abs() + 0.5 * tol;
        let xm = 0.5 * (c - b);
        if xm.abs() <= tol1 || fb == 0.0 {
            return b;
        }
        if e.abs() >= tol1 && fa.abs() > fb.abs() {
            // inverse quadratic interpolation, or the secant step when only two points differ
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * xm * s;
                q = 1.0 - s;
            } else {
                let qa = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * xm * qa * (qa - r) - (b - a) * (r - 1.0));
                q = (qa - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            }
            p = p.abs();
            if 2.0 * p < (3.0 * xm * q - (tol1 * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = xm;
                e = d;
            }
        } else {
            d = xm;
            e = d;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol1 { d } else { tol1.copysign(xm) };
        fb = f(b);
    }
    b
}

/// The maximizer of a unimodal `f` on [a, b] by golden-section search to relative width `rtol`;
/// returns (x, f(x)).
pub fn golden_max(mut f: impl FnMut(f64) -> f64, a: f64, b: f64, rtol: f64) -> (f64, f64) {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (a, b);
    let mut x1 = b - g * (b - a);
    let mut x2 = a + g * (b - a);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..200 {
        if (b - a).abs() <= rtol * (a.abs() + b.abs()).max(f64::MIN_POSITIVE) {
            break;
        }
        if f1 < f2 {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + g * (b - a);
            f2 = f(x2);
        } else {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - g * (b - a);
            f1 = f(x1);
        }
    }
    if f1 > f2 {
        (x1, f1)
    } else {
        (x2, f2)
    }
}

/// The maximizer of a unimodal `f` on [a, b] by Brent's method (parabolic interpolation through
/// the three best points, golden-section steps when a parabola is not trustworthy; R. P. Brent,
/// "Algorithms for Minimization without Derivatives", 1973, ch. 5) to relative width `rtol`;
/// returns (x, f(x)). Superlinear near a smooth peak: a handful of evaluations where golden-section
/// search needs forty.
pub fn brent_max(mut f: impl FnMut(f64) -> f64, a: f64, b: f64, rtol: f64) -> (f64, f64) {
    let cg = 0.5 * (3.0 - 5f64.sqrt());
    let (mut a, mut b) = if a <= b { (a, b) } else { (b, a) };
    let mut x = a + cg * (b - a);
    let (mut w, mut v) = (x, x);
    // Minimize g = −f.
    let mut fx = -f(x);
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        let tol1 = rtol * x.abs() + f64::MIN_POSITIVE.sqrt();
        let tol2 = 2.0 * tol1;
        if (x - m).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            } else {
                q = -q;
            }
            let e_prev = e;
            e = d;
            if p.abs() < (0.5 * q * e_prev).abs() && p > q * (a - x) && p < q * (b - x) {
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = tol1.copysign(m - x);
                }
                golden = false;
            }
        }
        if golden {
            e = if x < m { b - x } else { a - x };
            d = cg * e;
        }
        let u = x + if d.abs() >= tol1 { d } else { tol1.copysign(d) };
        let fu = -f(u);
        if fu <= fx {
            if u < x {
                b = x;
            } else {
                a = x;
            }
            (v, fv) = (w, fw);
            (w, fw) = (x, fx);
            (x, fx) = (u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv) = (w, fw);
                (w, fw) = (u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    (x, -fx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_cos_root_to_machine_precision() {
        // cos has its root at π/2 (closed form).
        let r = brent_root(f64::cos, 1.0, 2.0, 0.0);
        assert!((r - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    }

    #[test]
    fn golden_finds_parabola_peak() {
        // −(x − 0.3)² peaks at 0.3 (closed form).
        let (x, fx) = golden_max(|x| -(x - 0.3) * (x - 0.3), -1.0, 2.0, 1e-12);
        assert!((x - 0.3).abs() < 1e-9 && fx <= 0.0);
    }

    #[test]
    fn brent_finds_resonance_peak_in_few_evaluations() {
        // |1/(1 − ω² + 2jζω)| peaks at ω = √(1 − 2ζ²) (closed form), ζ = 0.05.
        let z: f64 = 0.05;
        let mut calls = 0;
        let (x, fx) = brent_max(
            |w| {
                calls += 1;
                1.0 / ((1.0 - w * w).powi(2) + (2.0 * z * w).powi(2)).sqrt()
            },
            0.7,
            1.4,
            1e-10,
        );
        let peak = 1.0 / (2.0 * z * (1.0 - z * z).sqrt());
        assert!((x - (1.0 - 2.0 * z * z).sqrt()).abs() < 1e-8, "{x}");
        assert!((fx - peak).abs() < 1e-12 * peak);
        assert!(calls < 30, "{calls} evaluations");
    }
}
