//! Tuning goals for a SISO loop u = C·(r − y), L = G·C (the convention of skyloop's margins), and
//! the generalized plants that turn the H∞-type goals into ‖lft(P_goal, C)‖∞.
//!
//! Each goal is normalized to a number r(θ) that is ≤ 1 exactly when the goal is met, so the
//! optimizer minimizes the worst r over goals and plants (Apkarian & Noll's max formulation).

use crate::error::{Result, RobustError};
use faer::Mat;
use skyloop_lti::StateSpace;

/// What a goal measures. Frequencies in rad/s unless the name says Hz.
#[derive(Debug, Clone, PartialEq)]
pub enum Requirement {
    /// Peak sensitivity Ms = ‖1/(1 + L)‖∞.
    Ms,
    /// Peak complementary sensitivity Mt = ‖L/(1 + L)‖∞.
    Mt,
    /// Symmetric disk margin α = 1/‖S − 1/2‖∞ (MATLAB `diskmargin`, skew 0).
    DiskMargin,
    /// Classic gain margin, dB (MATLAB `margin`).
    GainMarginDb,
    /// Classic phase margin, degrees (MATLAB `margin`).
    PhaseMarginDeg,
    /// Gain-crossover frequency where MATLAB `margin` reads the phase margin, Hz.
    CrossoverHz,
    /// ‖W·S‖∞ with a stable, proper, delay-free SISO weight W.
    WeightedS(StateSpace),
    /// ‖W·T‖∞.
    WeightedT(StateSpace),
    /// ‖W·C·S‖∞ (control effort from output disturbances and noise).
    WeightedKS(StateSpace),
    /// max |C(jω)| for ω ≥ `w_rad_s` (gain from gyro noise to the actuator above a frequency).
    ControllerGainAbove {
        /// Lower end of the band, rad/s.
        w_rad_s: f64,
    },
    /// Closed-loop pole decay rate −max Re λ, rad/s (on the rational, Padé-approximated loop).
    PoleDecay,
    /// The controller's integral gain ki (Åström & Hägglund's load-disturbance criterion, MIGO).
    IntegralGain,
    /// The integral corner ki/kp (rad/s, where the PI part's zero sits) as a fraction of the
    /// gain-crossover frequency (rad/s), dimensionless: how much integral action the loop keeps
    /// relative to its bandwidth (Betaflight's stock gains sit near 1/14 on the logs here).
    IntegralCorner,
}

/// The bound of a goal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bound {
    /// value ≤ bound.
    AtMost(f64),
    /// value ≥ bound.
    AtLeast(f64),
}

/// One goal: a requirement, its bound, and whether it is a hard constraint (must hold) or a soft
/// objective (minimized in the worst case once the hard ones hold).
#[derive(Debug, Clone, PartialEq)]
pub struct Goal {
    /// What is measured.
    pub req: Requirement,
    /// The bound.
    pub bound: Bound,
    /// Hard constraint (true) or soft objective.
    pub hard: bool,
    /// How the goal is reported (e.g. the text the user gave, `ms<=1.4`).
    pub label: String,
}

impl Goal {
    /// A hard goal.
    pub fn hard(req: Requirement, bound: Bound, label: impl Into<String>) -> Self {
        Goal {
            req,
            bound,
            hard: true,
            label: label.into(),
        }
    }

