//! Transfer functions: a MIMO matrix of SISO numerator/denominator polynomials with delays.

use crate::error::{LtiError, Result};
use crate::poly::Poly;
use faer::{c64, Mat};

/// A transfer-function matrix `G[i][j](s) = num[i][j](s) / den[i][j](s) · e^(−io_delay[i][j]·s)`
/// with extra input and output delays (seconds); `dt > 0` means discrete time in `z`.
#[derive(Debug, Clone, PartialEq)]
pub struct TransferFunction {
    /// Numerators, indexed \[output\]\[input\].
    pub num: Vec<Vec<Poly>>,
    /// Denominators, indexed \[output\]\[input\].
    pub den: Vec<Vec<Poly>>,
    /// Sample period in seconds; 0 for continuous time.
    pub dt: f64,
    /// Delay on each input in seconds.
    pub input_delay: Vec<f64>,
    /// Delay on each output in seconds.
    pub output_delay: Vec<f64>,
    /// Delay of each entry in seconds, indexed \[output\]\[input\].
    pub io_delay: Vec<Vec<f64>>,
}

impl TransferFunction {
    /// A delay-free SISO transfer function `num/den`; the denominator must not be zero.
    pub fn siso(num: Poly, den: Poly, dt: f64) -> Result<Self> {
        TransferFunction::new(vec![vec![num]], vec![vec![den]], dt)
    }

    /// A delay-free MIMO transfer function from \[output\]\[input\] numerators and denominators.
    pub fn new(num: Vec<Vec<Poly>>, den: Vec<Vec<Poly>>, dt: f64) -> Result<Self> {
        let ny = num.len();
        let nu = num.first().map_or(0, |r| r.len());
        let tf = TransferFunction {
            num,
            den,
            dt,
            input_delay: vec![0.0; nu],
            output_delay: vec![0.0; ny],
            io_delay: vec![vec![0.0; nu]; ny],
        };
        tf.validate()?;
        Ok(tf)
    }

    /// Checks shapes, non-zero denominators, finite coefficients and delays.
    pub fn validate(&self) -> Result<()> {
        let ny = self.num.len();
        let nu = self.num.first().map_or(0, |r| r.len());
        let shape_ok = |m: &Vec<Vec<Poly>>| m.len() == ny && m.iter().all(|r| r.len() == nu);
        if !shape_ok(&self.num) || !shape_ok(&self.den) {
            return Err(LtiError::Dimension(format!(
                "numerators and denominators must both be {ny}x{nu} matrices"
            )));
        }
        if self.io_delay.len() != ny || self.io_delay.iter().any(|r| r.len() != nu) {
            return Err(LtiError::Dimension(format!("io_delay must be {ny}x{nu}")));
        }
        if self.input_delay.len() != nu || self.output_delay.len() != ny {
            return Err(LtiError::Dimension(format!(
                "need {nu} input delays and {ny} output delays"
            )));
        }
        for (i, row) in self.den.iter().enumerate() {
            for (j, d) in row.iter().enumerate() {
                if d.is_zero() {
                    return Err(LtiError::InvalidArgument(format!("denominator ({i},{j}) is zero")));
                }
                let all = d.coeffs.iter().chain(&self.num[i][j].coeffs);
                if all.into_iter().any(|c| !c.is_finite()) {
                    return Err(LtiError::InvalidArgument(format!(
                        "entry ({i},{j}) has non-finite coefficients"
                    )));
                }
            }
        }
        if !(self.dt.is_finite() && self.dt >= 0.0) {
            return Err(LtiError::InvalidArgument(format!(
                "sample time must be finite and >= 0, got {}",
                self.dt
            )));
        }
        let delays = self
            .input_delay
            .iter()
            .chain(&self.output_delay)
            .chain(self.io_delay.iter().flatten());
        if delays.into_iter().any(|&t| !(t.is_finite() && t >= 0.0)) {
            return Err(LtiError::InvalidArgument("delays must be finite and >= 0".into()));
        }
        Ok(())
    }

    /// Number of outputs.
    pub fn ny(&self) -> usize {
        self.num.len()
    }

