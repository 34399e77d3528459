//! Second-order sections of a discrete SISO model: H(z) = k·Π (b0 + b1 z⁻¹ + b2 z⁻²)/(1 + a1 z⁻¹ + a2 z⁻²),
//! the form a flight controller runs (cascaded biquads are far less sensitive to coefficient rounding
//! than one high-order difference equation).
//!
//! Poles and zeros are paired into conjugate pairs (leftover real roots together, closest first) and
//! matched section by section in order of magnitude; the gain comes from one evaluation on the unit
//! circle and is checked to be real, which catches a factorization that does not match the model.

use crate::error::{LtiError, Result};
use crate::ss::StateSpace;
use faer::c64;
use serde::Serialize;

/// One biquad (b0 + b1 z⁻¹ + b2 z⁻²)/(1 + a1 z⁻¹ + a2 z⁻²); first-order sections have b2 = a2 = 0.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Section {
    /// Numerator coefficient of z⁰.
    pub b0: f64,
    /// Numerator coefficient of z⁻¹.
    pub b1: f64,
    /// Numerator coefficient of z⁻².
    pub b2: f64,
    /// Denominator coefficient of z⁻¹.
    pub a1: f64,
    /// Denominator coefficient of z⁻².
    pub a2: f64,
}

/// A discrete SISO model as gain·Π sections, with the sample time it was built for.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Sos {
    /// The sections, lowest-magnitude poles first.
    pub sections: Vec<Section>,
    /// Overall gain k.
    pub gain: f64,
    /// Sample time, s.
    pub dt: f64,
}

impl Sos {
    /// Frequency response k·Π sections at z = e^{jω·dt}, ω in rad/s.
    pub fn eval(&self, w_rad_s: f64) -> c64 {
        let zinv = c64::from_polar(1.0, -w_rad_s * self.dt);
        self.sections
            .iter()
            .fold(c64::new(self.gain, 0.0), |acc, s| acc * section_value(s, zinv))
    }
}

fn section_value(s: &Section, zinv: c64) -> c64 {
    (s.b0 + s.b1 * zinv + s.b2 * zinv * zinv) / (1.0 + s.a1 * zinv + s.a2 * zinv * zinv)
}

/// Pairs roots into conjugate pairs and leftover reals (closest reals together).
fn pair(mut r: Vec<c64>) -> Vec<(c64, Option<c64>)> {
    let mut out = Vec::new();
    let tol = 1e-9;
    let mut reals: Vec<f64> = Vec::new();
    r.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
    while let Some(z) = r.pop() {
        if z.im.abs() <= tol * z.norm().max(1.0) {
            reals.push(z.re);
        } else {
            let k = r
                .iter()
                .enumerate()
                .min_by(|a, b| (a.1 - z.conj()).norm().total_cmp(&(b.1 - z.conj()).norm()));
            if let Some((i, _)) = k {
                let w = r.remove(i);
                out.push((z, Some(w)));
            } else {
                reals.push(z.re);
            }
        }
    }
    reals.sort_by(|a, b| a.total_cmp(b));
    let mut it = reals.into_iter();
    while let Some(a) = it.next() {
        out.push((c64::new(a, 0.0), it.next().map(|b| c64::new(b, 0.0))));
    }
    out
}

/// Monic polynomial coefficients [1, c1, c2] of a root pair (or [0, 1, −z] for a single root, [0, 0, 1] for none),
/// as coefficients of z², z¹, z⁰.
fn quad(p: Option<(c64, Option<c64>)>) -> [f64; 3] {
    match p {
        Some((a, Some(b))) => [1.0, -(a + b).re, (a * b).re],
        Some((a, None)) => [0.0, 1.0, -a.re],
        None => [0.0, 0.0, 1.0],
    }
}

