//! Tunable controller blocks: a parameter vector θ ↦ a state-space realization K(θ) and the exact
//! derivative of (A, B, C, D) with respect to every parameter. The optimizer needs nothing else:
//! the gradient of a goal is the contraction of the goal's sensitivity to (A, B, C, D) (see
//! [`super::closed_loop`]) with these derivatives, so a block is added by writing its realization.
//!
//! Positive time constants and corner frequencies are tuned as their logarithm, which keeps them
//! positive without a constraint and makes the problem scale free.

use crate::error::{Result, RobustError};
use faer::Mat;
use skyloop_lti::StateSpace;

/// d(A, B, C, D)/dθᵢ of a realization for one parameter.
#[derive(Debug, Clone)]
pub struct RealizationGrad {
    /// dA/dθᵢ.
    pub a: Mat<f64>,
    /// dB/dθᵢ.
    pub b: Mat<f64>,
    /// dC/dθᵢ.
    pub c: Mat<f64>,
    /// dD/dθᵢ.
    pub d: Mat<f64>,
}

impl RealizationGrad {
    fn zeros(nx: usize, ny: usize, nu: usize) -> Self {
        RealizationGrad {
            a: Mat::zeros(nx, nx),
            b: Mat::zeros(nx, nu),
            c: Mat::zeros(ny, nx),
            d: Mat::zeros(ny, nu),
        }
    }
}

/// The derivative filter of a PID's D term, kd·s·F(s).
// A problem holds a handful of blocks, built once: boxing the fixed filters would only make the
// user's construction noisier.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum DerivativeFilter {
    /// F(s) = 1/(tf·s + 1) with the time constant tf (s) tuned.
    Tuned,
    /// A fixed strictly proper SISO F(s) (e.g. Betaflight's D-term lowpass chain; a first-order
    /// 1/(tf·s + 1) for a fixed tf).
    Fixed(StateSpace),
}

/// A tunable block. Parameters (θ) in order, in the units of the loop (controller output per
/// measured unit):
#[allow(clippy::large_enum_variant)] // as DerivativeFilter: few blocks, built once
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// K = k. θ = \[k\].
    Gain,
    /// K = kp + ki/s. θ = [kp, ki (1/s)].
    Pi,
    /// K = kp + ki/s + kd·s·F(s). θ = [kp, ki (1/s), kd (s)] and, for a tuned filter, ln tf (tf in s).
    Pid(DerivativeFilter),
    /// K = k·(s + z)/(s + p), z, p > 0 in rad/s (lead when z < p). θ = [k, ln z, ln p].
    LeadLag,
    /// A PID whose P+I path and D path see different fixed filters (firmware rate loops: PX4
    /// differentiates the gyro through its own lowpass, Betaflight filters the D term further):
    /// K = (kp + ki/s)·F_pi(s) + kd·s·F_d(s). θ = [kp, ki (1/s), kd (s)]. F_pi proper (None: 1),
    /// F_d strictly proper.
    PidFiltered {
        /// Filter on the P and I paths (None: none).
        pi_filter: Option<StateSpace>,
        /// Filter on the D path (strictly proper).
        d_filter: StateSpace,
    },
    /// A full state-space block of `order` states with `ny` outputs and `nu` inputs; θ = A, B, C, D
    /// entries row-major, in that order.
    StateSpace {
        /// Number of states.
        order: usize,
        /// Outputs (controls).
        ny: usize,
        /// Inputs (measurements).
        nu: usize,
    },
}

