//! Padé approximation of time delays, and replacing a model's delays by rational dynamics.

use crate::convert::siso_realization;
use crate::error::{LtiError, Result};
use crate::interconnect::{append, series};
use crate::poly::Poly;
use crate::ss::StateSpace;
use faer::Mat;

/// Highest Padé order accepted by [`pade_checked`] and [`StateSpace::try_pade`]: beyond it the
/// coefficients span more than the floating-point range for ordinary delays and the approximant's
/// realization is hopelessly ill-conditioned.
pub const MAX_PADE_ORDER: usize = 20;

/// Most shift-register states one discrete delay may become (delay/dt samples).
pub const MAX_DISCRETE_DELAY_STATES: usize = 10_000;

/// The [n/n] Padé approximant of `e^(−t_s·s)` as (numerator, denominator), descending powers,
/// denominator monic: the same coefficients as MATLAB `pade(T, n)`. Order 0 (or `t_s == 0`) is
/// the constant 1; see [`pade_checked`] for the validated form.
pub fn pade(t_s: f64, n: usize) -> (Poly, Poly) {
    if t_s == 0.0 || n == 0 {
        return (Poly::one(), Poly::one());
    }
    // Ascending coefficients a_k (numerator) and b_k (denominator) from the ratio
    // b_k / b_{k-1} = T (n − k + 1) / ((2n − k + 1) k), with a_k = (−1)^k b_k.
    let mut a = vec![1.0; n + 1];
    let mut b = vec![1.0; n + 1];
    for k in 1..=n {
        let fact = t_s * (n - k + 1) as f64 / ((2 * n - k + 1) as f64 * k as f64);
        a[k] = -fact * a[k - 1];
        b[k] = fact * b[k - 1];
    }
    let lead = b[n];
    let num = Poly::new(a.iter().rev().map(|x| x / lead).collect());
    let den = Poly::new(b.iter().rev().map(|x| x / lead).collect());
    (num, den)
}

/// [`pade`] after checking the delay (finite, ≥ 0, seconds) and the order (1 to [`MAX_PADE_ORDER`]),
/// and that every coefficient is finite (errors name the delay and order otherwise).
pub fn pade_checked(t_s: f64, n: usize) -> Result<(Poly, Poly)> {
    if !(t_s.is_finite() && t_s >= 0.0) {
        return Err(LtiError::InvalidArgument(format!(
            "Padé approximation: the delay must be finite and >= 0 s, got {t_s}"
        )));
    }
    if !(1..=MAX_PADE_ORDER).contains(&n) {
        return Err(LtiError::InvalidArgument(format!(
            "Padé order {n} is outside the supported range 1 to {MAX_PADE_ORDER} (order 0 would drop the delay)"
        )));
    }
    let (num, den) = pade(t_s, n);
    if num.coeffs.iter().chain(&den.coeffs).any(|c| !c.is_finite()) {
        return Err(LtiError::InvalidArgument(format!(
            "Padé order {n} of a {t_s} s delay has coefficients beyond the floating-point range; use a lower order"
        )));
    }
    Ok((num, den))
}

/// One delay as a SISO state-space model: Padé of order `n` in continuous time, exact `z^-k`
/// shift register in discrete time.
fn delay_model(t_s: f64, n: usize, dt: f64) -> Result<StateSpace> {
    if dt > 0.0 {
        let samples = (t_s / dt).round();
        if !(samples.is_finite() && samples <= MAX_DISCRETE_DELAY_STATES as f64) {
            return Err(LtiError::InvalidArgument(format!(
                "a {t_s} s delay at dt = {dt} s is {samples} samples; at most {MAX_DISCRETE_DELAY_STATES} shift-register states are supported"
            )));
        }
        let k = samples as usize;
        if k == 0 {
            return Ok(identity(1, dt));
        }
        let a = Mat::from_fn(k, k, |i, j| f64::from(u8::from(i == j + 1)));
        let b = Mat::from_fn(k, 1, |i, _| f64::from(u8::from(i == 0)));
        let c = Mat::from_fn(1, k, |_, j| f64::from(u8::from(j == k - 1)));
        return Ok(raw(a, b, c, Mat::zeros(1, 1), dt));
    }
    let (num, den) = pade_checked(t_s, n)?;
    let (a, b, c, d) = siso_realization(&num, &den);
    let m = raw(a, b, c, Mat::from_fn(1, 1, |_, _| d), dt);
    m.validate()?;
    Ok(m)
}

fn raw(a: Mat<f64>, b: Mat<f64>, c: Mat<f64>, d: Mat<f64>, dt: f64) -> StateSpace {
    let (nu, ny) = (d.ncols(), d.nrows());
    StateSpace {
        a,
        b,
        c,
        d,
        dt,
        input_delay: vec![0.0; nu],
        output_delay: vec![0.0; ny],
    }
}

fn identity(n: usize, dt: f64) -> StateSpace {
    raw(
        Mat::zeros(0, 0),
        Mat::zeros(0, n),
        Mat::zeros(n, 0),
        Mat::identity(n, n),
        dt,
    )
}

