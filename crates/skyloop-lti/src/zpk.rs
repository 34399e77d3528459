//! Zero-pole-gain models: for each SISO entry its zeros, poles and gain, with delays.

use crate::convert::{ss_entry_zpk, tf_to_ss};
use crate::error::{LtiError, Result};
use crate::interconnect::series;
use crate::poly::Poly;
use crate::ss::StateSpace;
use crate::tf::TransferFunction;
use faer::c64;

/// `G[i][j](s) = k[i][j] · Π(s − z) / Π(s − p)`, indexed \[output\]\[input\]; complex roots come in
/// conjugate pairs. Delays in seconds as in [`StateSpace`].
#[derive(Debug, Clone, PartialEq)]
pub struct Zpk {
    /// Zeros of each entry.
    pub z: Vec<Vec<Vec<c64>>>,
    /// Poles of each entry.
    pub p: Vec<Vec<Vec<c64>>>,
    /// Gain of each entry.
    pub k: Vec<Vec<f64>>,
    /// Sample period in seconds; 0 for continuous time.
    pub dt: f64,
    /// Delay on each input in seconds.
    pub input_delay: Vec<f64>,
    /// Delay on each output in seconds.
    pub output_delay: Vec<f64>,
}

impl Zpk {
    /// A delay-free SISO model.
    pub fn siso(z: Vec<c64>, p: Vec<c64>, k: f64, dt: f64) -> Self {
        Zpk {
            z: vec![vec![z]],
            p: vec![vec![p]],
            k: vec![vec![k]],
            dt,
            input_delay: vec![0.0],
            output_delay: vec![0.0],
        }
    }

    /// Zeros, poles and gain of every entry of a state-space model (minimal per entry).
    pub fn from_ss(sys: &StateSpace) -> Result<Self> {
        let (ny, nu) = (sys.ny(), sys.nu());
        let mut out = Zpk {
            z: vec![vec![Vec::new(); nu]; ny],
            p: vec![vec![Vec::new(); nu]; ny],
            k: vec![vec![0.0; nu]; ny],
            dt: sys.dt,
            input_delay: sys.input_delay.clone(),
            output_delay: sys.output_delay.clone(),
        };
        for i in 0..ny {
            for j in 0..nu {
                let (z, p, k) = ss_entry_zpk(sys, i, j)?;
                (out.z[i][j], out.p[i][j], out.k[i][j]) = (z, p, k);
            }
        }
        Ok(out)
    }

    /// The transfer-function form (polynomials expanded from the roots).
    pub fn to_tf(&self) -> Result<TransferFunction> {
        let ny = self.k.len();
        let nu = self.k.first().map_or(0, |r| r.len());
        if self.z.len() != ny || self.p.len() != ny || self.z.iter().chain(&self.p).any(|r| r.len() != nu) {
            return Err(LtiError::Dimension(
                "z, p and k must have the same [output][input] shape".into(),
            ));
        }
        let num = (0..ny)
            .map(|i| {
                (0..nu)
                    .map(|j| Poly::from_roots(&self.z[i][j]).scale(self.k[i][j]))
                    .collect()
            })
            .collect();
        let den = (0..ny)
            .map(|i| (0..nu).map(|j| Poly::from_roots(&self.p[i][j])).collect())
            .collect();
        let mut tf = TransferFunction::new(num, den, self.dt)?;
        tf.input_delay = self.input_delay.clone();
        tf.output_delay = self.output_delay.clone();
        tf.validate()?;
        Ok(tf)
    }

    /// A state-space realization: SISO as a cascade of first- and second-order sections (no
    /// expanded polynomials, so clustered roots stay accurate); MIMO via the transfer function.
    pub fn to_ss(&self) -> Result<StateSpace> {
        if self.k.len() == 1 && self.k[0].len() == 1 {
            let s = zpk_sections_ss(&self.z[0][0], &self.p[0][0], self.k[0][0], self.dt)?;
            return s.with_delays(self.input_delay.clone(), self.output_delay.clone());
        }
        tf_to_ss(&self.to_tf()?)
    }
}

