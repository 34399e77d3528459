//! Real polynomials with coefficients in descending powers (as MATLAB), roots via companion eigenvalues.

use crate::error::{LtiError, Result};
use faer::{c64, Mat};
use std::ops::{Add, Mul, Neg, Sub};

/// A real polynomial `c[0]·s^n + c[1]·s^(n-1) + … + c[n]`; the zero polynomial is `[0.0]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Poly {
    /// Coefficients in descending powers; the first is non-zero unless the polynomial is zero.
    pub coeffs: Vec<f64>,
}

impl Poly {
    /// Builds a polynomial from descending coefficients, dropping exactly-zero leading terms.
    pub fn new(coeffs: Vec<f64>) -> Self {
        let first = coeffs.iter().position(|&c| c != 0.0);
        match first {
            Some(k) => Poly {
                coeffs: coeffs[k..].to_vec(),
            },
            None => Poly::zero(),
        }
    }

    /// The constant polynomial `c`.
    pub fn constant(c: f64) -> Self {
        Poly { coeffs: vec![c] }
    }

    /// The zero polynomial.
    pub fn zero() -> Self {
        Poly::constant(0.0)
    }

    /// The constant 1.
    pub fn one() -> Self {
        Poly::constant(1.0)
    }

    /// The polynomial `s`.
    pub fn s() -> Self {
        Poly { coeffs: vec![1.0, 0.0] }
    }

    /// True for the zero polynomial.
    pub fn is_zero(&self) -> bool {
        self.coeffs.iter().all(|&c| c == 0.0)
    }

    /// Degree (0 for constants, including zero).
    pub fn degree(&self) -> usize {
        self.coeffs.len().saturating_sub(1)
    }

    /// Leading coefficient.
    pub fn leading(&self) -> f64 {
        self.coeffs.first().copied().unwrap_or(0.0)
    }

    /// Coefficient of `s^k`.
    pub fn coeff_of_power(&self, k: usize) -> f64 {
        let n = self.degree();
        if k > n {
            0.0
        } else {
            self.coeffs[n - k]
        }
    }

    /// Value at a complex point (Horner).
    pub fn eval(&self, s: c64) -> c64 {
        self.coeffs.iter().fold(c64::new(0.0, 0.0), |acc, &c| acc * s + c)
    }

    /// Value at a real point (Horner).
    pub fn eval_real(&self, x: f64) -> f64 {
        self.coeffs.iter().fold(0.0, |acc, &c| acc * x + c)
    }

    /// The polynomial times a scalar.
    pub fn scale(&self, k: f64) -> Poly {
        Poly::new(self.coeffs.iter().map(|&c| c * k).collect())
    }

    /// Integer power.
    pub fn powi(&self, k: u32) -> Poly {
        (0..k).fold(Poly::one(), |acc, _| &acc * self)
    }

    /// Derivative with respect to `s`.
    pub fn deriv(&self) -> Poly {
        let n = self.degree();
        if n == 0 {
            return Poly::zero();
        }
        Poly::new((0..n).map(|i| self.coeffs[i] * (n - i) as f64).collect())
    }

    /// Monic polynomial with the given roots; complex roots must come in conjugate pairs
    /// (the imaginary residue of the product is dropped).
    pub fn from_roots(roots: &[c64]) -> Poly {
        let mut c = vec![c64::new(1.0, 0.0)];
        for &r in roots {
            let mut next = vec![c64::new(0.0, 0.0); c.len() + 1];
            for (i, &ci) in c.iter().enumerate() {
                next[i] += ci;
                next[i + 1] -= ci * r;
            }
            c = next;
        }
        Poly::new(c.iter().map(|z| z.re).collect())
    }