impl Block {
    /// Checks the block's own data (a fixed derivative filter must be SISO, strictly proper,
    /// continuous and delay free).
    ///
    /// # Errors
    /// [`RobustError::InvalidArgument`] naming the problem.
    pub fn validate(&self) -> Result<()> {
        match self {
            Block::PidFiltered { pi_filter, d_filter } => {
                Block::Pid(DerivativeFilter::Fixed(d_filter.clone())).validate()?;
                if let Some(f) = pi_filter {
                    f.validate()?;
                    if f.ny() != 1 || f.nu() != 1 || f.dt != 0.0 || f.has_delay() {
                        return Err(RobustError::InvalidArgument(
                            "the P/I-path filter must be a continuous, delay-free SISO model".into(),
                        ));
                    }
                }
                Ok(())
            }
            Block::Pid(DerivativeFilter::Fixed(f)) => {
                f.validate()?;
                if f.ny() != 1 || f.nu() != 1 || f.dt != 0.0 || f.has_delay() {
                    return Err(RobustError::InvalidArgument(
                        "the fixed derivative filter must be a continuous, delay-free SISO model".into(),
                    ));
                }
                if f.d[(0, 0)] != 0.0 || f.nx() == 0 {
                    return Err(RobustError::InvalidArgument(
                        "the fixed derivative filter must be strictly proper (D = 0), so that kd·s·F(s) is proper"
                            .into(),
                    ));
                }
                Ok(())
            }
            Block::StateSpace { ny, nu, .. } if *ny == 0 || *nu == 0 => Err(RobustError::InvalidArgument(
                "a state-space block needs at least one input and one output".into(),
            )),
            _ => Ok(()),
        }
    }

    /// Number of parameters.
    pub fn nparams(&self) -> usize {
        match self {
            Block::Gain => 1,
            Block::Pi => 2,
            Block::Pid(DerivativeFilter::Tuned) => 4,
            Block::Pid(DerivativeFilter::Fixed(_)) | Block::PidFiltered { .. } => 3,
            Block::LeadLag => 3,
            Block::StateSpace { order, ny, nu } => (order + ny) * (order + nu),
        }
    }

    /// (outputs, inputs) of the block.
    pub fn dims(&self) -> (usize, usize) {
        match self {
            Block::StateSpace { ny, nu, .. } => (*ny, *nu),
            _ => (1, 1),
        }
    }

    /// Names of the parameters, in θ order (`ln_tf` etc. for log-tuned ones).
    pub fn param_names(&self) -> Vec<String> {
        let v = |s: &[&str]| s.iter().map(|x| x.to_string()).collect();
        match self {
            Block::Gain => v(&["k"]),
            Block::Pi => v(&["kp", "ki"]),
            Block::Pid(DerivativeFilter::Tuned) => v(&["kp", "ki", "kd", "ln_tf"]),
            Block::Pid(DerivativeFilter::Fixed(_)) | Block::PidFiltered { .. } => v(&["kp", "ki", "kd"]),
            Block::LeadLag => v(&["k", "ln_z", "ln_p"]),
            Block::StateSpace { order, ny, nu } => {
                let mut n = Vec::new();
                for (m, r, c) in [("a", order, order), ("b", order, nu), ("c", ny, order), ("d", ny, nu)] {
                    for i in 0..*r {
                        for j in 0..*c {
                            n.push(format!("{m}[{i}][{j}]"));
                        }
                    }
                }
                n
            }
        }
    }

    /// Index of the integral gain ki in θ, for the blocks that have one.
    pub fn integral_gain_index(&self) -> Option<usize> {
        match self {
            Block::Pi | Block::Pid(_) | Block::PidFiltered { .. } => Some(1),
            _ => None,
        }
    }

