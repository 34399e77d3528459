//! A discrete SISO controller as a gain times a cascade of second-order sections (biquads),
//! each run in transposed direct form II, the numerically robust form for fixed-rate firmware.

use crate::error::{ControlError, Result};
use crate::real::Real;

/// One biquad (b0 + b1 z⁻¹ + b2 z⁻²)/(1 + a1 z⁻¹ + a2 z⁻²).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Biquad<T> {
    /// Numerator coefficient of z⁰.
    pub b0: T,
    /// Numerator coefficient of z⁻¹.
    pub b1: T,
    /// Numerator coefficient of z⁻².
    pub b2: T,
    /// Denominator coefficient of z⁻¹.
    pub a1: T,
    /// Denominator coefficient of z⁻².
    pub a2: T,
}

/// Up to `N` cascaded biquads with an overall gain and output limits.
#[derive(Debug, Clone, Copy)]
pub struct SosController<T, const N: usize> {
    sections: [Biquad<T>; N],
    state: [[T; 2]; N],
    n: usize,
    gain: T,
    out_min: T,
    out_max: T,
}

impl<T: Real, const N: usize> SosController<T, N> {
    /// Builds the cascade from `sections` (at most N), overall `gain`, and output limits.
    pub fn new(sections: &[Biquad<T>], gain: T, out_min: T, out_max: T) -> Result<Self> {
        if sections.len() > N {
            return Err(ControlError::TooLarge("sections", sections.len(), N));
        }
        if !gain.is_finite() {
            return Err(ControlError::NonFinite("gain"));
        }
        if out_min > out_max {
            return Err(ControlError::InvalidLimits);
        }
        let mut s = [Biquad::default(); N];
        for (i, q) in sections.iter().enumerate() {
            for v in [q.b0, q.b1, q.b2, q.a1, q.a2] {
                if !v.is_finite() {
                    return Err(ControlError::NonFinite("biquad coefficient"));
                }
            }
            s[i] = *q;
        }
        Ok(SosController {
            sections: s,
            state: [[T::ZERO; 2]; N],
            n: sections.len(),
            gain,
            out_min,
            out_max,
        })
    }

    /// Number of sections in use.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True when the cascade is a pure gain.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Zeroes all section states.
    pub fn reset(&mut self) {
        self.state = [[T::ZERO; 2]; N];
    }

    /// One sample: input e → limited output.
    #[inline]
    pub fn step(&mut self, e: T) -> T {
        let mut x = e * self.gain;
        for (q, s) in self.sections[..self.n].iter().zip(self.state[..self.n].iter_mut()) {
            let y = q.b0 * x + s[0];
            s[0] = q.b1 * x - q.a1 * y + s[1];
            s[1] = q.b2 * x - q.a2 * y;
            x = y;
        }
        x.clamp_to(self.out_min, self.out_max)
    }
}
