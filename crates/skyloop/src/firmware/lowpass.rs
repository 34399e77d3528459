//! A firmware's lowpass and notch stages as continuous models (the prototypes of the discrete
//! filters in `skyloop_control::filter`), their series chains, and the D-term chain a blackbox
//! header states.

use super::vocab::{LowpassSetting, NotchSetting};
use crate::error::{Error, Result};
use skyloop_lti::interconnect::series;
use skyloop_lti::{Mat, StateSpace};
use std::f64::consts::PI;

/// The D-term chain a blackbox header states (Betaflight, INAV): its lowpass stages, named as the
/// header names them, then its static notch, modelled; a report line per stage goes to `lines`.
pub(crate) fn dterm_chain(
    stages: &[(&Option<LowpassSetting>, &str)],
    notch: Option<NotchSetting>,
    lines: &mut Vec<String>,
    notes: &mut Vec<String>,
) -> Vec<Lowpass> {
    let mut dterm = Vec::new();
    for (l, name) in stages {
        if let Some(l) = l {
            if let Some(lp) = header_lowpass(l, notes, name) {
                lines.push(format!(
                    "{name}: {} at {} Hz (in the controller)",
                    l.kind,
                    lp.cutoff_hz()
                ));
                dterm.push(lp);
            }
        }
    }
    if let Some(n) = notch {
        lines.push(format!(
            "dterm_notch: {} Hz, cutoff {} Hz (in the controller)",
            n.center_hz, n.cutoff_hz
        ));
        dterm.push(Lowpass::Notch(n.center_hz, n.cutoff_hz));
    }
    dterm
}

/// The model of a header's lowpass stage (a dynamic one at the low end of its range: hover
/// throttle, the most lag); None when it is off.
pub(crate) fn header_lowpass(l: &LowpassSetting, notes: &mut Vec<String>, name: &str) -> Option<Lowpass> {
    let f = match l.dynamic_hz {
        Some((lo, _)) => lo,
        None => l.cutoff_hz,
    };
    if !(f > 0.0) {
        return None;
    }
    Some(match l.kind.as_str() {
        "PT1" => Lowpass::Pt1(f),
        "PT2" => Lowpass::Pt2(f),
        "PT3" => Lowpass::Pt3(f),
        "BIQUAD" => Lowpass::Biquad(f),
        other => {
            notes.push(format!(
                "{name}: filter type {other} is not modelled; taken as PT1 at {f} Hz"
            ));
            Lowpass::Pt1(f)
        }
    })
}

/// A lowpass stage, cutoff in Hz, as the firmware defines it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Lowpass {
    /// First order ω/(s + ω).
    Pt1(f64),
    /// Two PT1 stages, each at f/√(2^{1/2} − 1) so the pair is −3 dB at f (Betaflight `pt2FilterGain`).
    Pt2(f64),
    /// Three PT1 stages, each at f/√(2^{1/3} − 1) (Betaflight `pt3FilterGain`).
    Pt3(f64),
    /// Second-order Butterworth ω²/(s² + √2·ω·s + ω²) (Betaflight BIQUAD, PX4's LowPassFilter2p).
    Biquad(f64),
    /// A notch (centre, lower cutoff), Hz: (s² + ω₀²)/(s² + (ω₀/Q)·s + ω₀²) with Betaflight's
    /// Q = f₀·f_c/(f₀² − f_c²) (`filterGetNotchQ`).
    Notch(f64, f64),
}

impl Lowpass {
    /// The cutoff in Hz.
    pub fn cutoff_hz(&self) -> f64 {
        match *self {
            Lowpass::Pt1(f) | Lowpass::Pt2(f) | Lowpass::Pt3(f) | Lowpass::Biquad(f) | Lowpass::Notch(f, _) => f,
        }
    }