/// Factors a discrete SISO model into gain and second-order sections.
pub fn to_sos(d: &StateSpace) -> Result<Sos> {
    d.validate()?;
    if d.nu() != 1 || d.ny() != 1 || d.is_continuous() {
        return Err(LtiError::InvalidArgument(format!(
            "second-order sections need a discrete SISO model, got {}x{} with dt = {}",
            d.ny(),
            d.nu(),
            d.dt
        )));
    }
    if d.has_delay() {
        return Err(LtiError::Unsupported(
            "second-order sections of a model with delays: absorb the delays into the states first".into(),
        ));
    }
    let poles = crate::poles_zeros::poles(d)?;
    let zeros = crate::poles_zeros::zeros(d)?;
    if zeros.len() > poles.len() {
        return Err(LtiError::InvalidArgument("more zeros than poles".into()));
    }
    let pp = pair(poles);
    let zp = pair(zeros);
    let mut secs = Vec::with_capacity(pp.len().max(1));
    let mut zi = zp.into_iter();
    for p in pp {
        let den = quad(Some(p));
        let num = quad(zi.next());
        // (n0 z² + n1 z + n2)/(z² + d1 z + d2) in z⁻¹ form when the denominator is 2nd order;
        // a 1st-order denominator [0, 1, −p] is shifted up to (z − p)·z / z².
        let (n, dd) = if den[0] == 0.0 {
            if num[0] != 0.0 {
                return Err(LtiError::Numerical(
                    "cannot place a 2nd-order numerator over a 1st-order section".into(),
                ));
            }
            ([num[1], num[2], 0.0], [den[1], den[2], 0.0])
        } else {
            (num, den)
        };
        secs.push(Section {
            b0: n[0],
            b1: n[1],
            b2: n[2],
            a1: dd[1],
            a2: dd[2],
        });
    }
    let mut sos = Sos {
        sections: secs,
        gain: 1.0,
        dt: d.dt,
    };
    // Gain from one evaluation point on the unit circle, away from poles and zeros.
    let w = 0.77 / d.dt;
    let h = crate::freqresp::freqresp(d, &[w])?[0][(0, 0)];
    let prod = sos.eval(w);
    if prod.norm() == 0.0 || !prod.norm().is_finite() {
        return Err(LtiError::Numerical("cannot determine the SOS gain".into()));
    }
    let k = h / prod;
    if k.im.abs() > 1e-6 * k.norm() {
        return Err(LtiError::Numerical(format!(
            "SOS factorization does not match the model (gain {k})"
        )));
    }
    sos.gain = k.re;
    Ok(sos)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discretize::{c2d, Method};

    #[test]
    fn sections_reproduce_the_model_on_the_unit_circle() {
        // Paper eq. (12) controller (bicopter), Tustin at 250 Hz: 5 poles → 3 sections.
        let c = crate::expr::parse_model(
            "24.02*(s+54.01)*(s+0.2474)*(s^2+139.3*s+26240)/(s*(s^2+24.14*s+8544)*(s^2+232.4*s+70410))",
        )
        .expect("parses");
        let d = c2d(&c, 1.0 / 250.0, Method::Tustin { prewarp_rad_s: None }).expect("c2d");
        let sos = to_sos(&d).expect("sos");
        assert_eq!(sos.sections.len(), 3);
        for f_hz in [0.1, 1.0, 10.0, 50.0, 120.0] {
            let w = 2.0 * std::f64::consts::PI * f_hz;
            let h = crate::freqresp::freqresp(&d, &[w]).expect("fr")[0][(0, 0)];
            let e = (sos.eval(w) - h).norm() / h.norm();
            assert!(e < 1e-9, "at {f_hz} Hz: relative error {e:e}");
        }
    }

    #[test]
    fn continuous_or_mimo_models_are_errors() {
        let c = crate::expr::parse_model("1/(s+1)").expect("parses");
        assert!(to_sos(&c).is_err());
        let d = c2d(&c, 0.01, Method::Zoh).expect("c2d");
        let two = crate::interconnect::append(&d, &d).expect("append");
        assert!(to_sos(&two).is_err());
    }
}
