//! D-scalings as state-space systems: rational fits of D-scale data made biproper, their inverses,
//! and the scaled plant diag(D_L, I)·P·diag(D_R⁻¹, I) of the K-step.

use super::dfit::{fit_magnitude, DFit};
use crate::error::Result;
use crate::error::RobustError;
use crate::uncertainty::blocks::{BlockKind, BlockStructure};
use faer::{c64, Mat};
use skyloop_lti::interconnect::{append, series};
use skyloop_lti::poly::Poly;
use skyloop_lti::tf::TransferFunction;
use skyloop_lti::StateSpace;

/// Fits |d(jω)| = `mag` by a stable, minimum-phase, biproper d(s) of order ≤ `order` (lower orders
/// are tried when a fit fails). Missing zeros or poles of the fit are placed at −100·max(ω), where
/// they leave the magnitude on the grid nearly unchanged but keep d⁻¹ proper.
pub fn fit_scaling(w_rad_s: &[f64], mag: &[f64], order: usize) -> Result<StateSpace> {
    let mut last = None;
    for ord in (0..=order).rev() {
        match fit_magnitude(w_rad_s, mag, ord) {
            Ok(f) => return biproper(&f, w_rad_s),
            Err(e) => last = Some(e),
        }
    }
    Err(last.unwrap_or_else(|| RobustError::InvalidArgument("no D-scale data to fit".into())))
}

fn biproper(f: &DFit, w_rad_s: &[f64]) -> Result<StateSpace> {
    let a = 100.0 * w_rad_s.iter().cloned().fold(0.0, f64::max).max(1e-12);
    let (mut zeros, mut poles, mut gain) = (f.zeros.clone(), f.poles.clone(), f.gain);
    // (s + a)/a ≈ 1 on the grid.
    while zeros.len() < poles.len() {
        zeros.push(c64::new(-a, 0.0));
        gain /= a;
    }
    while poles.len() < zeros.len() {
        poles.push(c64::new(-a, 0.0));
        gain *= a;
    }
    let num = Poly::from_roots(&zeros).scale(gain);
    let den = Poly::from_roots(&poles);
    Ok(skyloop_lti::convert::tf_to_ss(&TransferFunction::siso(num, den, 0.0)?)?)
}

/// The inverse of a square biproper system (D invertible): (A − B D⁻¹ C, B D⁻¹, −D⁻¹ C, D⁻¹).
pub fn inverse(d: &StateSpace) -> Result<StateSpace> {
    use faer::linalg::solvers::Solve;
    if d.ny() != d.nu() {
        return Err(RobustError::Dimension(format!(
            "only square systems can be inverted, got {}x{}",
            d.ny(),
            d.nu()
        )));
    }
    let n = d.nu();
    let lu = d.d.partial_piv_lu();
    let dinv = lu.solve(Mat::<f64>::identity(n, n));
    let check = &d.d * &dinv - Mat::<f64>::identity(n, n);
    let err = (0..n)
        .flat_map(|i| (0..n).map(move |j| (i, j)))
        .fold(0.0_f64, |m, (i, j)| m.max(check[(i, j)].abs()));
    if err.is_nan() || err >= 1e-8 {
        return Err(RobustError::Numerical(
            "the scaling's feedthrough is singular: it has no proper inverse".into(),
        ));
    }
    let b_dinv = &d.b * &dinv;
    let a = &d.a - &b_dinv * &d.c;
    let c = -(&dinv * &d.c);
    Ok(StateSpace::new(a, b_dinv, c, dinv, d.dt)?)
}

/// Per-channel scalings of one structure: `left[k]` scales M's row k (z), `right[k]` M's column
/// k (w). Built from one scalar d(s) per block channel, see [`block_channels`].
#[derive(Debug, Clone)]
pub struct Scalings {
    /// SISO d(s) on each z channel (M rows).
    pub left: Vec<StateSpace>,
    /// SISO d(s) on each w channel (M columns); the scaled plant uses their inverses.
    pub right: Vec<StateSpace>,
}

/// For a block structure, how many distinct scalar scalings each block has: one for a full block
/// (d·I on both sides), `r` for a δI_r block (a diagonal D_j; a full Hermitian D_j is not fitted).
pub fn block_channels(s: &BlockStructure) -> Vec<usize> {
    s.blocks()
        .iter()
        .map(|b| match b {
            BlockKind::Full { .. } => 1,
            _ => b.rows(),
        })
        .collect()
}

/// Expands one SISO scaling per block channel (in [`block_channels`] order) to the z and w channels.
pub fn expand(s: &BlockStructure, per_channel: &[StateSpace]) -> Result<Scalings> {
    let counts = block_channels(s);
    let total: usize = counts.iter().sum();
    if per_channel.len() != total {
        return Err(RobustError::Dimension(format!(
            "the structure has {total} scaling channels, got {} scalings",
            per_channel.len()
        )));
    }
    for (k, d) in per_channel.iter().enumerate() {
        if d.ny() != 1 || d.nu() != 1 || d.dt != 0.0 || d.has_delay() {
            return Err(RobustError::InvalidArgument(format!(
                "scaling {k} must be a continuous-time SISO system without delay"
            )));
        }
    }
    let mut left = Vec::with_capacity(s.m_rows());
    let mut right = Vec::with_capacity(s.m_cols());
    let mut off = 0;
    for (j, b) in s.blocks().iter().enumerate() {
        match b {
            BlockKind::Full { rows, cols } => {
                left.extend(std::iter::repeat_n(per_channel[off].clone(), *cols));
                right.extend(std::iter::repeat_n(per_channel[off].clone(), *rows));
            }
            _ => {
                for p in 0..b.rows() {
                    left.push(per_channel[off + p].clone());
                    right.push(per_channel[off + p].clone());
                }
            }
        }
        off += counts[j];
    }
    Ok(Scalings { left, right })
}

