//! Uncertain elements: real parameters, complex scalars and full dynamic blocks, each normalized to
//! a δ or Δ of unit size so that an uncertain system is an LFT of a nominal model and blkdiag(Δ).

use super::blocks::BlockKind;
use crate::error::Result;
use crate::error::RobustError;
use faer::c64;
use skyloop_lti::StateSpace;

/// An uncertain real parameter p ∈ [lower, upper] with nominal value p(δ = 0) = nominal.
#[derive(Debug, Clone, PartialEq)]
pub struct UReal {
    /// Name, for reports.
    pub name: String,
    /// Nominal value.
    pub nominal: f64,
    /// Smallest value.
    pub lower: f64,
    /// Largest value.
    pub upper: f64,
}

impl UReal {
    /// p ∈ [lower, upper] around `nominal` (lower ≤ nominal ≤ upper, lower < upper).
    pub fn range(name: &str, nominal: f64, lower: f64, upper: f64) -> Result<Self> {
        if !(nominal.is_finite() && lower.is_finite() && upper.is_finite()) {
            return Err(RobustError::InvalidArgument(format!(
                "ureal {name}: values must be finite"
            )));
        }
        if !(lower <= nominal && nominal <= upper && lower < upper) {
            return Err(RobustError::InvalidArgument(format!(
                "ureal {name}: need lower <= nominal <= upper and lower < upper, got {lower}, {nominal}, {upper}"
            )));
        }
        Ok(UReal {
            name: name.to_string(),
            nominal,
            lower,
            upper,
        })
    }

    /// p = nominal·(1 ± percent/100); `percent` > 0.
    pub fn percent(name: &str, nominal: f64, percent: f64) -> Result<Self> {
        if !(percent.is_finite() && percent > 0.0) || nominal == 0.0 {
            return Err(RobustError::InvalidArgument(format!(
                "ureal {name}: percentage uncertainty needs percent > 0 and a non-zero nominal"
            )));
        }
        let d = nominal.abs() * percent / 100.0;
        UReal::range(name, nominal, nominal - d, nominal + d)
    }

    /// The 2×2 upper-LFT coefficients [[m11, m12], [m21, m22]] with p(δ) = m22 + m21 δ (1 − m11 δ)⁻¹ m12,
    /// δ ∈ [−1, 1] mapping onto [lower, upper] and δ = 0 onto the nominal (a linear map when the
    /// nominal is centred; otherwise the bilinear map through the three points).
    pub fn lft(&self) -> [[f64; 2]; 2] {
        let (u, l) = (self.upper - self.nominal, self.nominal - self.lower);
        if u == 0.0 || l == 0.0 {
            // Nominal at an end of the range: the bilinear map degenerates; use the linear map
            // centred on the range, p = c + h δ, and accept δ ≠ 0 at the nominal.
            let (c, h) = (0.5 * (self.upper + self.lower), 0.5 * (self.upper - self.lower));
            return [[0.0, 1.0], [h, c]];
        }
        let b = (u - l) / (u + l);
        let a = 2.0 * u * l / (u + l);
        [[b, 1.0], [a, self.nominal]]
    }

    /// p(δ) for δ ∈ [−1, 1].
    pub fn value(&self, delta: f64) -> f64 {
        let m = self.lft();
        m[1][1] + m[1][0] * delta / (1.0 - m[0][0] * delta) * m[0][1]
    }

    /// Its block in Δ: a real scalar.
    pub fn block(&self) -> BlockKind {
        BlockKind::RealScalar { repeat: 1 }
    }
}

/// An uncertain complex scalar c = nominal + radius·δ, |δ| ≤ 1.
#[derive(Debug, Clone, PartialEq)]
pub struct UComplex {
    /// Name, for reports.
    pub name: String,
    /// Centre of the disc.
    pub nominal: c64,
    /// Radius of the disc (> 0).
    pub radius: f64,
}

