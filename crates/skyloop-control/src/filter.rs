//! The flight firmware's discrete signal filters, run at the loop rate: PT1, PT2, PT3 (cascaded
//! first-order lags, cutoff-corrected so the cascade is −3 dB at the set cutoff), the biquad
//! lowpass (Butterworth, Q = 1/√2) and the biquad notch, as Betaflight and INAV define them in their
//! filter documentation (PT1 gain k = ωT/(1 + ωT); biquads from the RBJ audio-EQ cookbook with
//! ω = 2πf·T), and their exact frequency responses H(e^{jωT}).
//!
//! One implementation serves the runtime (generic state `T`: f32 on a flight controller), the noise
//! what-if (the response on a spectrum) and the tune's loop model, so a filter modelled is a filter
//! flown.

use crate::error::{ControlError, Result};
use crate::real::Real;

/// Cutoff correction of each stage of a PT2 (1/√(2^{1/2} − 1)): the pair is −3 dB at the set cutoff.
pub const PT2_CUTOFF_CORRECTION: f64 = 1.553_773_974_030_037;
/// Cutoff correction of each stage of a PT3 (1/√(2^{1/3} − 1)).
pub const PT3_CUTOFF_CORRECTION: f64 = 1.961_459_176_700_963;

/// The kind of a discrete filter stage and its frequency parameters, Hz.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FilterKind {
    /// First-order lag at the cutoff, Hz.
    Pt1(f64),
    /// Two first-order lags, −3 dB together at the cutoff, Hz.
    Pt2(f64),
    /// Three first-order lags, −3 dB together at the cutoff, Hz.
    Pt3(f64),
    /// Biquad Butterworth lowpass (Q = 1/√2) at the cutoff, Hz.
    BiquadLowpass(f64),
    /// Biquad notch at `center` Hz with quality factor `q` (centre / −3 dB width).
    Notch {
        /// Notch centre, Hz.
        center: f64,
        /// Quality factor (dimensionless).
        q: f64,
    },
}

/// The coefficients of one stage at a given sample time: a PT-n as n first-order gains, or one
/// biquad (b0 + b1 z⁻¹ + b2 z⁻²)/(1 + a1 z⁻¹ + a2 z⁻²).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Coeffs {
    Lag { k: f64, order: u8 },
    Biquad { b: [f64; 3], a: [f64; 2] },
}

/// The quality factor of Betaflight's notch given its centre and lower −3 dB cutoff, Hz
/// (Q = f₀·f_c/(f₀² − f_c²)).
pub fn notch_q(center_hz: f64, cutoff_hz: f64) -> f64 {
    center_hz * cutoff_hz / (center_hz * center_hz - cutoff_hz * cutoff_hz)
}

/// The first-order lag gain k = ωT/(1 + ωT) of a PT1 at `cutoff_hz` run every `dt_s`.
pub fn pt1_gain(cutoff_hz: f64, dt_s: f64) -> f64 {
    let w = 2.0 * core::f64::consts::PI * cutoff_hz * dt_s;
    w / (1.0 + w)
}

impl FilterKind {
    fn coeffs(&self, dt_s: f64) -> Result<Coeffs> {
        let nyquist = 0.5 / dt_s;
        let check = |f: f64| {
            if f.is_finite() && f > 0.0 && dt_s.is_finite() && dt_s > 0.0 {
                Ok(f)
            } else {
                Err(ControlError::NonFinite("filter frequency or sample time"))
            }
        };
        Ok(match *self {
            FilterKind::Pt1(f) => Coeffs::Lag {
                k: pt1_gain(check(f)?, dt_s),
                order: 1,
            },
            FilterKind::Pt2(f) => Coeffs::Lag {
                k: pt1_gain(check(f)? * PT2_CUTOFF_CORRECTION, dt_s),
                order: 2,
            },
            FilterKind::Pt3(f) => Coeffs::Lag {
                k: pt1_gain(check(f)? * PT3_CUTOFF_CORRECTION, dt_s),
                order: 3,
            },
            FilterKind::BiquadLowpass(f) => {
                // A biquad cannot sit at or above Nyquist; the firmware limits its cutoffs likewise.
                let f = check(f)?.min(0.998 * nyquist);
                biquad(f, dt_s, core::f64::consts::FRAC_1_SQRT_2, true)
            }
            FilterKind::Notch { center, q } => {
                let f = check(center)?.min(0.998 * nyquist);
                if !(q.is_finite() && q > 0.0) {
                    return Err(ControlError::NonFinite("notch Q"));
                }
                biquad(f, dt_s, q, false)
            }
        })
    }

