//! State-space models: dx = A x + B u, y = C x + D u (or x[k+1] = ... when `dt > 0`), with delays.

use crate::error::{LtiError, Result};
use faer::Mat;

/// A MIMO state-space model with optional input and output delays.
///
/// `dt == 0` is continuous time; `dt > 0` is discrete time with sample period `dt` seconds.
/// Delays are in seconds for both (a discrete delay should be a multiple of `dt`).
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpace {
    /// State matrix, nx × nx.
    pub a: Mat<f64>,
    /// Input matrix, nx × nu.
    pub b: Mat<f64>,
    /// Output matrix, ny × nx.
    pub c: Mat<f64>,
    /// Feedthrough matrix, ny × nu.
    pub d: Mat<f64>,
    /// Sample period in seconds; 0 for continuous time.
    pub dt: f64,
    /// Delay on each input in seconds (length nu).
    pub input_delay: Vec<f64>,
    /// Delay on each output in seconds (length ny).
    pub output_delay: Vec<f64>,
}

impl StateSpace {
    /// The same model in balanced state coordinates (LAPACK dgebal on A: x = T·x̃ with T = P·D), so
    /// that eigenvalues, rank tests, Riccati solutions and norms are not spoiled by badly scaled
    /// realizations such as companion forms or states ranging from metres to millisecond delays.
    pub fn balance_states(&self) -> Result<StateSpace> {
        if self.nx() == 0 {
            return Ok(self.clone());
        }
        let bal = skyloop_linalg::balance::balance(self.a.as_ref());
        let mut out = self.clone();
        out.b = bal.forward_transform(self.b.as_ref());
        out.c = Mat::from_fn(self.ny(), self.nx(), |i, j| self.c[(i, bal.perm[j])] * bal.scale[j]);
        out.a = bal.a;
        out.validate()?;
        Ok(out)
    }

    /// Builds a delay-free model after checking every dimension and that `dt` is finite and ≥ 0.
    pub fn new(a: Mat<f64>, b: Mat<f64>, c: Mat<f64>, d: Mat<f64>, dt: f64) -> Result<Self> {
        let (nu, ny) = (d.ncols(), d.nrows());
        let sys = StateSpace {
            a,
            b,
            c,
            d,
            dt,
            input_delay: vec![0.0; nu],
            output_delay: vec![0.0; ny],
        };
        sys.validate()?;
        Ok(sys)
    }

    /// A static gain matrix (no states), in continuous time when `dt == 0`.
    pub fn gain(d: Mat<f64>, dt: f64) -> Result<Self> {
        let (ny, nu) = (d.nrows(), d.ncols());
        StateSpace::new(Mat::zeros(0, 0), Mat::zeros(0, nu), Mat::zeros(ny, 0), d, dt)
    }

    /// Builds a model from row-major nested vectors (as in LTI JSON); empty `a`, `b`, `c` mean a static gain.
    pub fn from_rows(a: &[Vec<f64>], b: &[Vec<f64>], c: &[Vec<f64>], d: &[Vec<f64>], dt: f64) -> Result<Self> {
        let d = mat_from_rows(d, "d")?;
        let (ny, nu) = (d.nrows(), d.ncols());
        let a = mat_from_rows(a, "a")?;
        let nx = a.nrows();
        let b = if b.is_empty() {
            Mat::zeros(nx, nu)
        } else {
            mat_from_rows(b, "b")?
        };
        let c = if c.is_empty() {
            Mat::zeros(ny, nx)
        } else {
            mat_from_rows(c, "c")?
        };
        StateSpace::new(a, b, c, d, dt)
    }

