//! The steady-state-integral PI rate law of Tai, Phang & Hoo (2018), eq. (31):
//! u = Kp·e + Ki·Kp·∫e dt − Ki·Jm·ω, with e = ω_r − ω and Jm the modelled inertia.
//!
//! The integral is forward Euler; when u saturates, back-calculation with gain kt (1/s) bleeds the
//! integral so that Ki·Kp·∫e tracks the saturated output.

use crate::error::{ControlError, Result};
use crate::real::Real;

/// SSI-PI parameters for one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SsiPiGains<T> {
    /// Proportional gain Kp (N·m per rad/s).
    pub kp: T,
    /// Integral gain Ki (1/s); the third closed-loop pole sits at s = −Ki when Jm = J (eq. (33)).
    pub ki: T,
    /// Modelled inertia Jm (kg·m²).
    pub jm: T,
    /// Lower output limit (N·m).
    pub out_min: T,
    /// Upper output limit (N·m).
    pub out_max: T,
    /// Back-calculation gain kt (1/s); 0 disables it.
    pub kt: T,
}

/// A running SSI-PI controller for one axis.
#[derive(Debug, Clone, Copy)]
pub struct SsiPi<T> {
    g: SsiPiGains<T>,
    integral: T,
}

impl<T: Real> SsiPi<T> {
    /// Checks the parameters and builds a controller at rest.
    pub fn new(g: SsiPiGains<T>) -> Result<Self> {
        for (v, what) in [
            (g.kp, "kp"),
            (g.ki, "ki"),
            (g.jm, "jm"),
            (g.out_min, "out_min"),
            (g.out_max, "out_max"),
            (g.kt, "kt"),
        ] {
            if !v.is_finite() {
                return Err(ControlError::NonFinite(what));
            }
        }
        if g.out_min > g.out_max || g.kt < T::ZERO {
            return Err(ControlError::InvalidLimits);
        }
        Ok(SsiPi { g, integral: T::ZERO })
    }

    /// The parameters in use.
    pub fn gains(&self) -> &SsiPiGains<T> {
        &self.g
    }

    /// ∫e dt so far (rad).
    pub fn integral(&self) -> T {
        self.integral
    }

    /// Forgets the integral.
    pub fn reset(&mut self) {
        self.integral = T::ZERO;
    }

    /// One sample: rate setpoint ω_r and measured rate ω (rad/s), sample time dt (s) → torque.
    #[inline]
    pub fn step(&mut self, omega_ref: T, omega: T, dt: T) -> T {
        let g = &self.g;
        let e = omega_ref - omega;
        let unsat = g.kp * e + g.ki * g.kp * self.integral - g.ki * g.jm * omega;
        let u = unsat.clamp_to(g.out_min, g.out_max);
        let kikp = g.ki * g.kp;
        let bc = if g.kt > T::ZERO && kikp.abs() > T::ZERO {
            g.kt * (u - unsat) / kikp
        } else {
            T::ZERO
        };
        self.integral += (e + bc) * dt;
        u
    }
}