    /// Checks that the bound points the way the requirement allows and lies in range.
    ///
    /// # Errors
    /// [`RobustError::InvalidArgument`] naming the goal and its allowed range.
    pub fn validate(&self) -> Result<()> {
        let bad = |why: &str| Err(RobustError::InvalidArgument(format!("goal `{}`: {why}", self.label)));
        let (upper, b) = match self.bound {
            Bound::AtMost(b) => (true, b),
            Bound::AtLeast(b) => (false, b),
        };
        if !b.is_finite() {
            return bad("the bound must be a finite number");
        }
        use Requirement as R;
        match &self.req {
            R::Ms | R::Mt => {
                if !upper || b <= 1.0 && matches!(self.req, R::Ms) || b <= 0.0 {
                    return bad("Ms takes an upper bound > 1 (e.g. ms<=1.4), Mt an upper bound > 0 (e.g. mt<=1.3)");
                }
            }
            R::DiskMargin => {
                if upper || !(b > 0.0 && b < 2.0) {
                    return bad("the disk margin takes a lower bound in (0, 2) (e.g. disk_margin>=0.6)");
                }
            }
            R::GainMarginDb => {
                if upper || !(b > 0.0 && b <= 60.0) {
                    return bad("the gain margin takes a lower bound in (0, 60] dB (e.g. gain_margin_db>=6)");
                }
            }
            R::PhaseMarginDeg => {
                if upper || !(b > 0.0 && b < 90.0) {
                    return bad("the phase margin takes a lower bound in (0, 90) degrees (e.g. phase_margin_deg>=45)");
                }
            }
            R::CrossoverHz => {
                if b <= 0.0 {
                    return bad("the crossover bound must be > 0 Hz (e.g. crossover_hz>=20)");
                }
            }
            R::WeightedS(w) | R::WeightedT(w) | R::WeightedKS(w) => {
                if !upper || b <= 0.0 {
                    return bad("a weighted norm takes an upper bound > 0");
                }
                check_weight(w, &self.label)?;
            }
            R::ControllerGainAbove { w_rad_s } => {
                if !upper || b <= 0.0 || !(w_rad_s.is_finite() && *w_rad_s > 0.0) {
                    return bad("the controller-gain limit takes an upper bound > 0 above a frequency > 0");
                }
            }
            R::PoleDecay => {
                if upper || b <= 0.0 {
                    return bad("the pole decay rate takes a lower bound > 0 rad/s");
                }
            }
            R::IntegralGain => {
                if upper || b <= 0.0 {
                    return bad("the integral gain takes a lower bound > 0");
                }
            }
            R::IntegralCorner => {
                if !(b > 0.0 && b <= 1.0) {
                    return bad("the integral corner takes a bound in (0, 1] (ki/kp over the crossover frequency, e.g. integral_corner>=0.067 or integral_corner<=0.25)");
                }
            }
        }
        Ok(())
    }

    /// Normalized value r (≤ 1 when met) of a raw value v of this goal. Ratio forms keep r
    /// scale free; the margins (which may be ≤ 0) are affine in their bound.
    pub fn normalize(&self, v: f64) -> f64 {
        use Requirement as R;
        match (&self.req, self.bound) {
            // α ≥ b ⟺ ‖S − ½‖∞ = 1/α ≤ 1/b.
            (R::DiskMargin, Bound::AtLeast(b)) => b / v.max(1e-300),
            (R::GainMarginDb | R::PhaseMarginDeg | R::PoleDecay, Bound::AtLeast(b)) => 1.0 + (b - v) / b,
            (_, Bound::AtLeast(b)) => b / v.max(1e-300),
            (_, Bound::AtMost(b)) => v / b,
        }
    }
}

fn check_weight(w: &StateSpace, label: &str) -> Result<()> {
    w.validate()?;
    if w.ny() != 1 || w.nu() != 1 || w.dt != 0.0 || w.has_delay() {
        return Err(RobustError::InvalidArgument(format!(
            "goal `{label}`: the weight must be a continuous, delay-free SISO model"
        )));
    }
    let stable = w.nx() == 0
        || w.a
            .eigenvalues()
            .map_err(|_| RobustError::Numerical("weight eigenvalues did not converge".into()))?
            .iter()
            .all(|l| l.re < 0.0);
    if !stable {
        return Err(RobustError::InvalidArgument(format!(
            "goal `{label}`: the weight must be stable (its norm with the loop would be infinite)"
        )));
    }
    Ok(())
}

/// Which signal an H∞ loop goal weighs: sig = αw·w + β·G·u + γ·u, with w an output disturbance.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Channel {
    pub alpha_w: f64,
    pub beta: f64,
    pub gamma: f64,
}

/// S (= y from an output disturbance), S − ½ (disk margin), T and C·S.
pub(crate) const CH_S: Channel = Channel {
    alpha_w: 1.0,
    beta: 1.0,
    gamma: 0.0,
};
pub(crate) const CH_DISK: Channel = Channel {
    alpha_w: 0.5,
    beta: 1.0,
    gamma: 0.0,
};
pub(crate) const CH_T: Channel = Channel {
    alpha_w: 0.0,
    beta: 1.0,
    gamma: 0.0,
};
pub(crate) const CH_KS: Channel = Channel {
    alpha_w: 0.0,
    beta: 0.0,
    gamma: 1.0,
};