    /// The realization K(θ) (continuous time).
    ///
    /// # Errors
    /// A parameter vector of the wrong length or with non-finite entries.
    pub fn realize(&self, th: &[f64]) -> Result<StateSpace> {
        self.check(th)?;
        let m = |r: usize, c: usize, v: &[f64]| Mat::from_fn(r, c, |i, j| v[i * c + j]);
        Ok(match self {
            Block::Gain => StateSpace::gain(m(1, 1, &[th[0]]), 0.0)?,
            Block::Pi => StateSpace::new(
                m(1, 1, &[0.0]),
                m(1, 1, &[1.0]),
                m(1, 1, &[th[1]]),
                m(1, 1, &[th[0]]),
                0.0,
            )?,
            Block::Pid(DerivativeFilter::Tuned) => {
                let (kp, ki, kd, tf) = (th[0], th[1], th[2], th[3].exp());
                // kd·s/(tf·s + 1) = kd/tf − (kd/tf²)/(s + 1/tf).
                StateSpace::new(
                    m(2, 2, &[0.0, 0.0, 0.0, -1.0 / tf]),
                    m(2, 1, &[1.0, 1.0]),
                    m(1, 2, &[ki, -kd / (tf * tf)]),
                    m(1, 1, &[kp + kd / tf]),
                    0.0,
                )?
            }
            Block::Pid(DerivativeFilter::Fixed(f)) => {
                // s·F(s) = Cf·Bf + Cf·Af·(sI − Af)⁻¹·Bf for strictly proper F.
                let (kp, ki, kd) = (th[0], th[1], th[2]);
                let nf = f.nx();
                let caf = &f.c * &f.a;
                let cbf = (&f.c * &f.b)[(0, 0)];
                let mut a = Mat::zeros(nf + 1, nf + 1);
                a.get_mut(1.., 1..).copy_from(&f.a);
                let mut b = Mat::zeros(nf + 1, 1);
                b[(0, 0)] = 1.0;
                b.get_mut(1.., ..).copy_from(&f.b);
                let c = Mat::from_fn(1, nf + 1, |_, j| if j == 0 { ki } else { kd * caf[(0, j - 1)] });
                StateSpace::new(a, b, c, m(1, 1, &[kp + kd * cbf]), 0.0)?
            }
            Block::PidFiltered { pi_filter, d_filter } => pid_filtered(pi_filter.as_ref(), d_filter, th)?,
            Block::LeadLag => {
                let (k, z, p) = (th[0], th[1].exp(), th[2].exp());
                StateSpace::new(
                    m(1, 1, &[-p]),
                    m(1, 1, &[1.0]),
                    m(1, 1, &[k * (z - p)]),
                    m(1, 1, &[k]),
                    0.0,
                )?
            }
            Block::StateSpace { order, ny, nu } => {
                let (n, p, q) = (*order, *ny, *nu);
                let (ia, ib, ic) = (n * n, n * n + n * q, n * n + n * q + p * n);
                StateSpace::new(
                    m(n, n, &th[..ia]),
                    m(n, q, &th[ia..ib]),
                    m(p, n, &th[ib..ic]),
                    m(p, q, &th[ic..]),
                    0.0,
                )?
            }
        })
    }

    /// d(A, B, C, D)/dθᵢ of [`Block::realize`] for every parameter, exact.
    ///
    /// # Errors
    /// As [`Block::realize`].
    pub fn realize_grad(&self, th: &[f64]) -> Result<Vec<RealizationGrad>> {
        self.check(th)?;
        let k = self.realize(th)?;
        let z = || RealizationGrad::zeros(k.nx(), k.ny(), k.nu());
        let mut g: Vec<RealizationGrad> = (0..self.nparams()).map(|_| z()).collect();
        match self {
            Block::Gain => g[0].d[(0, 0)] = 1.0,
            Block::Pi => {
                g[0].d[(0, 0)] = 1.0;
                g[1].c[(0, 0)] = 1.0;
            }
            Block::Pid(DerivativeFilter::Tuned) => {
                let (kd, tf) = (th[2], th[3].exp());
                g[0].d[(0, 0)] = 1.0;
                g[1].c[(0, 0)] = 1.0;
                g[2].c[(0, 1)] = -1.0 / (tf * tf);
                g[2].d[(0, 0)] = 1.0 / tf;
                // d/d(ln tf) = tf·d/dtf.
                g[3].a[(1, 1)] = 1.0 / tf;
                g[3].c[(0, 1)] = 2.0 * kd / (tf * tf);
                g[3].d[(0, 0)] = -kd / tf;
            }
            Block::Pid(DerivativeFilter::Fixed(f)) => {
                g[0].d[(0, 0)] = 1.0;
                g[1].c[(0, 0)] = 1.0;
                let caf = &f.c * &f.a;
                for j in 0..f.nx() {
                    g[2].c[(0, j + 1)] = caf[(0, j)];
                }
                g[2].d[(0, 0)] = (&f.c * &f.b)[(0, 0)];
            }
            Block::PidFiltered { pi_filter, d_filter } => {
                // Affine in θ: the derivative of each gain is the realization at that gain = 1.
                let base = pid_filtered(pi_filter.as_ref(), d_filter, &[0.0, 0.0, 0.0])?;
                for (i, gi) in g.iter_mut().enumerate() {
                    let mut e = [0.0; 3];
                    e[i] = 1.0;
                    let k1 = pid_filtered(pi_filter.as_ref(), d_filter, &e)?;
                    gi.c = &k1.c - &base.c;
                    gi.d = &k1.d - &base.d;
                }
            }
            Block::LeadLag => {
                let (k, z, p) = (th[0], th[1].exp(), th[2].exp());
                g[0].c[(0, 0)] = z - p;
                g[0].d[(0, 0)] = 1.0;
                g[1].c[(0, 0)] = k * z;
                g[2].a[(0, 0)] = -p;
                g[2].c[(0, 0)] = -k * p;
            }
            Block::StateSpace { order, ny, nu } => {
                let (n, p, q) = (*order, *ny, *nu);
                let mut idx = 0;
                for (which, r, c) in [(0, n, n), (1, n, q), (2, p, n), (3, p, q)] {
                    for i in 0..r {
                        for j in 0..c {
                            let gi = &mut g[idx];
                            match which {
                                0 => gi.a[(i, j)] = 1.0,
                                1 => gi.b[(i, j)] = 1.0,
                                2 => gi.c[(i, j)] = 1.0,
                                _ => gi.d[(i, j)] = 1.0,
                            }
                            idx += 1;
                        }
                    }
                }
            }
        }
        Ok(g)
    }

