//! Swept sines: linear and exponential (Novak et al. 2010, the bicopter paper's ref. \[13\]) chirps with a
//! linear amplitude envelope and raised-cosine fade-in/out.

use std::f64::consts::PI;

use super::{check_positive, check_rate, Signal};
use crate::error::{invalid, Result};

/// How the instantaneous frequency moves from `f0_hz` to `f1_hz`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sweep {
    /// f(t) = f0 + (f1 − f0)·t/T.
    Linear,
    /// f(t) = f0·(f1/f0)^(t/T): equal time per octave.
    Exponential,
}

/// A chirp's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct ChirpSpec {
    /// Start frequency, Hz.
    pub f0_hz: f64,
    /// End frequency, Hz.
    pub f1_hz: f64,
    /// Sweep duration, s.
    pub duration_s: f64,
    /// Amplitude at the start of the sweep.
    pub amplitude: f64,
    /// Amplitude at the end of the sweep (linear in time in between); `None` keeps `amplitude`.
    pub amplitude_end: Option<f64>,
    /// Raised-cosine fade-in and fade-out duration at each end, s (0 for none).
    pub fade_s: f64,
    /// Linear or exponential sweep.
    pub sweep: Sweep,
}

impl ChirpSpec {
    /// Instantaneous frequency at time `t_s`, Hz.
    pub fn frequency_hz(&self, t_s: f64) -> f64 {
        let x = t_s / self.duration_s;
        match self.sweep {
            Sweep::Linear => self.f0_hz + (self.f1_hz - self.f0_hz) * x,
            Sweep::Exponential => self.f0_hz * (self.f1_hz / self.f0_hz).powf(x),
        }
    }

    fn phase_rad(&self, t: f64) -> f64 {
        let (f0, f1, tt) = (self.f0_hz, self.f1_hz, self.duration_s);
        match self.sweep {
            Sweep::Linear => 2.0 * PI * (f0 * t + 0.5 * (f1 - f0) * t * t / tt),
            Sweep::Exponential => {
                let k = (f1 / f0).ln();
                if k.abs() < 1e-12 {
                    return 2.0 * PI * f0 * t;
                }
                let l = tt / k;
                2.0 * PI * f0 * l * ((t / l).exp() - 1.0)
            }
        }
    }

    fn validate(&self) -> Result<()> {
        check_positive(self.f0_hz, "chirp start frequency")?;
        check_positive(self.f1_hz, "chirp end frequency")?;
        check_positive(self.duration_s, "chirp duration")?;
        if !self.amplitude.is_finite() || !self.amplitude_end.unwrap_or(0.0).is_finite() {
            return Err(invalid("chirp amplitude must be finite"));
        }
        if !(self.fade_s.is_finite() && self.fade_s >= 0.0 && 2.0 * self.fade_s <= self.duration_s) {
            return Err(invalid(format!(
                "fade of {} s must be ≥ 0 and at most half the duration ({} s)",
                self.fade_s, self.duration_s
            )));
        }
        Ok(())
    }
}

/// Samples the chirp at `rate_hz` from t = 0 to t = duration (inclusive of neither end beyond it).
pub fn chirp(spec: &ChirpSpec, rate_hz: f64) -> Result<Signal> {
    spec.validate()?;
    check_rate(rate_hz)?;
    if spec.f0_hz.max(spec.f1_hz) >= rate_hz / 2.0 {
        return Err(invalid(format!(
            "chirp reaches {} Hz, at or above the Nyquist frequency {} Hz of rate {} Hz",
            spec.f0_hz.max(spec.f1_hz),
            rate_hz / 2.0,
            rate_hz
        )));
    }
    super::check_samples(spec.duration_s, rate_hz, "chirp")?;
    let n = (spec.duration_s * rate_hz).round() as usize;
    let a1 = spec.amplitude_end.unwrap_or(spec.amplitude);
    let values = (0..n)
        .map(|i| {
            let t = i as f64 / rate_hz;
            let x = t / spec.duration_s;
            let amp = spec.amplitude + (a1 - spec.amplitude) * x;
            amp * fade(t, spec.duration_s, spec.fade_s) * spec.phase_rad(t).sin()
        })
        .collect();
    Ok(Signal { rate_hz, values })
}

/// Raised-cosine taper: 0 at both ends, 1 in the middle.
fn fade(t: f64, total: f64, fade: f64) -> f64 {
    if fade <= 0.0 {
        return 1.0;
    }
    let edge = t.min(total - t);
    if edge >= fade {
        1.0
    } else {
        0.5 * (1.0 - (PI * edge.max(0.0) / fade).cos())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(sweep: Sweep) -> ChirpSpec {
        ChirpSpec {
            f0_hz: 0.8,
            f1_hz: 20.0,
            duration_s: 30.0,
            amplitude: 1.0,
            amplitude_end: None,
            fade_s: 1.0,
            sweep,
        }
    }

    /// The instantaneous frequency (phase derivative by central differences) follows the sweep law.
    #[test]
    fn instantaneous_frequency_follows_law() {
        for sweep in [Sweep::Linear, Sweep::Exponential] {
            let s = spec(sweep);
            for &t in &[0.5, 7.0, 15.0, 29.0] {
                let h = 1e-6;
                let f = (s.phase_rad(t + h) - s.phase_rad(t - h)) / (2.0 * h) / (2.0 * PI);
                assert!(
                    (f - s.frequency_hz(t)).abs() < 1e-5 * s.frequency_hz(t),
                    "{sweep:?} t={t} f={f}"
                );
            }
            // Law endpoints: f(0) = f0, f(T) = f1 (closed forms of the two sweeps).
            assert!((s.frequency_hz(0.0) - 0.8).abs() < 1e-12);
            assert!((s.frequency_hz(30.0) - 20.0).abs() < 1e-9);
        }
    }

    #[test]
    fn fades_and_envelope() {
        let mut s = spec(Sweep::Exponential);
        s.amplitude_end = Some(3.0);
        let sig = chirp(&s, 250.0).unwrap();
        assert_eq!(sig.values.len(), 7500);
        assert_eq!(sig.values[0], 0.0);
        // Near the end the envelope is close to 3, but the last fade brings it to ~0.
        let late_peak = sig.values[6000..7000].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(late_peak > 2.5 && late_peak <= 3.0, "{late_peak}");
        assert!(sig.values[7499].abs() < 0.01);
        let early_peak = sig.values[300..1000].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(early_peak <= 1.3, "{early_peak}");
    }

    #[test]
    fn rejects_bad_input() {
        let mut s = spec(Sweep::Linear);
        assert!(chirp(&s, 30.0).is_err()); // 20 Hz ≥ Nyquist of 30 Hz
        assert!(chirp(&s, -1.0).is_err());
        s.fade_s = 20.0;
        assert!(chirp(&s, 250.0).is_err());
        s.fade_s = 0.0;
        s.f0_hz = 0.0;
        assert!(chirp(&s, 250.0).is_err());
    }
}
