//! First-order weights in the style of MATLAB's `makeweight`.

use crate::error::Result;
use crate::error::RobustError;
use faer::Mat;
use skyloop_lti::StateSpace;

/// First-order weight W(s) = (hf·s + dc·a)/(s + a) with |W(0)| = dc, |W(j·crossover_rad_s)| = 1
/// and |W(j∞)| = hf; dc and hf positive and on opposite sides of 1 (continuous time).
pub fn makeweight(dc: f64, crossover_rad_s: f64, hf: f64) -> Result<StateSpace> {
    makeweight_mag(dc, crossover_rad_s, 1.0, hf)
}

/// As [`makeweight`] but with |W(j·w_rad_s)| = mag (mag strictly between dc and hf).
pub fn makeweight_mag(dc: f64, w_rad_s: f64, mag: f64, hf: f64) -> Result<StateSpace> {
    for (v, name) in [
        (dc, "dc gain"),
        (w_rad_s, "frequency"),
        (mag, "magnitude"),
        (hf, "high-frequency gain"),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(RobustError::InvalidArgument(format!(
                "makeweight: {name} must be finite and > 0, got {v}"
            )));
        }
    }
    if !((dc < mag && mag < hf) || (hf < mag && mag < dc)) {
        return Err(RobustError::InvalidArgument(format!(
            "makeweight: the magnitude {mag} must lie strictly between the dc gain {dc} and the high-frequency gain {hf}"
        )));
    }
    // |hf·jω + dc·a|² = mag²|jω + a|²  ⇒  a² (dc² − mag²) = ω² (mag² − hf²).
    let a = w_rad_s * ((mag * mag - hf * hf) / (dc * dc - mag * mag)).sqrt();
    // W = hf + a (dc − hf)/(s + a).
    Ok(StateSpace::new(
        Mat::from_fn(1, 1, |_, _| -a),
        Mat::from_fn(1, 1, |_, _| 1.0),
        Mat::from_fn(1, 1, |_, _| a * (dc - hf)),
        Mat::from_fn(1, 1, |_, _| hf),
        0.0,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::c64;

    /// Test-only evaluation of a first-order SISO model at jω.
    fn eval1(w: &StateSpace, omega: f64) -> f64 {
        let s = c64::new(0.0, omega);
        (w.d[(0, 0)] + w.c[(0, 0)] * w.b[(0, 0)] / (s - w.a[(0, 0)])).norm()
    }

    #[test]
    fn gains_at_dc_crossover_and_infinity() {
        // Specification of makeweight: |W(0)| = dc, |W(jωc)| = 1, |W(j∞)| = hf.
        for (dc, wc, hf) in [(0.1, 10.0, 5.0), (100.0, 2.0, 0.05), (0.5, 0.3, 1.5)] {
            let w = makeweight(dc, wc, hf).expect("valid weight");
            assert!((eval1(&w, 0.0) - dc).abs() < 1e-12 * dc);
            assert!((eval1(&w, wc) - 1.0).abs() < 1e-12);
            assert!((eval1(&w, 1e12) - hf).abs() < 1e-6 * hf);
            assert!(w.a[(0, 0)] < 0.0, "weight must be stable");
        }
        let w = makeweight_mag(0.2, 4.0, 0.5, 2.0).expect("valid");
        assert!((eval1(&w, 4.0) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn rejects_impossible_weights() {
        assert!(makeweight(0.5, 1.0, 0.8).is_err());
        assert!(makeweight(2.0, 1.0, 3.0).is_err());
        assert!(makeweight(0.1, -1.0, 3.0).is_err());
        assert!(makeweight(0.0, 1.0, 3.0).is_err());
        assert!(makeweight(0.1, f64::NAN, 3.0).is_err());
    }
}