impl UComplex {
    /// A disc of radius `radius` > 0 around `nominal`.
    pub fn new(name: &str, nominal: c64, radius: f64) -> Result<Self> {
        if !(radius.is_finite() && radius > 0.0 && nominal.re.is_finite() && nominal.im.is_finite()) {
            return Err(RobustError::InvalidArgument(format!(
                "ucomplex {name}: need a finite nominal and radius > 0"
            )));
        }
        Ok(UComplex {
            name: name.to_string(),
            nominal,
            radius,
        })
    }
    /// c(δ) for |δ| ≤ 1.
    pub fn value(&self, delta: c64) -> c64 {
        self.nominal + delta * self.radius
    }
    /// Its block in Δ: a complex scalar.
    pub fn block(&self) -> BlockKind {
        BlockKind::ComplexScalar { repeat: 1 }
    }
}

/// Unmodelled dynamics: a stable `rows × cols` Δ(s) with ‖Δ‖∞ ≤ 1, optionally shaped by a SISO
/// frequency weight W(s) (the perturbation is W·Δ), like MATLAB's ultidyn with a weight.
#[derive(Debug, Clone, PartialEq)]
pub struct ULtiDyn {
    /// Name, for reports.
    pub name: String,
    /// Outputs of Δ.
    pub rows: usize,
    /// Inputs of Δ.
    pub cols: usize,
    /// SISO weight multiplying Δ (none = 1).
    pub weight: Option<StateSpace>,
}

impl ULtiDyn {
    /// A `rows × cols` dynamic uncertainty with an optional SISO weight.
    pub fn new(name: &str, rows: usize, cols: usize, weight: Option<StateSpace>) -> Result<Self> {
        if rows == 0 || cols == 0 {
            return Err(RobustError::InvalidArgument(format!(
                "ultidyn {name}: dimensions must be positive"
            )));
        }
        if let Some(w) = &weight {
            w.validate()?;
            if w.ny() != 1 || w.nu() != 1 {
                return Err(RobustError::Dimension(format!(
                    "ultidyn {name}: the weight must be SISO, got {}x{}",
                    w.ny(),
                    w.nu()
                )));
            }
        }
        Ok(ULtiDyn {
            name: name.to_string(),
            rows,
            cols,
            weight,
        })
    }
    /// Its block in Δ: a full complex block (a scalar block when 1×1).
    pub fn block(&self) -> BlockKind {
        if self.rows == 1 && self.cols == 1 {
            BlockKind::ComplexScalar { repeat: 1 }
        } else {
            BlockKind::Full {
                rows: self.rows,
                cols: self.cols,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ureal_maps_the_range() {
        // Off-centre nominal: δ = −1, 0, 1 must give lower, nominal, upper exactly (definition).
        let p = UReal::range("k", 2.0, 1.0, 5.0).expect("valid");
        for (d, want) in [(-1.0, 1.0), (0.0, 2.0), (1.0, 5.0)] {
            assert!((p.value(d) - want).abs() < 1e-12, "p({d}) = {}", p.value(d));
        }
        // Monotone in between.
        let vals: Vec<f64> = (0..=20).map(|k| p.value(-1.0 + 0.1 * k as f64)).collect();
        assert!(vals.windows(2).all(|w| w[1] > w[0]));
        let q = UReal::percent("m", -4.0, 25.0).expect("valid");
        assert_eq!((q.lower, q.upper), (-5.0, -3.0));
        assert!((q.value(0.5) + 3.5).abs() < 1e-12);
        assert!(UReal::range("x", 0.0, 1.0, 2.0).is_err());
        assert!(UReal::percent("x", 1.0, -3.0).is_err());
        assert!(UReal::range("x", f64::NAN, 1.0, 2.0).is_err());
    }

    #[test]
    fn ultidyn_checks_its_weight() {
        let w2 = StateSpace::gain(faer::Mat::zeros(2, 1), 0.0).expect("gain");
        assert!(ULtiDyn::new("d", 2, 2, Some(w2)).is_err());
        assert!(ULtiDyn::new("d", 0, 2, None).is_err());
        assert_eq!(
            ULtiDyn::new("d", 4, 4, None).expect("ok").block(),
            BlockKind::Full { rows: 4, cols: 4 }
        );
    }
}
