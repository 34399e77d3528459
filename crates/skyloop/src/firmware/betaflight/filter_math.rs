//! Betaflight's filter coefficients as the firmware computes them, in its single-precision
//! arithmetic: the PT1/PT2/PT3 gains with their cutoff corrections, the notch Q from centre and
//! cutoff, and the biquads (RBJ lowpass and notch) with the firmware's polynomial sine and cosine
//! and its loop time in whole microseconds. Written from the behaviour of `src/main/common/filter.c`
//! and `maths.c` (4.2–2025.12), checked sample by sample against that code compiled for the host
//! (`tools/gen_betaflight_filters.sh`, fixtures in `tests/fixtures/betaflight/`).
//!
//! The loop analysis uses [`FilterKind`](skyloop_control::filter::FilterKind) instead (libm's
//! sine, exact sample time, double precision): the difference is a deliberate simplification,
//! measured against these fixtures at below 0.03 dB and 0.12° per stage (0.015 dB and 0.02° for
//! cutoffs of 50 Hz and up) of the response up to 0.45 of
//! the loop rate (the test `analysis_model_is_within_its_stated_error` in `tests/betaflight_filters.rs`).

use skyloop_control::filter::Filter;

/// π as the firmware's single-precision constant.
const PI_F: f32 = core::f32::consts::PI;

/// PT2's cutoff correction 1/√(2^(1/2) − 1), as the firmware's constant.
pub const PT2_CUTOFF_CORRECTION: f32 = 1.553_773_9;
/// PT3's cutoff correction 1/√(2^(1/3) − 1), as the firmware's constant.
pub const PT3_CUTOFF_CORRECTION: f32 = 1.961_459_2;

/// The firmware's sine: the argument wrapped to [−π, π], folded to [−π/2, π/2], then an odd
/// polynomial x + c3·x³ + c5·x⁵ + c7·x⁷ (its `VERY_FAST_MATH` build, the default since 4.x; largest
/// error about 2.3e-6). Arguments beyond ±32 rad give 0, as the firmware's guard does.
#[allow(clippy::excessive_precision)] // the firmware's literals, digit for digit
pub fn sin_approx(x: f32) -> f32 {
    // The order-7 minimax coefficients the firmware uses, as its source writes them.
    const C3: f32 = -1.666_568_1e-1;
    const C5: f32 = 8.312_366e-3;
    const C7: f32 = -1.849_218_2e-4;
    if !(-33.0..33.0).contains(&x) || (x as i32).abs() > 32 {
        return 0.0;
    }
    let mut x = x;
    while x > PI_F {
        x -= 2.0 * PI_F;
    }
    while x < -PI_F {
        x += 2.0 * PI_F;
    }
    let half = 0.5 * PI_F;
    if x > half {
        x = half - (x - half);
    } else if x < -half {
        x = -half - (half + x);
    }
    let x2 = x * x;
    x + x * x2 * (C3 + x2 * (C5 + x2 * C7))
}

/// The firmware's cosine: its sine a quarter turn on.
pub fn cos_approx(x: f32) -> f32 {
    sin_approx(x + 0.5 * PI_F)
}

/// The PT1 gain k = ω/(ω + 1), ω = 2π·f·dT, in single precision.
pub fn pt1_gain(cutoff_hz: f32, dt_s: f32) -> f32 {
    let omega = 2.0 * PI_F * cutoff_hz * dt_s;
    omega / (omega + 1.0)
}

/// The notch's Q from its centre and lower −3 dB cutoff: f₀·f_c/(f₀² − f_c²).
pub fn notch_q(center_hz: f32, cutoff_hz: f32) -> f32 {
    center_hz * cutoff_hz / (center_hz * center_hz - cutoff_hz * cutoff_hz)
}

/// A biquad's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BiquadShape {
    /// Lowpass (Q = 1/√2 for the firmware's Butterworth lowpass).
    Lowpass,
    /// Notch.
    Notch,
}

/// The biquad coefficients (b0, b1, b2; a1, a2), normalised by a0, as the firmware computes them at
/// `freq_hz` with the loop time in whole microseconds (`looptime_us`: 125 at 8 kHz, 312 at 3.2 kHz).
pub fn biquad_coeffs(shape: BiquadShape, freq_hz: f32, looptime_us: u32, q: f32) -> ([f32; 3], [f32; 2]) {
    let omega = 2.0 * PI_F * freq_hz * looptime_us as f32 * 0.000_001;
    let (sn, cs) = (sin_approx(omega), cos_approx(omega));
    let alpha = sn / (2.0 * q);
    let (b, a) = match shape {
        BiquadShape::Lowpass => {
            let b1 = 1.0 - cs;
            let b0 = b1 * 0.5;
            ([b0, b1, b0], [-2.0 * cs, 1.0 - alpha])
        }
        BiquadShape::Notch => ([1.0, -2.0 * cs, 1.0], [-2.0 * cs, 1.0 - alpha]),
    };
    let a0 = 1.0 + alpha;
    (b.map(|v| v / a0), a.map(|v| v / a0))
}

/// The firmware's Butterworth Q, 1/√2 in single precision.
pub fn butterworth_q() -> f32 {
    1.0 / 2f32.sqrt()
}

/// A running stage as the firmware runs it: a PT-n (`order` 1..=3, `cutoff_hz` before its
/// correction) at `looptime_us`.
///
/// # Errors
/// An order outside 1..=3 or a cutoff that gives no valid gain.
pub fn lag_filter(order: u8, cutoff_hz: f32, looptime_us: u32) -> crate::Result<Filter<f32>> {
    let dt = looptime_us as f32 * 1e-6;
    let f = match order {
        2 => cutoff_hz * PT2_CUTOFF_CORRECTION,
        3 => cutoff_hz * PT3_CUTOFF_CORRECTION,
        _ => cutoff_hz,
    };
    Filter::from_lag(f64::from(pt1_gain(f, dt)), order).map_err(|e| crate::Error::Input(format!("filter: {e}")))
}

/// A running biquad as the firmware runs it.
///
/// # Errors
/// Coefficients that are not finite.
pub fn biquad_filter(shape: BiquadShape, freq_hz: f32, looptime_us: u32, q: f32) -> crate::Result<Filter<f32>> {
    let (b, a) = biquad_coeffs(shape, freq_hz, looptime_us, q);
    Filter::from_biquad(b.map(f64::from), a.map(f64::from)).map_err(|e| crate::Error::Input(format!("filter: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_polynomial_sine_is_within_its_stated_error() {
        let worst = (0..20_000)
            .map(|k| -6.0 + 12.0 * k as f32 / 20_000.0)
            .map(|x| (f64::from(sin_approx(x)) - f64::from(x).sin()).abs())
            .fold(0.0, f64::max);
        assert!(worst < 3e-6, "{worst}");
        assert_eq!(sin_approx(40.0), 0.0);
        assert!((cos_approx(0.0) - 1.0).abs() < 3e-6);
    }
}