    /// Number of inputs.
    pub fn nu(&self) -> usize {
        self.num.first().map_or(0, |r| r.len())
    }

    /// Total delay of entry (i, j) in seconds (input + io + output).
    pub fn total_delay(&self, i: usize, j: usize) -> f64 {
        self.input_delay[j] + self.io_delay[i][j] + self.output_delay[i]
    }

    /// Frequency response at one complex point (`s`, or `z` in discrete time), exact with delays
    /// (in discrete time a delay of `k·dt` seconds is `z^-k`).
    pub fn eval(&self, s: c64) -> Mat<c64> {
        Mat::from_fn(self.ny(), self.nu(), |i, j| {
            let g = self.num[i][j].eval(s) / self.den[i][j].eval(s);
            let t = self.total_delay(i, j);
            if t == 0.0 {
                g
            } else if self.dt > 0.0 {
                g * s.powf(-t / self.dt)
            } else {
                g * (-s * t).exp()
            }
        })
    }

    /// True when every entry has deg(num) ≤ deg(den).
    pub fn is_proper(&self) -> bool {
        self.num
            .iter()
            .flatten()
            .zip(self.den.iter().flatten())
            .all(|(n, d)| n.is_zero() || n.degree() <= d.degree())
    }

    fn check_same_dt(&self, o: &TransferFunction) -> Result<()> {
        if self.dt != o.dt {
            return Err(LtiError::InvalidArgument(format!(
                "sample times differ: {} and {}",
                self.dt, o.dt
            )));
        }
        Ok(())
    }

    /// Entry delays folded into io_delay (input and output delays set to zero).
    fn folded_delays(&self) -> Vec<Vec<f64>> {
        (0..self.ny())
            .map(|i| (0..self.nu()).map(|j| self.total_delay(i, j)).collect())
            .collect()
    }

    /// Sum `self + o` (same shape); entries that add must carry the same delay.
    pub fn add(&self, o: &TransferFunction) -> Result<TransferFunction> {
        self.check_same_dt(o)?;
        if (self.ny(), self.nu()) != (o.ny(), o.nu()) {
            return Err(LtiError::Dimension(format!(
                "cannot add {}x{} and {}x{} transfer functions",
                self.ny(),
                self.nu(),
                o.ny(),
                o.nu()
            )));
        }
        let (da, db) = (self.folded_delays(), o.folded_delays());
        let mut out = TransferFunction::new(self.num.clone(), self.den.clone(), self.dt)?;
        for i in 0..self.ny() {
            for j in 0..self.nu() {
                let (n, d) = rat_add(&self.num[i][j], &self.den[i][j], &o.num[i][j], &o.den[i][j]);
                let delay = if self.num[i][j].is_zero() {
                    db[i][j]
                } else if o.num[i][j].is_zero() || same_delay(da[i][j], db[i][j]) {
                    da[i][j]
                } else {
                    return Err(LtiError::Unsupported(format!(
                        "entry ({i},{j}): cannot add terms with different delays ({} s and {} s) exactly",
                        da[i][j], db[i][j]
                    )));
                };
                out.num[i][j] = n;
                out.den[i][j] = d;
                out.io_delay[i][j] = delay;
            }
        }
        Ok(out)
    }

    /// Negation.
    pub fn neg(&self) -> TransferFunction {
        let mut out = self.clone();
        for n in out.num.iter_mut().flatten() {
            *n = -&*n;
        }
        out
    }