impl StateSpace {
    /// The model with every input and output delay replaced by an order-`n` Padé approximant
    /// (continuous time) or by exact shift-register states (discrete time); the result has no delays.
    ///
    /// Infallible for compatibility: an order outside 1 to [`MAX_PADE_ORDER`] is clamped into that
    /// range (order 0 used to drop the delay silently), and should the approximation still fail
    /// (coefficients out of range, too many discrete delay states) the lowest order is used, then,
    /// only for a discrete delay beyond [`MAX_DISCRETE_DELAY_STATES`] samples, the model is returned
    /// with its delays kept (never dropped). Prefer [`StateSpace::try_pade`], which reports these cases.
    pub fn pade(&self, n: usize) -> StateSpace {
        let n = n.clamp(1, MAX_PADE_ORDER);
        self.try_pade(n)
            .or_else(|_| self.try_pade(1))
            .unwrap_or_else(|_| self.clone())
    }

    /// [`StateSpace::pade`] with errors: the order must be 1 to [`MAX_PADE_ORDER`], the Padé
    /// coefficients finite, and a discrete delay at most [`MAX_DISCRETE_DELAY_STATES`] samples.
    pub fn try_pade(&self, n: usize) -> Result<StateSpace> {
        if self.dt == 0.0 && self.has_delay() && !(1..=MAX_PADE_ORDER).contains(&n) {
            return Err(LtiError::InvalidArgument(format!(
                "Padé order {n} is outside the supported range 1 to {MAX_PADE_ORDER} (order 0 would drop the delay)"
            )));
        }
        let core = raw(self.a.clone(), self.b.clone(), self.c.clone(), self.d.clone(), self.dt);
        let block = |delays: &[f64]| -> Result<StateSpace> {
            let mut acc = identity(0, self.dt);
            for &t in delays {
                let m = if t > 0.0 {
                    delay_model(t, n, self.dt)?
                } else {
                    identity(1, self.dt)
                };
                acc = append(&acc, &m)?;
            }
            Ok(acc)
        };
        let mut out = core;
        if self.input_delay.iter().any(|&t| t > 0.0) {
            out = series(&block(&self.input_delay)?, &out)?;
        }
        if self.output_delay.iter().any(|&t| t > 0.0) {
            out = series(&out, &block(&self.output_delay)?)?;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::parse_model;
    use faer::c64;

    #[test]
    fn first_order_closed_form() {
        // [1/1] Padé of e^{-Ts}: (1 − sT/2)/(1 + sT/2) = (−s + 2/T)/(s + 2/T).
        let (n, d) = pade(0.1, 1);
        assert!((n.coeffs[0] + 1.0).abs() < 1e-15 && (n.coeffs[1] - 20.0).abs() < 1e-12);
        assert!((d.coeffs[0] - 1.0).abs() < 1e-15 && (d.coeffs[1] - 20.0).abs() < 1e-12);
    }

    #[test]
    fn model_delays_replaced() {
        let g = parse_model("exp(-0.032*s)/(0.0256*s+1)").unwrap();
        let p = g.pade(3);
        assert!(!p.has_delay());
        assert_eq!(p.nx(), 4);
        // At low frequency the Padé model matches the exact delay closely ([3/3] error ~ (wT)^7).
        let w = 5.0;
        let s = c64::new(0.0, w);
        let exact = (-s * 0.032).exp() / (s * 0.0256 + 1.0);
        let (num, den) = pade(0.032, 3);
        let approx = num.eval(s) / den.eval(s) / (s * 0.0256 + 1.0);
        assert!((exact - approx).norm() < 1e-6);
        let gd = crate::discretize::c2d(&g, 0.004, crate::discretize::Method::Zoh).unwrap();
        let pd = gd.pade(3);
        assert_eq!(pd.nx(), 1 + 8);
    }

    #[test]
    fn order_bounds_are_errors_not_dropped_delays() {
        let g = parse_model("exp(-0.032*s)/(0.0256*s+1)").unwrap();
        for n in [0, MAX_PADE_ORDER + 1, 100] {
            let e = g.try_pade(n).unwrap_err().to_string();
            assert!(e.contains("1 to 20"), "{e}");
            // The infallible form clamps instead of dropping the delay.
            assert!(g.pade(n).nx() > g.nx());
        }
        assert!(pade_checked(f64::NAN, 3).is_err());
        assert!(pade_checked(0.1, 0).is_err());
        assert!(pade_checked(1e-20, 20).is_err());
        assert!(g.try_pade(MAX_PADE_ORDER).is_ok());
        // A discrete delay of 1e9 samples is refused, not allocated.
        let gd = crate::discretize::c2d(&g, 0.004, crate::discretize::Method::Zoh).unwrap();
        let long = gd.clone().with_delays(vec![4e6], vec![0.0]).unwrap();
        assert!(long.try_pade(3).is_err());
    }
}
