//! Uncertain systems as upper LFTs: y = F_u(M, Δ) u with Δ = blkdiag(Δ₁, …) of a block structure.
//!
//! M's first Σcols(Δ_j) outputs z feed Δ, Δ's outputs v enter M's first Σrows(Δ_j) inputs:
//! [z; y] = M [v; u], v = Δ z.

use super::blocks::{BlockKind, BlockStructure};
use super::sample::sample_ltidyn;
use crate::error::Result;
use crate::error::RobustError;
use faer::Mat;
use rand::Rng;
use skyloop_lti::interconnect::{append, lft_upper};
use skyloop_lti::StateSpace;

/// A nominal interconnection M and the structure of Δ closing its upper channels.
#[derive(Debug, Clone, PartialEq)]
pub struct UncertainSystem {
    /// The LFT coefficient system, inputs [v; u], outputs [z; y].
    pub m: StateSpace,
    /// The structure of Δ.
    pub blocks: BlockStructure,
    /// One name per block, for reports.
    pub names: Vec<String>,
}

impl UncertainSystem {
    /// Wraps M and a structure after checking that M has the uncertainty channels.
    pub fn new(m: StateSpace, blocks: BlockStructure, names: Vec<String>) -> Result<Self> {
        m.validate()?;
        if m.ny() < blocks.m_rows() || m.nu() < blocks.m_cols() {
            return Err(RobustError::Dimension(format!(
                "the LFT system has {} outputs and {} inputs, fewer than the {} and {} uncertainty channels",
                m.ny(),
                m.nu(),
                blocks.m_rows(),
                blocks.m_cols()
            )));
        }
        if names.len() != blocks.len() {
            return Err(RobustError::Dimension(format!(
                "{} names for {} uncertainty blocks",
                names.len(),
                blocks.len()
            )));
        }
        Ok(UncertainSystem { m, blocks, names })
    }

    /// Number of performance outputs y.
    pub fn ny(&self) -> usize {
        self.m.ny() - self.blocks.m_rows()
    }
    /// Number of performance inputs u.
    pub fn nu(&self) -> usize {
        self.m.nu() - self.blocks.m_cols()
    }
    /// A random real perturbed system F_u(M, Δ): real scalars uniform in [−1, 1] (±1 with
    /// `on_boundary`), complex and full blocks replaced by random real stable all-pass-type
    /// systems with ‖Δ‖∞ ≤ 1 (see [`sample_ltidyn`]) with corners in [w_min_rad_s, w_max_rad_s].
    pub fn sample<R: Rng>(
        &self,
        rng: &mut R,
        w_min_rad_s: f64,
        w_max_rad_s: f64,
        on_boundary: bool,
    ) -> Result<StateSpace> {
        let delta = self.sample_delta_system(rng, w_min_rad_s, w_max_rad_s, on_boundary)?;
        Ok(lft_upper(&self.m, &delta)?)
    }

    /// The random real Δ system that [`UncertainSystem::sample`] closes the upper channels with.
    pub fn sample_delta_system<R: Rng>(
        &self,
        rng: &mut R,
        w_min_rad_s: f64,
        w_max_rad_s: f64,
        on_boundary: bool,
    ) -> Result<StateSpace> {
        let mut delta: Option<StateSpace> = None;
        for blk in self.blocks.blocks() {
            let part = match *blk {
                BlockKind::RealScalar { repeat } => {
                    let v = if on_boundary {
                        if rng.gen::<bool>() {
                            1.0
                        } else {
                            -1.0
                        }
                    } else {
                        rng.gen_range(-1.0..=1.0)
                    };
                    StateSpace::gain(
                        Mat::from_fn(repeat, repeat, |i, j| if i == j { v } else { 0.0 }),
                        self.m.dt,
                    )?
                }
                BlockKind::ComplexScalar { repeat } => {
                    let one = sample_ltidyn(1, 1, w_min_rad_s, w_max_rad_s, rng, on_boundary)?;
                    let mut acc = one.clone();
                    for _ in 1..repeat {
                        acc = append(&acc, &one)?;
                    }
                    acc
                }
                BlockKind::Full { rows, cols } => {
                    sample_ltidyn(rows, cols, w_min_rad_s, w_max_rad_s, rng, on_boundary)?
                }
            };
            delta = Some(match delta {
                None => part,
                Some(d) => append(&d, &part)?,
            });
        }
        let delta = delta.ok_or_else(|| RobustError::InvalidArgument("empty block structure".into()))?;
        if self.m.dt != 0.0 && delta.nx() > 0 {
            return Err(RobustError::Unsupported(
                "dynamic uncertainty samples are continuous time only".into(),
            ));
        }
        Ok(delta)
    }