    /// The same kind of stage at cutoff `f_hz`; a notch is returned unchanged (it sits on a
    /// resonance, not at a cutoff one moves).
    pub fn with_cutoff(self, f_hz: f64) -> Lowpass {
        match self {
            Lowpass::Pt1(_) => Lowpass::Pt1(f_hz),
            Lowpass::Pt2(_) => Lowpass::Pt2(f_hz),
            Lowpass::Pt3(_) => Lowpass::Pt3(f_hz),
            Lowpass::Biquad(_) => Lowpass::Biquad(f_hz),
            n @ Lowpass::Notch(..) => n,
        }
    }

    /// The same stage with its cutoff scaled by `k` and rounded to whole Hz (the firmware's
    /// settings are integers); a notch is returned unchanged.
    pub fn scaled(self, k: f64) -> Lowpass {
        self.with_cutoff(scaled_cutoff_hz(self.cutoff_hz(), k))
    }

    /// True for a lowpass (not a notch).
    pub fn is_lowpass(&self) -> bool {
        !matches!(self, Lowpass::Notch(..))
    }

    /// The continuous filter's poles, rad/s (a notch's too: its zeros are not returned).
    ///
    /// # Errors
    /// A cutoff that is not a finite positive number.
    pub fn poles(&self) -> Result<Vec<skyloop_lti::c64>> {
        use skyloop_lti::c64;
        // Written out, not computed as eigenvalues: PT2's and PT3's repeated poles would come
        // back perturbed by ~eps^(1/n), and a de-embedding ratio must cancel them exactly.
        self.model()?;
        let w = 2.0 * PI * self.cutoff_hz();
        let pt = |n: i32| vec![c64::new(-w / (2f64.powf(1.0 / f64::from(n)) - 1.0).sqrt(), 0.0); n as usize];
        Ok(match *self {
            Lowpass::Pt1(_) => vec![c64::new(-w, 0.0)],
            Lowpass::Pt2(_) => pt(2),
            Lowpass::Pt3(_) => pt(3),
            Lowpass::Biquad(_) => {
                let h = w * std::f64::consts::FRAC_1_SQRT_2;
                vec![c64::new(-h, h), c64::new(-h, -h)]
            }
            Lowpass::Notch(f0, fc) => {
                let w0 = 2.0 * PI * f0;
                let b = w0 / (f0 * fc / (f0 * f0 - fc * fc));
                let disc = b * b - 4.0 * w0 * w0;
                if disc >= 0.0 {
                    vec![
                        c64::new((-b + disc.sqrt()) / 2.0, 0.0),
                        c64::new((-b - disc.sqrt()) / 2.0, 0.0),
                    ]
                } else {
                    let im = (-disc).sqrt() / 2.0;
                    vec![c64::new(-b / 2.0, im), c64::new(-b / 2.0, -im)]
                }
            }
        })
    }

    /// The continuous filter.
    ///
    /// # Errors
    /// A cutoff that is not a finite positive number.
    pub fn model(&self) -> Result<StateSpace> {
        let f = self.cutoff_hz();
        if !(f.is_finite() && f > 0.0) {
            return Err(Error::Input(format!(
                "lowpass cutoff must be a positive number of Hz, got {f}"
            )));
        }
        let w = 2.0 * PI * f;
        let pt = |n: i32| -> Result<StateSpace> {
            let ws = w / (2f64.powf(1.0 / n as f64) - 1.0).sqrt();
            let one = StateSpace::new(m1(-ws), m1(ws), m1(1.0), m1(0.0), 0.0)?;
            let mut acc = one.clone();
            for _ in 1..n {
                acc = series(&acc, &one)?;
            }
            Ok(acc)
        };
        Ok(match self {
            Lowpass::Pt1(_) => StateSpace::new(m1(-w), m1(w), m1(1.0), m1(0.0), 0.0)?,
            Lowpass::Pt2(_) => pt(2)?,
            Lowpass::Pt3(_) => pt(3)?,
            Lowpass::Notch(f0, fc) => notch(*f0, *fc)?,
            Lowpass::Biquad(_) => StateSpace::from_rows(
                &[vec![0.0, 1.0], vec![-w * w, -std::f64::consts::SQRT_2 * w]],
                &[vec![0.0], vec![w * w]],
                &[vec![1.0, 0.0]],
                &[vec![0.0]],
                0.0,
            )?,
        })
    }
}