/// Block-diagonal system of SISO pieces followed by an identity of size `extra`.
fn diagonal(parts: &[StateSpace], extra: usize) -> Result<StateSpace> {
    let mut out = StateSpace::gain(Mat::<f64>::identity(extra, extra), 0.0)?;
    for p in parts.iter().rev() {
        out = append(p, &out)?;
    }
    Ok(out)
}

/// The D-scaled plant diag(D_L, I_nmeas)·P·diag(D_R⁻¹, I_ncon), where D_L and D_R act on the
/// first `sc.left.len()` outputs and `sc.right.len()` inputs of P (the channels of Δ and of the
/// performance block). Every scaling must be stable, minimum phase and biproper.
pub fn scaled_plant(p: &StateSpace, sc: &Scalings, nmeas: usize, ncon: usize) -> Result<StateSpace> {
    if sc.left.len() + nmeas != p.ny() || sc.right.len() + ncon != p.nu() {
        return Err(RobustError::Dimension(format!(
            "scalings for {} outputs and {} inputs (+ {nmeas} measurements, {ncon} controls) do not fit a {}x{} plant",
            sc.left.len(),
            sc.right.len(),
            p.ny(),
            p.nu()
        )));
    }
    let rinv = sc.right.iter().map(inverse).collect::<Result<Vec<_>>>()?;
    let dl = diagonal(&sc.left, nmeas)?;
    let dr = diagonal(&rinv, ncon)?;
    Ok(series(&series(&dr, p)?, &dl)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use skyloop_lti::freqresp::evalfr;

    #[test]
    fn fitted_scalings_are_biproper_and_invert() {
        // Data of d(s) = (s+1)/(s+10)·10 (a lead with unit DC gain, exact for order 1); an order-2
        // request must still give a stable, minimum-phase, biproper system.
        let w: Vec<f64> = (0..40).map(|k| 10f64.powf(-2.0 + 4.0 * k as f64 / 39.0)).collect();
        let mag: Vec<f64> = w
            .iter()
            .map(|&x| 10.0 * (1.0 + x * x).sqrt() / (100.0 + x * x).sqrt())
            .collect();
        let d = fit_scaling(&w, &mag, 2).expect("fit");
        assert!(d.d[(0, 0)].abs() > 0.0);
        let di = inverse(&d).expect("inverse");
        for &x in &[0.03, 1.0, 30.0] {
            let g = evalfr(&d, c64::new(0.0, x)).expect("eval")[(0, 0)];
            let gi = evalfr(&di, c64::new(0.0, x)).expect("eval")[(0, 0)];
            assert!((g * gi - c64::new(1.0, 0.0)).norm() < 1e-9);
            let want = 10.0 * (1.0 + x * x).sqrt() / (100.0 + x * x).sqrt();
            assert!((g.norm() / want - 1.0).abs() < 1e-3, "|d| {} vs {want}", g.norm());
        }
        let poles = skyloop_lti::poles_zeros::poles(&d).expect("poles");
        let zeros = skyloop_lti::poles_zeros::poles(&di).expect("zeros");
        assert!(poles.iter().chain(&zeros).all(|p| p.re < 0.0));
    }

    #[test]
    fn scaled_plant_is_d_p_dinv() {
        // P = 3x3 static gain with nmeas = ncon = 1; the 2x2 upper part is scaled by constants
        // d = (2, 5) on a structure of two complex scalars, so entry (i, j) becomes d_i/d_j·P_ij.
        let s = BlockStructure::parse("c1x1,c1x1").expect("spec");
        let pd = Mat::from_fn(3, 3, |i, j| (1 + i + 3 * j) as f64);
        let p = StateSpace::gain(pd.clone(), 0.0).expect("P");
        let k = |v: f64| StateSpace::gain(Mat::from_fn(1, 1, |_, _| v), 0.0).expect("gain");
        let sc = expand(&s, &[k(2.0), k(5.0)]).expect("expand");
        let ps = scaled_plant(&p, &sc, 1, 1).expect("scaled");
        let dv = [2.0, 5.0, 1.0];
        for i in 0..3 {
            for j in 0..3 {
                assert!((ps.d[(i, j)] - dv[i] / dv[j] * pd[(i, j)]).abs() < 1e-12);
            }
        }
        assert!(expand(&s, &[k(1.0)]).is_err());
        assert!(scaled_plant(&p, &sc, 2, 1).is_err());
        assert!(inverse(&k(0.0)).is_err());
    }
}