    /// The stage's frequency response H(e^{j2πf·T}) at `freq_hz` when run every `dt_s` seconds,
    /// as (real, imaginary).
    ///
    /// # Errors
    /// A frequency, Q or sample time that is not a finite positive number.
    pub fn response(&self, freq_hz: f64, dt_s: f64) -> Result<(f64, f64)> {
        let theta = 2.0 * core::f64::consts::PI * freq_hz * dt_s;
        // z⁻¹ = e^{−jθ}.
        let (zr, zi) = (libm::cos(theta), -libm::sin(theta));
        let (z2r, z2i) = (zr * zr - zi * zi, 2.0 * zr * zi);
        Ok(match self.coeffs(dt_s)? {
            Coeffs::Lag { k, order } => {
                // k/(1 − (1−k) z⁻¹) per stage.
                let (dr, di) = (1.0 - (1.0 - k) * zr, -(1.0 - k) * zi);
                let m = dr * dr + di * di;
                let one = (k * dr / m, -k * di / m);
                let mut acc = (1.0, 0.0);
                for _ in 0..order {
                    acc = (acc.0 * one.0 - acc.1 * one.1, acc.0 * one.1 + acc.1 * one.0);
                }
                acc
            }
            Coeffs::Biquad { b, a } => {
                let nr = b[0] + b[1] * zr + b[2] * z2r;
                let ni = b[1] * zi + b[2] * z2i;
                let dr = 1.0 + a[0] * zr + a[1] * z2r;
                let di = a[0] * zi + a[1] * z2i;
                let m = dr * dr + di * di;
                ((nr * dr + ni * di) / m, (ni * dr - nr * di) / m)
            }
        })
    }
}

/// RBJ cookbook biquad, normalised by a0: lowpass (b = (1−cos)/2·[1, 2, 1]) or notch (b = [1, −2cos, 1]).
fn biquad(f: f64, dt_s: f64, q: f64, lowpass: bool) -> Coeffs {
    let w = 2.0 * core::f64::consts::PI * f * dt_s;
    let (sn, cs) = (libm::sin(w), libm::cos(w));
    let alpha = sn / (2.0 * q);
    let a0 = 1.0 + alpha;
    let b = if lowpass {
        let b0 = (1.0 - cs) / 2.0;
        [b0 / a0, 2.0 * b0 / a0, b0 / a0]
    } else {
        [1.0 / a0, -2.0 * cs / a0, 1.0 / a0]
    };
    Coeffs::Biquad {
        b,
        a: [-2.0 * cs / a0, (1.0 - alpha) / a0],
    }
}

/// One running filter stage: coefficients at a fixed sample time and its state (precision `T`).
#[derive(Debug, Clone, Copy)]
pub struct Filter<T> {
    coeffs: Coeffs,
    k: T,
    b: [T; 3],
    a: [T; 2],
    state: [T; 3],
}

impl<T: Real> Filter<T> {
    /// The stage `kind` run every `dt_s` seconds, at rest.
    ///
    /// # Errors
    /// A frequency, Q or sample time that is not a finite positive number.
    pub fn new(kind: FilterKind, dt_s: f64) -> Result<Self> {
        let coeffs = kind.coeffs(dt_s)?;
        let (k, b, a) = match coeffs {
            Coeffs::Lag { k, .. } => (k, [0.0; 3], [0.0; 2]),
            Coeffs::Biquad { b, a } => (0.0, b, a),
        };
        Ok(Filter {
            coeffs,
            k: T::from_f64(k),
            b: b.map(T::from_f64),
            a: a.map(T::from_f64),
            state: [T::ZERO; 3],
        })
    }

    /// A cascade of `order` (1..=3) first-order lags y += k·(x − y), at rest: a PT-n whose gain `k`
    /// was computed elsewhere (a firmware's own arithmetic, see `skyloop::firmware`).
    ///
    /// # Errors
    /// An order outside 1..=3 or a gain outside (0, 1].
    pub fn from_lag(k: f64, order: u8) -> Result<Self> {
        if !((1..=3).contains(&order) && k > 0.0 && k <= 1.0) {
            return Err(ControlError::OutOfRange(
                "a lag needs an order in 1..=3 and a gain in (0, 1]",
            ));
        }
        Ok(Filter {
            coeffs: Coeffs::Lag { k, order },
            k: T::from_f64(k),
            b: [T::ZERO; 3],
            a: [T::ZERO; 2],
            state: [T::ZERO; 3],
        })
    }

    /// A biquad (b0 + b1 z⁻¹ + b2 z⁻²)/(1 + a1 z⁻¹ + a2 z⁻²) with given coefficients, at rest, run
    /// in transposed direct form II.
    ///
    /// # Errors
    /// A coefficient that is not finite.
    pub fn from_biquad(b: [f64; 3], a: [f64; 2]) -> Result<Self> {
        if !b.iter().chain(a.iter()).all(|v| v.is_finite()) {
            return Err(ControlError::NonFinite("biquad coefficients"));
        }
        Ok(Filter {
            coeffs: Coeffs::Biquad { b, a },
            k: T::ZERO,
            b: b.map(T::from_f64),
            a: a.map(T::from_f64),
            state: [T::ZERO; 3],
        })
    }