/// Generalized plant [z; e] = P·[w; u] with z = W·sig and e = −(w + G·u), so that
/// lft(P, C) is W·S, W·(S − ½), −W·T or −W·C·S for the channels above (the sign does not change a
/// norm). States [x_G; x_W].
pub(crate) fn loop_plant(g: &StateSpace, ch: Channel, w: Option<&StateSpace>) -> Result<StateSpace> {
    let unit;
    let w = match w {
        Some(w) => w,
        None => {
            unit = StateSpace::gain(Mat::from_fn(1, 1, |_, _| 1.0), 0.0)?;
            &unit
        }
    };
    let (ng, nw) = (g.nx(), w.nx());
    let dg = g.d[(0, 0)];
    let dw = w.d[(0, 0)];
    let mut a = Mat::zeros(ng + nw, ng + nw);
    a.get_mut(..ng, ..ng).copy_from(&g.a);
    a.get_mut(ng.., ..ng).copy_from(&w.b * &g.c * ch.beta);
    a.get_mut(ng.., ng..).copy_from(&w.a);
    let mut b = Mat::zeros(ng + nw, 2);
    b.get_mut(..ng, 1..2).copy_from(&g.b);
    b.get_mut(ng.., 0..1).copy_from(&w.b * ch.alpha_w);
    b.get_mut(ng.., 1..2).copy_from(&w.b * (ch.beta * dg + ch.gamma));
    let mut c = Mat::zeros(2, ng + nw);
    c.get_mut(0..1, ..ng).copy_from(&g.c * (dw * ch.beta));
    c.get_mut(0..1, ng..).copy_from(&w.c);
    c.get_mut(1..2, ..ng).copy_from(-&g.c);
    let d = Mat::from_fn(2, 2, |i, j| match (i, j) {
        (0, 0) => dw * ch.alpha_w,
        (0, 1) => dw * (ch.beta * dg + ch.gamma),
        (1, 0) => -1.0,
        _ => -dg,
    });
    Ok(StateSpace::new(a, b, c, d, 0.0)?)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use faer::c64;
    use skyloop_lti::expr::parse_model;
    use skyloop_lti::freqresp::evalfr;

    #[test]
    fn loop_plants_close_to_the_textbook_transfers() {
        let g = parse_model("2/((s+1)*(0.1*s+1))").unwrap();
        let c = parse_model("1.5+0.7/s").unwrap();
        let w = parse_model("(s+3)/(s+30)").unwrap();
        let s = c64::new(0.0, 1.7);
        let gv = evalfr(&g, s).unwrap()[(0, 0)];
        let cv = evalfr(&c, s).unwrap()[(0, 0)];
        let wv = evalfr(&w, s).unwrap()[(0, 0)];
        let sens = 1.0 / (1.0 + gv * cv);
        let cases = [
            (CH_S, wv * sens),
            (CH_DISK, wv * (sens - 0.5)),
            (CH_T, -wv * (1.0 - sens)),
            (CH_KS, -wv * cv * sens),
        ];
        for (ch, want) in cases {
            let p = loop_plant(&g, ch, Some(&w)).unwrap();
            let cl = skyloop_lti::interconnect::lft_lower(&p, &c).unwrap();
            let got = evalfr(&cl, s).unwrap()[(0, 0)];
            assert!((got - want).norm() < 1e-12, "{got} vs {want}");
        }
    }

    #[test]
    fn goals_reject_bounds_outside_their_range() {
        let e = Goal::hard(Requirement::Ms, Bound::AtMost(0.9), "ms<=0.9")
            .validate()
            .unwrap_err();
        assert!(
            e.to_string().contains("ms<=0.9") && e.to_string().contains("> 1"),
            "{e}"
        );
        let e = Goal::hard(Requirement::DiskMargin, Bound::AtLeast(2.5), "disk_margin>=2.5")
            .validate()
            .unwrap_err();
        assert!(e.to_string().contains("(0, 2)"), "{e}");
        let e = Goal::hard(Requirement::PhaseMarginDeg, Bound::AtMost(45.0), "phase_margin_deg<=45")
            .validate()
            .unwrap_err();
        assert!(e.to_string().contains("lower bound"), "{e}");
        let unstable = parse_model("1/(s-1)").unwrap();
        let e = Goal::hard(Requirement::WeightedS(unstable), Bound::AtMost(1.0), "ws")
            .validate()
            .unwrap_err();
        assert!(e.to_string().contains("stable"), "{e}");
    }
}