    fn check(&self, th: &[f64]) -> Result<()> {
        if th.len() != self.nparams() {
            return Err(RobustError::Dimension(format!(
                "the block has {} parameters, got {}",
                self.nparams(),
                th.len()
            )));
        }
        if let Some(x) = th.iter().find(|x| !x.is_finite()) {
            return Err(RobustError::InvalidArgument(format!(
                "block parameter {x} is not finite"
            )));
        }
        Ok(())
    }
}

/// (kp + ki/s)·F_pi + kd·s·F_d with states [x_pi-filter; x_integrator; x_d-filter]; only C and D
/// depend on the gains (linearly), which [`Block::realize_grad`] relies on.
fn pid_filtered(fpi: Option<&StateSpace>, fd: &StateSpace, th: &[f64]) -> Result<StateSpace> {
    let (kp, ki, kd) = (th[0], th[1], th[2]);
    let unit;
    let f1 = match fpi {
        Some(f) => f,
        None => {
            unit = StateSpace::gain(Mat::from_fn(1, 1, |_, _| 1.0), 0.0)?;
            &unit
        }
    };
    let (n1, n2) = (f1.nx(), fd.nx());
    let n = n1 + 1 + n2;
    let mut a = Mat::zeros(n, n);
    a.get_mut(..n1, ..n1).copy_from(&f1.a);
    a.get_mut(n1..n1 + 1, ..n1).copy_from(&f1.c);
    a.get_mut(n1 + 1.., n1 + 1..).copy_from(&fd.a);
    let mut b = Mat::zeros(n, 1);
    b.get_mut(..n1, ..).copy_from(&f1.b);
    b[(n1, 0)] = f1.d[(0, 0)];
    b.get_mut(n1 + 1.., ..).copy_from(&fd.b);
    let caf = &fd.c * &fd.a;
    let mut c = Mat::zeros(1, n);
    for j in 0..n1 {
        c[(0, j)] = kp * f1.c[(0, j)];
    }
    c[(0, n1)] = ki;
    for j in 0..n2 {
        c[(0, n1 + 1 + j)] = kd * caf[(0, j)];
    }
    let d = Mat::from_fn(1, 1, |_, _| kp * f1.d[(0, 0)] + kd * (&fd.c * &fd.b)[(0, 0)]);
    Ok(StateSpace::new(a, b, c, d, 0.0)?)
}