/// Betaflight's notch at centre `f0` with lower cutoff `fc`, Hz.
fn notch(f0: f64, fc: f64) -> Result<StateSpace> {
    if !(fc.is_finite() && fc > 0.0 && fc < f0) {
        return Err(Error::Input(format!(
            "notch cutoff must lie in (0, {f0}) Hz (below its centre), got {fc}"
        )));
    }
    let w = 2.0 * PI * f0;
    let q = f0 * fc / (f0 * f0 - fc * fc);
    // (s² + w²)/(s² + (w/Q)s + w²) = 1 + (−(w/Q)s)/(s² + (w/Q)s + w²).
    Ok(StateSpace::from_rows(
        &[vec![0.0, 1.0], vec![-w * w, -w / q]],
        &[vec![0.0], vec![1.0]],
        &[vec![0.0, -w / q]],
        &[vec![1.0]],
        0.0,
    )?)
}

fn m1(v: f64) -> Mat<f64> {
    Mat::from_fn(1, 1, |_, _| v)
}

/// The SISO static gain `v` (a controller path without states).
///
/// # Errors
/// A non-finite gain.
pub(crate) fn static_gain(v: f64) -> Result<StateSpace> {
    Ok(StateSpace::gain(m1(v), 0.0)?)
}

/// A cutoff `hz` scaled by `k` and rounded to whole Hz (the firmwares store integers), at least 1.
pub fn scaled_cutoff_hz(hz: f64, k: f64) -> f64 {
    (hz * k).round().max(1.0)
}

/// `stages` with every lowpass cutoff scaled by `k` ([`Lowpass::scaled`]; notches kept).
pub fn scale_lowpasses(stages: &[Lowpass], k: f64) -> Vec<Lowpass> {
    stages
        .iter()
        .map(|l| if l.is_lowpass() { l.scaled(k) } else { *l })
        .collect()
}

/// The lowest lowpass cutoff of `stages`, Hz (None without a lowpass).
pub fn lowest_cutoff_hz(stages: &[Lowpass]) -> Option<f64> {
    stages
        .iter()
        .filter(|l| l.is_lowpass())
        .map(Lowpass::cutoff_hz)
        .min_by(f64::total_cmp)
}

/// The series connection of `stages` (None when empty: no filter).
///
/// # Errors
/// As [`Lowpass::model`].
pub fn chain(stages: &[Lowpass]) -> Result<Option<StateSpace>> {
    let mut acc: Option<StateSpace> = None;
    for s in stages {
        let m = s.model()?;
        acc = Some(match acc {
            None => m,
            Some(a) => series(&a, &m)?,
        });
    }
    Ok(acc)
}

/// The D-path filter of a PID with no D filter configured: a lowpass at half the loop's Nyquist
/// rate stands in for the discrete derivative's own roll-off (a continuous kd·s is improper).
pub(crate) fn derivative_rolloff(loop_hz: f64) -> Lowpass {
    Lowpass::Pt1(loop_hz / 4.0)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use skyloop_lti::c64;

    #[test]
    fn every_lowpass_is_minus_3_db_at_its_cutoff() {
        for lp in [
            Lowpass::Pt1(100.0),
            Lowpass::Pt2(100.0),
            Lowpass::Pt3(100.0),
            Lowpass::Biquad(100.0),
        ] {
            let g =
                skyloop_lti::freqresp::evalfr(&lp.model().unwrap(), c64::new(0.0, 2.0 * PI * 100.0)).unwrap()[(0, 0)];
            assert!((g.norm() - 0.5f64.sqrt()).abs() < 1e-9, "{lp:?}: {}", g.norm());
        }
        assert!(Lowpass::Pt1(-1.0).model().is_err());
    }
}