/// Real factors of a root list: conjugate pairs as quadratics, real roots as linears.
fn real_factors(roots: &[c64]) -> Result<Vec<Poly>> {
    let mut rest: Vec<c64> = roots.to_vec();
    let mut out = Vec::new();
    while let Some(r) = rest.pop() {
        if r.im == 0.0 {
            out.push(Poly::new(vec![1.0, -r.re]));
            continue;
        }
        let k = rest
            .iter()
            .enumerate()
            .map(|(k, x)| (k, (x - r.conj()).norm()))
            .fold(None, |acc: Option<(usize, f64)>, b| match acc {
                Some(a) if a.1 <= b.1 => Some(a),
                _ => Some(b),
            })
            .filter(|(_, d)| *d <= 1e-8 * (1.0 + r.norm()))
            .map(|(k, _)| k)
            .ok_or_else(|| LtiError::InvalidArgument(format!("complex root {r} has no conjugate partner")))?;
        rest.remove(k);
        out.push(Poly::new(vec![1.0, -2.0 * r.re, r.norm_sqr()]));
    }
    Ok(out)
}

/// SISO realization of `k·Π(s − z)/Π(s − p)` as a series of sections of degree ≤ 2, each zero
/// factor attached to a pole factor of at least its degree.
pub(crate) fn zpk_sections_ss(z: &[c64], p: &[c64], k: f64, dt: f64) -> Result<StateSpace> {
    if z.len() > p.len() {
        return Err(LtiError::Unsupported("more zeros than poles: improper model".into()));
    }
    let mut zf = real_factors(z)?;
    let mut pf = real_factors(p)?;
    // Quadratic poles first so quadratic zero factors find a partner.
    pf.sort_by_key(|f| std::cmp::Reverse(f.degree()));
    zf.sort_by_key(|f| std::cmp::Reverse(f.degree()));
    let mut sections: Vec<(Poly, Poly)> = Vec::new();
    let mut zi = 0;
    for den in pf {
        let mut num = Poly::one();
        while zi < zf.len() && num.degree() + zf[zi].degree() <= den.degree() {
            num = &num * &zf[zi];
            zi += 1;
        }
        sections.push((num, den));
    }
    // Leftover zero factors (a quadratic zero with only linear poles left): merge pairs of sections.
    while zi < zf.len() {
        let (n1, d1) = sections
            .pop()
            .ok_or_else(|| LtiError::Numerical("zpk sections".into()))?;
        let (n2, d2) = sections
            .pop()
            .ok_or_else(|| LtiError::Numerical("zpk sections".into()))?;
        let mut num = &n1 * &n2;
        let den = &d1 * &d2;
        while zi < zf.len() && num.degree() + zf[zi].degree() <= den.degree() {
            num = &num * &zf[zi];
            zi += 1;
        }
        sections.insert(0, (num, den));
    }
    let mut acc = StateSpace::gain(faer::Mat::from_fn(1, 1, |_, _| k), dt)?;
    for (num, den) in sections {
        let sec = tf_to_ss(&TransferFunction::siso(num, den, dt)?)?;
        acc = series(&acc, &sec)?;
    }
    Ok(acc)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::parse_model;

    #[test]
    fn round_trip() {
        // 3(s+2)/((s+1)(s^2+2s+5)): zero −2, poles −1, −1±2j, gain 3 (read off the factors).
        let g = parse_model("3*(s+2)/((s+1)*(s^2+2*s+5))").unwrap();
        let z = Zpk::from_ss(&g).unwrap();
        assert_eq!(z.z[0][0].len(), 1);
        assert!((z.z[0][0][0] - c64::new(-2.0, 0.0)).norm() < 1e-10);
        assert!((z.k[0][0] - 3.0).abs() < 1e-10);
        let mut p = z.p[0][0].clone();
        p.sort_by(|a, b| a.im.total_cmp(&b.im));
        assert!((p[0] - c64::new(-1.0, -2.0)).norm() < 1e-10 && (p[2] - c64::new(-1.0, 2.0)).norm() < 1e-10);
        let back = z.to_ss().unwrap();
        assert_eq!(back.nx(), 3);
    }
}
