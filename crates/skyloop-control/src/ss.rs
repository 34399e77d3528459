//! A discrete state-space controller x⁺ = A·x + B·e + L·(u − v), v = C·x + D·e, u = sat(v),
//! with anti-windup by conditioning: L is the back-calculation gain. Hanus's self-conditioned form
//! (Hanus, Kinnaert & Henrotte 1987) takes L = B·D⁻¹, which makes the controller states consistent
//! with the output actually applied; L = 0 is the plain controller.

use crate::error::{ControlError, Result};
use crate::real::Real;

/// Controller with at most NX states, NU inputs (errors) and NY outputs (commands); sizes are runtime.
#[derive(Debug, Clone, Copy)]
pub struct SsController<T, const NX: usize, const NU: usize, const NY: usize> {
    a: [[T; NX]; NX],
    b: [[T; NU]; NX],
    c: [[T; NX]; NY],
    d: [[T; NU]; NY],
    l: [[T; NY]; NX],
    u_min: [T; NY],
    u_max: [T; NY],
    x: [T; NX],
    nx: usize,
    nu: usize,
    ny: usize,
}

fn fill<T: Real, const R: usize, const C: usize>(
    dst: &mut [[T; C]; R],
    src: &[T],
    rows: usize,
    cols: usize,
    what: &'static str,
) -> Result<()> {
    if src.len() != rows * cols {
        return Err(ControlError::TooLarge(what, src.len(), rows * cols));
    }
    for i in 0..rows {
        for j in 0..cols {
            let v = src[i * cols + j];
            if !v.is_finite() {
                return Err(ControlError::NonFinite(what));
            }
            dst[i][j] = v;
        }
    }
    Ok(())
}

impl<T: Real, const NX: usize, const NU: usize, const NY: usize> SsController<T, NX, NU, NY> {
    /// Builds from row-major A (nx×nx), B (nx×nu), C (ny×nx), D (ny×nu); unlimited output, L = 0.
    pub fn new(nx: usize, nu: usize, ny: usize, a: &[T], b: &[T], c: &[T], d: &[T]) -> Result<Self> {
        for (n, cap, what) in [(nx, NX, "states"), (nu, NU, "inputs"), (ny, NY, "outputs")] {
            if n > cap {
                return Err(ControlError::TooLarge(what, n, cap));
            }
        }
        let big = T::from_f64(1e30);
        let mut s = SsController {
            a: [[T::ZERO; NX]; NX],
            b: [[T::ZERO; NU]; NX],
            c: [[T::ZERO; NX]; NY],
            d: [[T::ZERO; NU]; NY],
            l: [[T::ZERO; NY]; NX],
            u_min: [-big; NY],
            u_max: [big; NY],
            x: [T::ZERO; NX],
            nx,
            nu,
            ny,
        };
        fill(&mut s.a, a, nx, nx, "A entries")?;
        fill(&mut s.b, b, nx, nu, "B entries")?;
        fill(&mut s.c, c, ny, nx, "C entries")?;
        fill(&mut s.d, d, ny, nu, "D entries")?;
        Ok(s)
    }

    /// Sets output limits (one pair per output).
    pub fn with_limits(mut self, u_min: &[T], u_max: &[T]) -> Result<Self> {
        if u_min.len() != self.ny || u_max.len() != self.ny {
            return Err(ControlError::TooLarge("limits", u_min.len().max(u_max.len()), self.ny));
        }
        for i in 0..self.ny {
            if u_min[i] > u_max[i] {
                return Err(ControlError::InvalidLimits);
            }
            self.u_min[i] = u_min[i];
            self.u_max[i] = u_max[i];
        }
        Ok(self)
    }

    /// Sets the anti-windup gain L (row-major nx×ny).
    pub fn with_aw_gain(mut self, l: &[T]) -> Result<Self> {
        let (nx, ny) = (self.nx, self.ny);
        fill(&mut self.l, l, nx, ny, "L entries")?;
        Ok(self)
    }

    /// Hanus conditioning for a SISO controller: L = B/D (needs D ≠ 0).
    pub fn with_hanus_aw(mut self) -> Result<Self> {
        if self.nu != 1 || self.ny != 1 {
            return Err(ControlError::TooLarge(
                "inputs/outputs for Hanus conditioning",
                self.nu.max(self.ny),
                1,
            ));
        }
        let d = self.d[0][0];
        if d.abs() <= T::from_f64(1e-12) * (T::ONE + d.abs()) || !d.is_finite() {
            return Err(ControlError::SingularFeedthrough);
        }
        for i in 0..self.nx {
            self.l[i][0] = self.b[i][0] / d;
        }
        Ok(self)
    }

    /// (states, inputs, outputs) in use.
    pub fn dims(&self) -> (usize, usize, usize) {
        (self.nx, self.nu, self.ny)
    }

    /// Current state vector (first nx entries are meaningful).
    pub fn state(&self) -> &[T; NX] {
        &self.x
    }

    /// Zeroes the state.
    pub fn reset(&mut self) {
        self.x = [T::ZERO; NX];
    }

    /// One sample of a MIMO controller: errors e (first nu used) → limited commands.
    #[inline]
    pub fn step(&mut self, e: &[T; NU]) -> [T; NY] {
        let (nx, nu, ny) = (self.nx, self.nu, self.ny);
        let mut v = [T::ZERO; NY];
        let mut u = [T::ZERO; NY];
        for k in 0..ny {
            let mut acc = T::ZERO;
            for j in 0..nx {
                acc += self.c[k][j] * self.x[j];
            }
            for j in 0..nu {
                acc += self.d[k][j] * e[j];
            }
            v[k] = acc;
            u[k] = acc.clamp_to(self.u_min[k], self.u_max[k]);
        }
        let mut xn = [T::ZERO; NX];
        for i in 0..nx {
            let mut acc = T::ZERO;
            for j in 0..nx {
                acc += self.a[i][j] * self.x[j];
            }
            for j in 0..nu {
                acc += self.b[i][j] * e[j];
            }
            for k in 0..ny {
                acc += self.l[i][k] * (u[k] - v[k]);
            }
            xn[i] = acc;
        }
        self.x = xn;
        u
    }
}

impl<T: Real, const NX: usize> SsController<T, NX, 1, 1> {
    /// One sample of a SISO controller: error e → limited command.
    #[inline]
    pub fn step_siso(&mut self, e: T) -> T {
        self.step(&[e])[0]
    }
}