    /// Clears the state (output 0 for input 0).
    pub fn reset(&mut self) {
        self.state = [T::ZERO; 3];
    }

    /// One sample through the filter.
    pub fn apply(&mut self, x: T) -> T {
        match self.coeffs {
            Coeffs::Lag { order, .. } => {
                // Each lag follows the previous one: y += k·(x − y).
                let mut input = x;
                for s in self.state.iter_mut().take(order as usize) {
                    *s += self.k * (input - *s);
                    input = *s;
                }
                input
            }
            Coeffs::Biquad { .. } => {
                // Transposed direct form II.
                let y = self.b[0] * x + self.state[0];
                self.state[0] = self.b[1] * x - self.a[0] * y + self.state[1];
                self.state[1] = self.b[2] * x - self.a[1] * y;
                y
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    const DT: f64 = 1.0 / 8000.0;

    fn gain(k: FilterKind, f: f64) -> f64 {
        let (r, i) = k.response(f, DT).unwrap();
        libm::sqrt(r * r + i * i)
    }

    /// The response function and the running filter agree: a sinusoid through `Filter` settles to
    /// the amplitude and phase `response` gives.
    #[test]
    fn running_filter_matches_its_response() {
        for kind in [
            FilterKind::Pt1(100.0),
            FilterKind::Pt2(150.0),
            FilterKind::Pt3(200.0),
            FilterKind::BiquadLowpass(250.0),
            FilterKind::Notch { center: 300.0, q: 3.0 },
        ] {
            for f in [20.0, 150.0, 290.0, 800.0] {
                let mut flt = Filter::<f64>::new(kind, DT).unwrap();
                let w = 2.0 * core::f64::consts::PI * f;
                let n = 40_000;
                let (mut re, mut im) = (0.0, 0.0);
                for i in 0..n {
                    let t = i as f64 * DT;
                    let y = flt.apply(libm::sin(w * t));
                    if i >= n / 2 {
                        re += y * libm::sin(w * t);
                        im += y * libm::cos(w * t);
                    }
                }
                let scale = 2.0 / (n / 2) as f64;
                let (hr, hi) = kind.response(f, DT).unwrap();
                assert!(
                    (re * scale - hr).abs() < 2e-3 && (im * scale - hi).abs() < 2e-3,
                    "{kind:?} at {f} Hz"
                );
            }
        }
    }

    /// Each lowpass is −3 dB at its cutoff to within the firmware's own discretisation (its PT1 gain
    /// is a backward-Euler lag: 0.694 for a PT1, 0.683 for a PT2 rather than 0.707 at 100 Hz of
    /// 8 kHz), and a notch removes its
    /// centre.
    #[test]
    fn cutoffs_and_notch_centres() {
        for k in [
            FilterKind::Pt1(100.0),
            FilterKind::Pt2(100.0),
            FilterKind::Pt3(100.0),
            FilterKind::BiquadLowpass(100.0),
        ] {
            let g = gain(k, 100.0);
            assert!((g - core::f64::consts::FRAC_1_SQRT_2).abs() < 0.04, "{k:?}: {g}");
            assert!((gain(k, 0.0) - 1.0).abs() < 1e-12);
        }
        let n = FilterKind::Notch {
            center: 240.0,
            q: notch_q(240.0, 160.0),
        };
        assert!(gain(n, 240.0) < 1e-9);
        assert!((gain(n, 0.0) - 1.0).abs() < 1e-12);
        assert!(Filter::<f32>::new(FilterKind::Pt1(-1.0), DT).is_err());
        assert!(Filter::<f32>::new(FilterKind::Notch { center: 100.0, q: 0.0 }, DT).is_err());
    }

    /// Between a quarter of the sample rate and Nyquist a notch still sits where it is asked
    /// (a 400 Hz loop's second harmonic notch at 120 Hz), and a lowpass keeps its −3 dB point.
    #[test]
    fn stages_above_a_quarter_of_the_rate_are_not_moved() {
        let dt = 1.0 / 400.0;
        let n = FilterKind::Notch { center: 120.0, q: 8.0 };
        let (re, im) = n.response(120.0, dt).unwrap();
        assert!(re.hypot(im) < 1e-9, "{re} {im}");
        // The RBJ biquad is prewarped at its cutoff: exactly 1/√2 there.
        let (re, im) = FilterKind::BiquadLowpass(150.0).response(150.0, dt).unwrap();
        assert!(
            (re.hypot(im) - core::f64::consts::FRAC_1_SQRT_2).abs() < 1e-9,
            "{re} {im}"
        );
    }
}
