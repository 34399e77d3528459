//! PX4-style parallel PID: u = kp·e + ∫ki·e + kd·D(−y) + kff·r, derivative on the measurement.
//!
//! The derivative uses the Tustin discretization of s/(tf·s + 1) applied to −y (no derivative kick on
//! setpoint steps); with tf = 0 it is a backward difference. The integrator is forward Euler and is
//! kept inside ±`i_limit` (clamping); in addition either conditional integration or back-calculation
//! (Åström & Hägglund, *Advanced PID Control*, §3.5) stops windup when the output saturates.

use crate::error::{ControlError, Result};
use crate::real::Real;

/// How the integrator reacts to a saturated output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AntiWindup<T> {
    /// Only the ±i_limit clamp.
    Clamp,
    /// Clamp, and do not integrate while the output is saturated in the direction the error pushes (PX4).
    Conditional,
    /// Clamp, and feed kt·(u_sat − u) back into the integrator (kt in 1/s; Åström's tracking gain).
    BackCalculation(T),
}

/// PID gains and limits (SI units of the loop; e.g. rad/s in, normalized torque out).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidGains<T> {
    /// Proportional gain.
    pub kp: T,
    /// Integral gain (1/s · kp-units).
    pub ki: T,
    /// Derivative gain (s · kp-units).
    pub kd: T,
    /// Setpoint feed-forward gain.
    pub kff: T,
    /// Derivative filter time constant tf in seconds (0 = unfiltered).
    pub tf_s: T,
    /// Lower output limit.
    pub out_min: T,
    /// Upper output limit.
    pub out_max: T,
    /// Integrator state limit (absolute value, in output units).
    pub i_limit: T,
    /// Anti-windup scheme.
    pub anti_windup: AntiWindup<T>,
}

impl<T: Real> PidGains<T> {
    /// Gains with no feed-forward, no derivative filter, and wide limits (±1e9).
    pub fn new(kp: T, ki: T, kd: T) -> Self {
        let big = T::from_f64(1e9);
        PidGains {
            kp,
            ki,
            kd,
            kff: T::ZERO,
            tf_s: T::ZERO,
            out_min: -big,
            out_max: big,
            i_limit: big,
            anti_windup: AntiWindup::Clamp,
        }
    }
}

/// A running PID controller; `step` once per sample.
#[derive(Debug, Clone, Copy)]
pub struct Pid<T> {
    g: PidGains<T>,
    integral: T,
    d_state: T,
    y_prev: T,
    first: bool,
}

impl<T: Real> Pid<T> {
    /// Checks the gains (finite, min ≤ max, nonnegative limits) and builds a controller at rest.
    pub fn new(g: PidGains<T>) -> Result<Self> {
        for (v, what) in [
            (g.kp, "kp"),
            (g.ki, "ki"),
            (g.kd, "kd"),
            (g.kff, "kff"),
            (g.tf_s, "tf_s"),
            (g.out_min, "out_min"),
            (g.out_max, "out_max"),
            (g.i_limit, "i_limit"),
        ] {
            if !v.is_finite() {
                return Err(ControlError::NonFinite(what));
            }
        }
        if g.out_min > g.out_max || g.i_limit < T::ZERO || g.tf_s < T::ZERO {
            return Err(ControlError::InvalidLimits);
        }
        if let AntiWindup::BackCalculation(kt) = g.anti_windup {
            if !kt.is_finite() || kt < T::ZERO {
                return Err(ControlError::InvalidLimits);
            }
        }
        Ok(Pid {
            g,
            integral: T::ZERO,
            d_state: T::ZERO,
            y_prev: T::ZERO,
            first: true,
        })
    }

    /// The gains in use.
    pub fn gains(&self) -> &PidGains<T> {
        &self.g
    }

    /// Current integrator value (output units).
    pub fn integral(&self) -> T {
        self.integral
    }

    /// Forgets all history.
    pub fn reset(&mut self) {
        self.integral = T::ZERO;
        self.d_state = T::ZERO;
        self.first = true;
    }

    /// One sample: setpoint r, measurement y, sample time dt (s) → saturated output.
    #[inline]
    pub fn step(&mut self, r: T, y: T, dt: T) -> T {
        let e = r - y;
        if self.first {
            self.y_prev = y;
            self.first = false;
        }
        let two = T::from_f64(2.0);
        let dv = -(y - self.y_prev);
        self.d_state = if self.g.tf_s > T::ZERO {
            let tf2 = two * self.g.tf_s;
            ((tf2 - dt) * self.d_state + two * dv) / (tf2 + dt)
        } else if dt > T::ZERO {
            dv / dt
        } else {
            T::ZERO
        };
        self.y_prev = y;
        let unsat = self.g.kp * e + self.integral + self.g.kd * self.d_state + self.g.kff * r;
        let u = unsat.clamp_to(self.g.out_min, self.g.out_max);
        let di = self.g.ki * e * dt;
        let next = match self.g.anti_windup {
            AntiWindup::Clamp => self.integral + di,
            AntiWindup::Conditional => {
                let pushing_up = unsat > self.g.out_max && di > T::ZERO;
                let pushing_down = unsat < self.g.out_min && di < T::ZERO;
                if pushing_up || pushing_down {
                    self.integral
                } else {
                    self.integral + di
                }
            }
            AntiWindup::BackCalculation(kt) => self.integral + di + kt * (u - unsat) * dt,
        };
        self.integral = next.clamp_to(-self.g.i_limit, self.g.i_limit);
        u
    }
}