    /// Checks dimensions, finiteness and delays; every constructor calls it.
    pub fn validate(&self) -> Result<()> {
        let nx = self.a.nrows();
        if self.a.ncols() != nx {
            return Err(LtiError::Dimension(format!(
                "A must be square, got {}x{}",
                nx,
                self.a.ncols()
            )));
        }
        let (ny, nu) = (self.d.nrows(), self.d.ncols());
        let check = |m: &Mat<f64>, r: usize, c: usize, name: &str| {
            if m.nrows() != r || m.ncols() != c {
                Err(LtiError::Dimension(format!(
                    "{name} must be {r}x{c} for nx={nx}, ny={ny}, nu={nu}; got {}x{}",
                    m.nrows(),
                    m.ncols()
                )))
            } else {
                Ok(())
            }
        };
        check(&self.b, nx, nu, "B")?;
        check(&self.c, ny, nx, "C")?;
        for (m, name) in [(&self.a, "A"), (&self.b, "B"), (&self.c, "C"), (&self.d, "D")] {
            for j in 0..m.ncols() {
                for i in 0..m.nrows() {
                    if !m[(i, j)].is_finite() {
                        return Err(LtiError::InvalidArgument(format!("{name}[{i},{j}] is not finite")));
                    }
                }
            }
        }
        if !(self.dt.is_finite() && self.dt >= 0.0) {
            return Err(LtiError::InvalidArgument(format!(
                "sample time must be finite and >= 0, got {}",
                self.dt
            )));
        }
        if self.input_delay.len() != nu || self.output_delay.len() != ny {
            return Err(LtiError::Dimension(format!(
                "need {nu} input delays and {ny} output delays, got {} and {}",
                self.input_delay.len(),
                self.output_delay.len()
            )));
        }
        for &t in self.input_delay.iter().chain(&self.output_delay) {
            if !(t.is_finite() && t >= 0.0) {
                return Err(LtiError::InvalidArgument(format!(
                    "delays must be finite and >= 0, got {t}"
                )));
            }
        }
        Ok(())
    }

    /// Returns the model with the given input and output delays in seconds (lengths nu and ny).
    pub fn with_delays(mut self, input_delay: Vec<f64>, output_delay: Vec<f64>) -> Result<Self> {
        self.input_delay = input_delay;
        self.output_delay = output_delay;
        self.validate()?;
        Ok(self)
    }

    /// Number of states.
    pub fn nx(&self) -> usize {
        self.a.nrows()
    }
    /// Number of outputs.
    pub fn ny(&self) -> usize {
        self.d.nrows()
    }
    /// Number of inputs.
    pub fn nu(&self) -> usize {
        self.d.ncols()
    }
    /// True for continuous time (`dt == 0`).
    pub fn is_continuous(&self) -> bool {
        self.dt == 0.0
    }
    /// True when any input or output delay is non-zero.
    pub fn has_delay(&self) -> bool {
        self.input_delay.iter().chain(&self.output_delay).any(|&t| t > 0.0)
    }
}

/// Converts row-major nested vectors to a matrix, rejecting ragged rows.
pub fn mat_from_rows(rows: &[Vec<f64>], name: &str) -> Result<Mat<f64>> {
    let r = rows.len();
    let c = rows.first().map_or(0, |x| x.len());
    if let Some((i, row)) = rows.iter().enumerate().find(|(_, x)| x.len() != c) {
        return Err(LtiError::Dimension(format!(
            "{name}: row {i} has {} entries, row 0 has {c}",
            row.len()
        )));
    }
    Ok(Mat::from_fn(r, c, |i, j| rows[i][j]))
}

/// Converts a matrix to row-major nested vectors.
pub fn mat_to_rows(m: &Mat<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_non_square_a() {
        let e = StateSpace::from_rows(&[vec![1.0, 2.0]], &[vec![1.0]], &[vec![1.0]], &[vec![0.0]], 0.0);
        assert!(matches!(e, Err(LtiError::Dimension(_))));
    }

    #[test]
    fn static_gain_has_no_states() {
        let g = StateSpace::from_rows(&[], &[], &[], &[vec![2.0, 3.0]], 0.0).unwrap();
        assert_eq!((g.nx(), g.ny(), g.nu()), (0, 1, 2));
    }

    #[test]
    fn rejects_negative_delay() {
        let g = StateSpace::gain(Mat::identity(1, 1), 0.0).unwrap();
        assert!(g.with_delays(vec![-1.0], vec![0.0]).is_err());
    }
}