/// A tunable block followed by nothing and preceded by a fixed SISO/MIMO filter F on its input:
/// K_total(θ) = K(θ)·F (for a loop, F is the measurement filter, so C_fb = K·F). The realization
/// stacks the states as [x_F; x_K].
#[derive(Debug, Clone, PartialEq)]
pub struct Structure {
    /// The tunable block.
    pub block: Block,
    /// Fixed filter on the block's input (None: identity).
    pub input_filter: Option<StateSpace>,
}

impl Structure {
    /// A bare block.
    pub fn new(block: Block) -> Self {
        Structure {
            block,
            input_filter: None,
        }
    }

    /// Checks the block and that the filter is continuous, delay free and fits the block's input.
    ///
    /// # Errors
    /// [`RobustError::InvalidArgument`] / [`RobustError::Dimension`] naming the problem.
    pub fn validate(&self) -> Result<()> {
        self.block.validate()?;
        if let Some(f) = &self.input_filter {
            f.validate()?;
            if f.dt != 0.0 || f.has_delay() {
                return Err(RobustError::InvalidArgument(
                    "the fixed input filter must be continuous and delay free (put delays in the plant)".into(),
                ));
            }
            let (_, nu) = self.block.dims();
            if f.ny() != nu || f.nu() != nu {
                return Err(RobustError::Dimension(format!(
                    "the input filter must be {nu}x{nu} to precede the block, got {}x{}",
                    f.ny(),
                    f.nu()
                )));
            }
        }
        Ok(())
    }

    /// Realization of K(θ)·F.
    ///
    /// # Errors
    /// As [`Block::realize`].
    pub fn realize(&self, th: &[f64]) -> Result<StateSpace> {
        let k = self.block.realize(th)?;
        match &self.input_filter {
            None => Ok(k),
            Some(f) => Ok(skyloop_lti::interconnect::series(f, &k)?),
        }
    }