    /// The nominal system (Δ = 0): the lower-right channel of M.
    pub fn nominal(&self) -> Result<StateSpace> {
        let (nz, nv) = (self.blocks.m_rows(), self.blocks.m_cols());
        let (ny, nu) = (self.ny(), self.nu());
        let m = &self.m;
        let mut out = StateSpace::new(
            m.a.clone(),
            Mat::from_fn(m.nx(), nu, |i, j| m.b[(i, nv + j)]),
            Mat::from_fn(ny, m.nx(), |i, j| m.c[(nz + i, j)]),
            Mat::from_fn(ny, nu, |i, j| m.d[(nz + i, nv + j)]),
            m.dt,
        )?;
        out.input_delay = m.input_delay[nv..].to_vec();
        out.output_delay = m.output_delay[nz..].to_vec();
        Ok(out)
    }
}

/// Builds per-channel copies of a SISO weight as an n×n diagonal system (w·I_n), or checks an n×n one.
fn diagonal_weight(w: &StateSpace, n: usize) -> Result<StateSpace> {
    w.validate()?;
    if w.dt != 0.0 {
        return Err(RobustError::Unsupported(
            "uncertainty weights must be continuous time".into(),
        ));
    }
    if w.ny() == n && w.nu() == n {
        return Ok(w.clone());
    }
    if w.ny() != 1 || w.nu() != 1 {
        return Err(RobustError::Dimension(format!(
            "the weight must be SISO or {n}x{n}, got {}x{}",
            w.ny(),
            w.nu()
        )));
    }
    let k = w.nx();
    Ok(StateSpace::new(
        Mat::from_fn(
            n * k,
            n * k,
            |i, j| if i / k == j / k { w.a[(i % k, j % k)] } else { 0.0 },
        ),
        Mat::from_fn(n * k, n, |i, j| if i / k == j { w.b[(i % k, 0)] } else { 0.0 }),
        Mat::from_fn(n, n * k, |i, j| if j / k == i { w.c[(0, j % k)] } else { 0.0 }),
        Mat::from_fn(n, n, |i, j| if i == j { w.d[(0, 0)] } else { 0.0 }),
        0.0,
    )?)
}

fn check_plain(g: &StateSpace) -> Result<()> {
    g.validate()?;
    if g.dt != 0.0 || g.has_delay() {
        return Err(RobustError::Unsupported(
            "multiplicative uncertainty needs a continuous model without delays (apply pade first)".into(),
        ));
    }
    Ok(())
}

/// Input multiplicative uncertainty G_p = G (I + Δ W) with Δ a full nu×nu block (‖Δ‖∞ ≤ 1) and
/// W a SISO weight (used on every input) or an nu×nu weight.
///
/// M: z = W u, y = G (u + v); states [x_W; x_G].
pub fn input_multiplicative(g: &StateSpace, w: &StateSpace) -> Result<UncertainSystem> {
    check_plain(g)?;
    let nu = g.nu();
    let w = diagonal_weight(w, nu)?;
    let (nw, ng, ny) = (w.nx(), g.nx(), g.ny());
    let n = nw + ng;
    // Inputs [v (nu); u (nu)], outputs [z (nu); y (ny)].
    let a = Mat::from_fn(n, n, |i, j| match (i < nw, j < nw) {
        (true, true) => w.a[(i, j)],
        (false, false) => g.a[(i - nw, j - nw)],
        _ => 0.0,
    });
    let b = Mat::from_fn(n, 2 * nu, |i, j| {
        if i < nw {
            if j >= nu {
                w.b[(i, j - nu)]
            } else {
                0.0
            }
        } else {
            g.b[(i - nw, j % nu)]
        }
    });
    let c = Mat::from_fn(nu + ny, n, |i, j| match (i < nu, j < nw) {
        (true, true) => w.c[(i, j)],
        (false, false) => g.c[(i - nu, j - nw)],
        _ => 0.0,
    });
    let d = Mat::from_fn(nu + ny, 2 * nu, |i, j| {
        if i < nu {
            if j >= nu {
                w.d[(i, j - nu)]
            } else {
                0.0
            }
        } else {
            g.d[(i - nu, j % nu)]
        }
    });
    let m = StateSpace::new(a, b, c, d, 0.0)?;
    let blocks = BlockStructure::new(vec![full_or_scalar(nu, nu)])?;
    UncertainSystem::new(m, blocks, vec!["input multiplicative".into()])
}