    /// Product `self · o` (matrix product; output of `o` feeds input of `self`).
    pub fn mul(&self, o: &TransferFunction) -> Result<TransferFunction> {
        self.check_same_dt(o)?;
        if self.nu() != o.ny() {
            return Err(LtiError::Dimension(format!(
                "cannot multiply {}x{} by {}x{}",
                self.ny(),
                self.nu(),
                o.ny(),
                o.nu()
            )));
        }
        let (da, db) = (self.folded_delays(), o.folded_delays());
        let (ny, nu) = (self.ny(), o.nu());
        let mut num = vec![vec![Poly::zero(); nu]; ny];
        let mut den = vec![vec![Poly::one(); nu]; ny];
        let mut delay = vec![vec![0.0; nu]; ny];
        for i in 0..ny {
            for j in 0..nu {
                let mut first = true;
                for k in 0..self.nu() {
                    let n = &self.num[i][k] * &o.num[k][j];
                    if n.is_zero() {
                        continue;
                    }
                    let d = &self.den[i][k] * &o.den[k][j];
                    let t = da[i][k] + db[k][j];
                    if first {
                        (num[i][j], den[i][j], delay[i][j]) = (n, d, t);
                        first = false;
                    } else if same_delay(t, delay[i][j]) {
                        let (sn, sd) = rat_add(&num[i][j], &den[i][j], &n, &d);
                        (num[i][j], den[i][j]) = (sn, sd);
                    } else {
                        return Err(LtiError::Unsupported(format!(
                            "entry ({i},{j}) of the product sums paths with different delays"
                        )));
                    }
                }
            }
        }
        let mut out = TransferFunction::new(num, den, self.dt)?;
        out.io_delay = delay;
        Ok(out)
    }

    /// Reciprocal of a SISO transfer function (a delay would become a prediction: error).
    pub fn inv(&self) -> Result<TransferFunction> {
        if self.ny() != 1 || self.nu() != 1 {
            return Err(LtiError::Dimension(
                "only a SISO transfer function can be inverted".into(),
            ));
        }
        if self.total_delay(0, 0) > 0.0 {
            return Err(LtiError::Unsupported("the inverse of a delay is not causal".into()));
        }
        if self.num[0][0].is_zero() {
            return Err(LtiError::InvalidArgument(
                "cannot invert a zero transfer function".into(),
            ));
        }
        TransferFunction::siso(self.den[0][0].clone(), self.num[0][0].clone(), self.dt)
    }
}

/// True when two delays are equal to rounding.
fn same_delay(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1e-300)
}

/// `n1/d1 + n2/d2` with a common denominator; equal denominators are not multiplied out.
pub(crate) fn rat_add(n1: &Poly, d1: &Poly, n2: &Poly, d2: &Poly) -> (Poly, Poly) {
    if n2.is_zero() {
        return (n1.clone(), d1.clone());
    }
    if n1.is_zero() {
        return (n2.clone(), d2.clone());
    }
    if d1 == d2 {
        return (n1 + n2, d1.clone());
    }
    (&(n1 * d2) + &(n2 * d1), d1 * d2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn siso_algebra() {
        // 1/(s+1) + 1/(s+2) = (2s+3)/(s^2+3s+2), by hand.
        let a = TransferFunction::siso(Poly::one(), Poly::new(vec![1.0, 1.0]), 0.0).unwrap();
        let b = TransferFunction::siso(Poly::one(), Poly::new(vec![1.0, 2.0]), 0.0).unwrap();
        let s = a.add(&b).unwrap();
        assert_eq!(s.num[0][0].coeffs, vec![2.0, 3.0]);
        assert_eq!(s.den[0][0].coeffs, vec![1.0, 3.0, 2.0]);
        let p = a.mul(&b).unwrap();
        assert_eq!(p.den[0][0].coeffs, vec![1.0, 3.0, 2.0]);
        let g = p.eval(c64::new(0.0, 1.0))[(0, 0)];
        let want = c64::new(1.0, 0.0) / (c64::new(1.0, 1.0) * c64::new(2.0, 1.0));
        assert!((g - want).norm() < 1e-15);
    }

    #[test]
    fn different_delays_do_not_add() {
        let mut a = TransferFunction::siso(Poly::one(), Poly::new(vec![1.0, 1.0]), 0.0).unwrap();
        let b = a.clone();
        a.io_delay[0][0] = 0.1;
        assert!(matches!(a.add(&b), Err(LtiError::Unsupported(_))));
        assert!(a.inv().is_err());
    }

    #[test]
    fn zero_denominator_rejected() {
        assert!(TransferFunction::siso(Poly::one(), Poly::zero(), 0.0).is_err());
    }
}
