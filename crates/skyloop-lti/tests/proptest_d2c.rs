//! Property test of discretization round trips: a random continuous model (real poles, lightly to
//! well damped complex pairs, an integrator or not, real zeros, gains over six decades), sampled by
//! `c2d` with zero-order hold or Tustin and brought back by `d2c` with the same method, has the
//! original frequency response to 1e-8 relative at frequencies up to half the Nyquist frequency
//! (where the response lies within 120 dB of its peak; below that, to 1e-14 of the peak).
//! Poles are kept within 1e-3..3 rad per sample, where the matrix logarithm of the sampled model is
//! well conditioned.
#![allow(clippy::unwrap_used)] // a panic is how a test reports failure

use proptest::prelude::*;
use skyloop_lti::c64;
use skyloop_lti::discretize::{c2d, d2c, Method};
use skyloop_lti::expr::parse_model;
use skyloop_lti::freqresp::evalfr;

#[derive(Debug, Clone)]
struct Model {
    gain: f64,
    real_poles: Vec<f64>,
    pairs: Vec<(f64, f64)>,
    zeros: Vec<f64>,
    integrator: bool,
}

impl Model {
    fn expr(&self) -> String {
        let mut den: Vec<String> = self.real_poles.iter().map(|p| format!("(s/{p:e}+1)")).collect();
        den.extend(
            self.pairs
                .iter()
                .map(|(w, z)| format!("((s/{w:e})^2+2*{z:e}*s/{w:e}+1)")),
        );
        if self.integrator {
            den.push("s".into());
        }
        let num: Vec<String> = self.zeros.iter().map(|z| format!("(s/{z:e}+1)")).collect();
        let num = if num.is_empty() { "1".into() } else { num.join("*") };
        let den = if den.is_empty() { "1".into() } else { den.join("*") };
        format!("{:e}*{num}/({den})", self.gain)
    }
}

/// The sampling step, s.
const DT: f64 = 0.004;

fn model() -> impl Strategy<Value = Model> {
    let freq = || (-3.0f64..0.45).prop_map(|e| 10f64.powf(e) / DT);
    (
        (-3.0f64..3.0).prop_map(|e| 10f64.powf(e)),
        prop::collection::vec(freq(), 0..3),
        prop::collection::vec((freq(), 0.05f64..0.9), 0..2),
        prop::collection::vec(freq(), 0..2),
        any::<bool>(),
    )
        .prop_filter("at least one pole", |m| !(m.1.is_empty() && m.2.is_empty() && !m.4))
        .prop_map(|(gain, real_poles, pairs, zeros, integrator)| Model {
            gain,
            real_poles,
            pairs,
            zeros,
            integrator,
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn c2d_then_d2c_is_the_identity(m in model(), tustin in any::<bool>()) {
        let g = parse_model(&m.expr()).unwrap();
        let method = if tustin { Method::Tustin { prewarp_rad_s: None } } else { Method::Zoh };
        let gd = c2d(&g, DT, method).unwrap();
        let back = d2c(&gd, method).unwrap();
        let nyq = std::f64::consts::PI / DT;
        let pairs: Vec<(f64, c64, c64)> = (1..=12)
            .map(|k| {
                let w = nyq * 0.5 * (k as f64 / 12.0).powi(3);
                (w, evalfr(&g, c64::new(0.0, w)).unwrap()[(0, 0)], evalfr(&back, c64::new(0.0, w)).unwrap()[(0, 0)])
            })
            .collect();
        // Relative to the response where it is within 120 dB of its largest value on the grid:
        // further down a steep roll-off (|G| 1e-16 of its peak, seen with five slow poles) the
        // value is a cancellation of terms of the peak's size, known to ε·peak only.
        let peak = pairs.iter().fold(0.0f64, |m, p| m.max(p.1.norm()));
        for (w, a, b) in pairs {
            prop_assert!((a - b).norm() <= 1e-8 * (a.norm() + 1e-6 * peak), "{}: w {w:.3}: {a} vs {b}", m.expr());
        }
    }
}