    /// Roots as eigenvalues of the companion matrix of the frequency-scaled monic polynomial.
    ///
    /// Roots at the origin (trailing zero coefficients) are returned exactly.
    pub fn roots(&self) -> Result<Vec<c64>> {
        if self.is_zero() {
            return Err(LtiError::InvalidArgument(
                "the zero polynomial has no finite roots".into(),
            ));
        }
        let mut c = self.coeffs.clone();
        let mut out = Vec::new();
        while c.len() > 1 && c[c.len() - 1] == 0.0 {
            c.pop();
            out.push(c64::new(0.0, 0.0));
        }
        let n = c.len() - 1;
        if n == 0 {
            return Ok(out);
        }
        // Scale s = alpha·x so that the roots of the scaled polynomial are of order one; this keeps
        // the companion matrix entries comparable and the eigenvalues accurate.
        let alpha = (c[n] / c[0]).abs().powf(1.0 / n as f64);
        let alpha = if alpha.is_finite() && alpha > 0.0 { alpha } else { 1.0 };
        let monic: Vec<f64> = (1..=n).map(|k| c[k] / (c[0] * alpha.powi(k as i32))).collect();
        if n == 1 {
            out.push(c64::new(-monic[0] * alpha, 0.0));
            return Ok(out);
        }
        let comp = Mat::<f64>::from_fn(n, n, |i, j| {
            if i == 0 {
                -monic[j]
            } else if i == j + 1 {
                1.0
            } else {
                0.0
            }
        });
        let ev = comp
            .eigenvalues()
            .map_err(|e| LtiError::Numerical(format!("companion eigenvalues: {e:?}")))?;
        out.extend(ev.into_iter().map(|z| z * alpha));
        Ok(out)
    }
}

impl Add for &Poly {
    type Output = Poly;
    fn add(self, o: &Poly) -> Poly {
        let n = self.coeffs.len().max(o.coeffs.len());
        let get = |p: &Poly, i: usize| {
            let off = n - p.coeffs.len();
            if i < off {
                0.0
            } else {
                p.coeffs[i - off]
            }
        };
        Poly::new((0..n).map(|i| get(self, i) + get(o, i)).collect())
    }
}

impl Sub for &Poly {
    type Output = Poly;
    fn sub(self, o: &Poly) -> Poly {
        self + &(-o)
    }
}

impl Neg for &Poly {
    type Output = Poly;
    fn neg(self) -> Poly {
        Poly {
            coeffs: self.coeffs.iter().map(|&c| -c).collect(),
        }
    }
}

impl Mul for &Poly {
    type Output = Poly;
    fn mul(self, o: &Poly) -> Poly {
        let mut c = vec![0.0; self.coeffs.len() + o.coeffs.len() - 1];
        for (i, &a) in self.coeffs.iter().enumerate() {
            for (j, &b) in o.coeffs.iter().enumerate() {
                c[i + j] += a * b;
            }
        }
        Poly::new(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_and_eval() {
        // (s + 1)(s - 2) = s^2 - s - 2, expanded by hand.
        let p = &Poly::new(vec![1.0, 1.0]) * &Poly::new(vec![1.0, -2.0]);
        assert_eq!(p.coeffs, vec![1.0, -1.0, -2.0]);
        assert_eq!(p.eval_real(3.0), 4.0);
        let q = &p - &p;
        assert!(q.is_zero());
        assert_eq!(Poly::new(vec![0.0, 0.0, 3.0]).degree(), 0);
        assert_eq!(p.deriv().coeffs, vec![2.0, -1.0]);
    }

    #[test]
    fn roots_round_trip() {
        let r = [
            c64::new(-1.0, 0.0),
            c64::new(-2.0, 3.0),
            c64::new(-2.0, -3.0),
            c64::new(0.0, 0.0),
            c64::new(500.0, 0.0),
        ];
        let p = Poly::from_roots(&r).scale(7.0);
        let mut got = p.roots().unwrap();
        assert_eq!(got.len(), 5);
        for want in r {
            let (k, d) = got
                .iter()
                .enumerate()
                .map(|(k, z)| (k, (z - want).norm()))
                .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
            assert!(d < 1e-9 * (1.0 + want.norm()), "root {want} missed by {d}");
            got.remove(k);
        }
    }

    #[test]
    fn zero_poly_roots_is_error() {
        assert!(Poly::zero().roots().is_err());
    }
}