    /// Exact d(A, B, C, D)/dθᵢ of [`Structure::realize`]: the filter's matrices are constant, so
    /// with states [x_F; x_K], dA = [0 0; dB_K·C_F dA_K], dB = [0; dB_K·D_F], dC = [dD_K·C_F dC_K],
    /// dD = dD_K·D_F.
    ///
    /// # Errors
    /// As [`Block::realize`].
    pub fn realize_grad(&self, th: &[f64]) -> Result<Vec<RealizationGrad>> {
        let gk = self.block.realize_grad(th)?;
        let Some(f) = &self.input_filter else {
            return Ok(gk);
        };
        let nf = f.nx();
        Ok(gk
            .into_iter()
            .map(|g| {
                let nk = g.a.nrows();
                let (ny, nu) = (g.d.nrows(), f.nu());
                let mut r = RealizationGrad::zeros(nf + nk, ny, nu);
                r.a.get_mut(nf.., ..nf).copy_from(&g.b * &f.c);
                r.a.get_mut(nf.., nf..).copy_from(&g.a);
                r.b.get_mut(nf.., ..).copy_from(&g.b * &f.d);
                r.c.get_mut(.., ..nf).copy_from(&g.d * &f.c);
                r.c.get_mut(.., nf..).copy_from(&g.c);
                r.d = &g.d * &f.d;
                r
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// Central differences of the realization against the analytic derivative.
    fn check_grad(s: &Structure, th: &[f64]) {
        let g = s.realize_grad(th).unwrap();
        for i in 0..th.len() {
            let h = 1e-6 * th[i].abs().max(1.0);
            let (mut tp, mut tm) = (th.to_vec(), th.to_vec());
            tp[i] += h;
            tm[i] -= h;
            let (kp, km) = (s.realize(&tp).unwrap(), s.realize(&tm).unwrap());
            for (an, fd_p, fd_m) in [
                (&g[i].a, &kp.a, &km.a),
                (&g[i].b, &kp.b, &km.b),
                (&g[i].c, &kp.c, &km.c),
                (&g[i].d, &kp.d, &km.d),
            ] {
                for r in 0..an.nrows() {
                    for c in 0..an.ncols() {
                        let fd = (fd_p[(r, c)] - fd_m[(r, c)]) / (2.0 * h);
                        assert!(
                            (fd - an[(r, c)]).abs() < 1e-6 * (1.0 + fd.abs()),
                            "param {i}: {fd} vs {}",
                            an[(r, c)]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn realization_gradients_match_finite_differences() {
        let filt = skyloop_lti::expr::parse_model("100/(s+100)").unwrap();
        let dfilt = skyloop_lti::expr::parse_model("2500/(s^2+70*s+2500)").unwrap();
        let cases = [
            (Structure::new(Block::Gain), vec![2.0]),
            (Structure::new(Block::Pi), vec![1.5, 0.3]),
            (
                Structure::new(Block::Pid(DerivativeFilter::Tuned)),
                vec![1.0, 0.5, 0.2, (0.05f64).ln()],
            ),
            (
                Structure::new(Block::Pid(DerivativeFilter::Fixed(dfilt))),
                vec![1.0, 0.5, 0.2],
            ),
            (Structure::new(Block::LeadLag), vec![2.0, 1.0f64.ln(), 10.0f64.ln()]),
            (
                Structure::new(Block::PidFiltered {
                    pi_filter: Some(skyloop_lti::expr::parse_model("300/(s+300)").unwrap()),
                    d_filter: skyloop_lti::expr::parse_model("2500/(s^2+70*s+2500)").unwrap(),
                }),
                vec![1.0, 0.5, 0.2],
            ),
            (
                Structure::new(Block::StateSpace { order: 2, ny: 1, nu: 2 }),
                (0..12).map(|i| 0.1 * i as f64 - 0.4).collect(),
            ),
            (
                Structure {
                    block: Block::Pid(DerivativeFilter::Tuned),
                    input_filter: Some(filt),
                },
                vec![1.0, 0.5, 0.2, (0.05f64).ln()],
            ),
        ];
        for (s, th) in &cases {
            s.validate().unwrap();
            check_grad(s, th);
        }
    }

    #[test]
    fn pid_realization_is_the_textbook_pid() {
        // K(j) = kp + ki/j + kd·j/(tf·j + 1) at ω = 1 rad/s.
        let (kp, ki, kd, tf) = (2.0, 3.0, 0.5, 0.1);
        let k = Block::Pid(DerivativeFilter::Tuned)
            .realize(&[kp, ki, kd, f64::ln(tf)])
            .unwrap();
        let s = faer::c64::new(0.0, 1.0);
        let want = kp + ki / s + kd * s / (tf * s + 1.0);
        let got = skyloop_lti::freqresp::evalfr(&k, s).unwrap()[(0, 0)];
        assert!((got - want).norm() < 1e-12);
    }

    #[test]
    fn two_path_pid_is_the_sum_of_its_paths() {
        let fpi = skyloop_lti::expr::parse_model("300/(s+300)").unwrap();
        let fd = skyloop_lti::expr::parse_model("2500/(s^2+70*s+2500)").unwrap();
        let k = Block::PidFiltered {
            pi_filter: Some(fpi.clone()),
            d_filter: fd.clone(),
        }
        .realize(&[2.0, 3.0, 0.5])
        .unwrap();
        let s = faer::c64::new(0.0, 7.0);
        let ev = |m: &StateSpace| skyloop_lti::freqresp::evalfr(m, s).unwrap()[(0, 0)];
        let want = (2.0 + 3.0 / s) * ev(&fpi) + 0.5 * s * ev(&fd);
        assert!((ev(&k) - want).norm() < 1e-12 * want.norm());
    }

    #[test]
    fn bad_blocks_are_named() {
        let biproper = skyloop_lti::expr::parse_model("(s+2)/(s+1)").unwrap();
        let e = Block::Pid(DerivativeFilter::Fixed(biproper)).validate().unwrap_err();
        assert!(e.to_string().contains("strictly proper"), "{e}");
        let e = Block::Pi.realize(&[1.0]).unwrap_err();
        assert!(e.to_string().contains("2 parameters"), "{e}");
    }
}