/// Output multiplicative uncertainty G_p = (I + Δ W) G with Δ a full ny×ny block and W SISO or ny×ny.
///
/// M: z = W G u, y = G u + v; states [x_G; x_W].
pub fn output_multiplicative(g: &StateSpace, w: &StateSpace) -> Result<UncertainSystem> {
    check_plain(g)?;
    let ny = g.ny();
    let w = diagonal_weight(w, ny)?;
    let (nw, ng, nu) = (w.nx(), g.nx(), g.nu());
    let n = ng + nw;
    let bwcg = &w.b * &g.c;
    let bwdg = &w.b * &g.d;
    let dwcg = &w.d * &g.c;
    let dwdg = &w.d * &g.d;
    let a = Mat::from_fn(n, n, |i, j| match (i < ng, j < ng) {
        (true, true) => g.a[(i, j)],
        (false, true) => bwcg[(i - ng, j)],
        (false, false) => w.a[(i - ng, j - ng)],
        (true, false) => 0.0,
    });
    // Inputs [v (ny); u (nu)], outputs [z (ny); y (ny)].
    let b = Mat::from_fn(n, ny + nu, |i, j| match (i < ng, j < ny) {
        (_, true) => 0.0,
        (true, false) => g.b[(i, j - ny)],
        (false, false) => bwdg[(i - ng, j - ny)],
    });
    let c = Mat::from_fn(2 * ny, n, |i, j| match (i < ny, j < ng) {
        (true, true) => dwcg[(i, j)],
        (true, false) => w.c[(i, j - ng)],
        (false, true) => g.c[(i - ny, j)],
        (false, false) => 0.0,
    });
    let d = Mat::from_fn(2 * ny, ny + nu, |i, j| match (i < ny, j < ny) {
        (true, true) => 0.0,
        (true, false) => dwdg[(i, j - ny)],
        (false, true) => {
            if i - ny == j {
                1.0
            } else {
                0.0
            }
        }
        (false, false) => g.d[(i - ny, j - ny)],
    });
    let m = StateSpace::new(a, b, c, d, 0.0)?;
    let blocks = BlockStructure::new(vec![full_or_scalar(ny, ny)])?;
    UncertainSystem::new(m, blocks, vec!["output multiplicative".into()])
}

fn full_or_scalar(rows: usize, cols: usize) -> BlockKind {
    if rows == 1 && cols == 1 {
        BlockKind::ComplexScalar { repeat: 1 }
    } else {
        BlockKind::Full { rows, cols }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::c64;

    /// Test-only dense evaluation C (sI − A)⁻¹ B + D of a small model.
    fn eval(sys: &StateSpace, w: f64) -> Mat<c64> {
        use faer::linalg::solvers::Solve;
        let n = sys.nx();
        let s = c64::new(0.0, w);
        let a = Mat::<c64>::from_fn(n, n, |i, j| if i == j { s } else { c64::new(0.0, 0.0) } - sys.a[(i, j)]);
        let b = Mat::<c64>::from_fn(n, sys.nu(), |i, j| c64::new(sys.b[(i, j)], 0.0));
        let c = Mat::<c64>::from_fn(sys.ny(), n, |i, j| c64::new(sys.c[(i, j)], 0.0));
        let x = a.partial_piv_lu().solve(b);
        let cx = c * x;
        Mat::from_fn(sys.ny(), sys.nu(), |i, j| cx[(i, j)] + sys.d[(i, j)])
    }

    fn plant() -> StateSpace {
        // 2×2, 3 states: arbitrary stable test plant.
        StateSpace::from_rows(
            &[vec![-1.0, 0.5, 0.0], vec![0.0, -2.0, 1.0], vec![0.3, 0.0, -0.5]],
            &[vec![1.0, 0.0], vec![0.0, 1.0], vec![0.5, -1.0]],
            &[vec![1.0, 0.0, 1.0], vec![0.0, 2.0, 0.0]],
            &[vec![0.0, 0.1], vec![0.0, 0.0]],
            0.0,
        )
        .expect("plant")
    }

    /// F_u(M, Δ) at one frequency for a constant Δ, by the LFT formula.
    fn lft_u(m: &Mat<c64>, nz: usize, nv: usize, delta: &Mat<c64>) -> Mat<c64> {
        use faer::linalg::solvers::Solve;
        let (ny, nu) = (m.nrows() - nz, m.ncols() - nv);
        let m11 = Mat::from_fn(nz, nv, |i, j| m[(i, j)]);
        let m12 = Mat::from_fn(nz, nu, |i, j| m[(i, nv + j)]);
        let m21 = Mat::from_fn(ny, nv, |i, j| m[(nz + i, j)]);
        let m22 = Mat::from_fn(ny, nu, |i, j| m[(nz + i, nv + j)]);
        let dm = delta * &m11;
        let i_dm = Mat::from_fn(
            nv,
            nv,
            |i, j| if i == j { c64::new(1.0, 0.0) } else { c64::new(0.0, 0.0) } - dm[(i, j)],
        );
        let x = i_dm.partial_piv_lu().solve(delta * &m12);
        Mat::from_fn(ny, nu, |i, j| m22[(i, j)] + (&m21 * &x)[(i, j)])
    }

    #[test]
    fn multiplicative_forms_match_their_definition() {
        let g = plant();
        let w = crate::uncertainty::weights::makeweight(0.1, 5.0, 2.0).expect("weight");
        let delta = Mat::<c64>::from_fn(2, 2, |i, j| c64::new(0.3 * i as f64 - 0.2, 0.1 * j as f64));
        for om in [0.0, 0.8, 7.0] {
            let gj = eval(&g, om);
            let wj = eval(&w, om)[(0, 0)];
            let eye = |n: usize| Mat::<c64>::from_fn(n, n, |i, j| c64::new(if i == j { 1.0 } else { 0.0 }, 0.0));
            let dw = Mat::<c64>::from_fn(2, 2, |i, j| delta[(i, j)] * wj);
            let ui = input_multiplicative(&g, &w).expect("input form");
            let want = &gj * (eye(2) + &dw);
            let got = lft_u(&eval(&ui.m, om), 2, 2, &delta);
            assert!((&got - &want).norm_max() < 1e-12 * want.norm_max());
            let uo = output_multiplicative(&g, &w).expect("output form");
            let want = (eye(2) + &dw) * &gj;
            let got = lft_u(&eval(&uo.m, om), 2, 2, &delta);
            assert!((&got - &want).norm_max() < 1e-12 * want.norm_max());
            // Δ = 0 gives the nominal plant.
            assert!((&eval(&ui.nominal().expect("nominal"), om) - &gj).norm_max() < 1e-12);
        }
        // Samples: on the boundary, a real all-pass Δ(s) = D₀(a − s)/(a + s) closes the loop; the
        // sampled system must match the LFT formula with that Δ evaluated at jω.
        use rand::SeedableRng;
        let ui = input_multiplicative(&g, &w).expect("input form");
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let dsys = ui.sample_delta_system(&mut rng, 0.1, 10.0, true).expect("sample");
        let gp = lft_upper(&ui.m, &dsys).expect("lft");
        assert_eq!((gp.ny(), gp.nu()), (2, 2));
        for om in [0.0, 0.8, 7.0] {
            let dj = eval(&dsys, om);
            assert!(
                (dj.singular_values().expect("svd")[0] - 1.0).abs() < 1e-12,
                "boundary sample has norm 1"
            );
            let want = lft_u(&eval(&ui.m, om), 2, 2, &dj);
            assert!((&eval(&gp, om) - &want).norm_max() < 1e-10 * want.norm_max());
        }
        let gs = ui.sample(&mut rng, 0.1, 10.0, false).expect("sample");
        assert_eq!(gs.nx(), ui.m.nx() + 2);
        let w3 = StateSpace::gain(Mat::zeros(3, 3), 0.0).expect("gain");
        assert!(input_multiplicative(&g, &w3).is_err());
    }
}
