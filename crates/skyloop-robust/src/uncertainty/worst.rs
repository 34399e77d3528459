//! The worst-case (destabilizing) perturbation of a μ analysis as a real-rational stable system.
//!
//! μ's lower bound gives a constant complex Δ₀ at one frequency ω₀ with det(I − M(jω₀)Δ₀) = 0. A
//! time-domain check needs a real, stable, causal Δ(s) with the same structure, Δ(jω₀) = Δ₀ and
//! ‖Δ‖∞ = σ̄(Δ₀) (Zhou, Doyle & Glover, *Robust and Optimal Control*, 1996, §9.3 / Lemma 9.2 and
//! §11.2; MATLAB `robstab` returns such a perturbation). Each complex number c = |c|·e^{jφ} is
//! realized as |c|·(a − s)/(a + s), whose phase −2·atan(ω₀/a) covers (−π, 0), or as the negated
//! all-pass −|c|·(a − s)/(a + s) for phases in (0, π); both have the constant gain |c| at every
//! frequency. A full block's lower-bound perturbation is rank one, σ·u·vᴴ, realized as
//! σ·u(s)·vᴴ(s) with every entry such an all-pass: then ‖u(jω)‖ = ‖v(jω)‖ = 1 for all ω, so
//! σ̄(Δ(jω)) = σ at every frequency. A full block's common phase (u·e^{jθ}, v·e^{jθ}) is chosen to
//! keep every entry's phase away from 0 and ±π, so its all-pass corners stay within a decade or two of
//! ω₀; a scalar block has no such freedom, and a phase within a few 1e-k rad of 0 or ±π puts its corner
//! about 10^k times above or below ω₀ (phases within 1e-12 rad are realized as real constants).

use super::blocks::{BlockKind, BlockStructure};
use crate::error::Result;
use crate::error::RobustError;
use faer::{c64, Mat, MatRef};
use skyloop_lti::interconnect::append;
use skyloop_lti::StateSpace;
use std::f64::consts::PI;

/// A realized perturbation and what the realization had to drop.
#[derive(Debug, Clone)]
pub struct RealizedPerturbation {
    /// The stable real-rational Δ(s): `s.m_rows()` inputs (M's outputs), `s.m_cols()` outputs.
    pub sys: StateSpace,
    /// Largest singular value dropped from a full block that was not rank one, relative to that
    /// block's largest (0 when every full block was rank one, as μ's lower bound returns them).
    pub dropped_rel: f64,
}

/// Realizes the constant structured perturbation `delta` (M cols × M rows, as `MuPeak::delta`) found
/// at `w0_rad_s` as a stable real-rational Δ(s) with the same block structure, Δ(jω₀) = `delta` and
/// ‖Δ‖∞ = σ̄(`delta`). Full blocks that are not rank one are replaced by their rank-one part (see
/// [`realize_perturbation_detailed`] for how much was dropped). At ω₀ = 0 the result is the constant
/// real matrix, and `delta` must be real there.
pub fn realize_perturbation(delta: MatRef<c64>, s: &BlockStructure, w0_rad_s: f64) -> Result<StateSpace> {
    Ok(realize_perturbation_detailed(delta, s, w0_rad_s)?.sys)
}

/// As [`realize_perturbation`], also reporting the relative size of what a rank-one truncation dropped.
pub fn realize_perturbation_detailed(
    delta: MatRef<c64>,
    s: &BlockStructure,
    w0_rad_s: f64,
) -> Result<RealizedPerturbation> {
    if !(w0_rad_s.is_finite() && w0_rad_s >= 0.0) {
        return Err(RobustError::InvalidArgument(format!(
            "realize_perturbation: the frequency {w0_rad_s} rad/s must be finite and >= 0"
        )));
    }
    if delta.nrows() != s.m_cols() || delta.ncols() != s.m_rows() {
        return Err(RobustError::Dimension(format!(
            "realize_perturbation: the block structure needs Δ of size {}x{}, got {}x{}",
            s.m_cols(),
            s.m_rows(),
            delta.nrows(),
            delta.ncols()
        )));
    }
    for j in 0..delta.ncols() {
        for i in 0..delta.nrows() {
            let z = delta[(i, j)];
            if !(z.re.is_finite() && z.im.is_finite()) {
                return Err(RobustError::InvalidArgument(format!(
                    "realize_perturbation: Δ({i},{j}) = {z} is not finite"
                )));
            }
        }
    }
    let scale = max_abs(delta);
    // Entries outside the blocks must be zero: Δ is block diagonal.
    let mut inside = Mat::<bool>::from_fn(delta.nrows(), delta.ncols(), |_, _| false);
    for j in 0..s.len() {
        for p in s.col_range(j) {
            for q in s.row_range(j) {
                inside[(p, q)] = true;
            }
        }
    }
    for q in 0..delta.ncols() {
        for p in 0..delta.nrows() {
            if !inside[(p, q)] && delta[(p, q)].norm() > 1e-12 * scale.max(f64::MIN_POSITIVE) {
                return Err(RobustError::InvalidArgument(format!(
                    "realize_perturbation: Δ({p},{q}) = {} lies outside the block diagonal",
                    delta[(p, q)]
                )));
            }
        }
    }

    let mut dropped_rel = 0.0f64;
    let mut parts = Vec::with_capacity(s.len());
    for (j, blk) in s.blocks().iter().enumerate() {
        let (cr, rr) = (s.col_range(j), s.row_range(j));
        let sub = Mat::<c64>::from_fn(cr.len(), rr.len(), |p, q| delta[(cr.start + p, rr.start + q)]);
        let part = match *blk {
            BlockKind::RealScalar { repeat } => {
                let d = repeated_scalar(&sub, j)?;
                if d.im.abs() > 1e-9 * d.norm().max(f64::MIN_POSITIVE) {
                    return Err(RobustError::InvalidArgument(format!(
                        "realize_perturbation: block {} is real but Δ has the complex value {d}",
                        j + 1
                    )));
                }
                StateSpace::gain(
                    Mat::from_fn(repeat, repeat, |p, q| if p == q { d.re } else { 0.0 }),
                    0.0,
                )?
            }
            BlockKind::ComplexScalar { repeat } => {
                let d = repeated_scalar(&sub, j)?;
                let one = siso_allpass(d, w0_rad_s, j)?;
                let mut acc = one.clone();
                for _ in 1..repeat {
                    acc = append(&acc, &one)?;
                }
                acc
            }
            BlockKind::Full { rows, cols } => {
                let (sys, dropped) = full_block(&sub, rows, cols, w0_rad_s, j)?;
                dropped_rel = dropped_rel.max(dropped);
                sys
            }
        };
        parts.push(part);
    }
    let mut sys = parts[0].clone();
    for p in &parts[1..] {
        sys = append(&sys, p)?;
    }
    Ok(RealizedPerturbation { sys, dropped_rel })
}

fn max_abs(m: MatRef<c64>) -> f64 {
    let mut x = 0.0f64;
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            x = x.max(m[(i, j)].norm());
        }
    }
    x
}

/// The δ of a δ·I block; the block must be a multiple of the identity.
fn repeated_scalar(sub: &Mat<c64>, j: usize) -> Result<c64> {
    let d = sub[(0, 0)];
    let tol = 1e-9 * max_abs(sub.as_ref()).max(f64::MIN_POSITIVE);
    for q in 0..sub.ncols() {
        for p in 0..sub.nrows() {
            let want = if p == q { d } else { c64::new(0.0, 0.0) };
            if (sub[(p, q)] - want).norm() > tol {
                return Err(RobustError::InvalidArgument(format!(
                    "realize_perturbation: block {} is a repeated scalar δ·I but Δ is not a multiple of I there",
                    j + 1
                )));
            }
        }
    }
    Ok(d)
}

/// Phase below which an entry is taken as real (rad): the resulting error |c|·|φ| is at rounding level.
const PHASE_TOL: f64 = 1e-12;

/// c·(a − s)/(a + s) or a constant, with value `c` at s = jω₀, as (A, B, C, D) scalars or None
/// for a constant (then the gain is the returned D).
fn allpass_parts(c: c64, w0_rad_s: f64, j: usize) -> Result<(Option<f64>, f64)> {
    let mag = c.norm();
    let phi = c.arg(); // (−π, π]
    if mag == 0.0 {
        return Ok((None, 0.0));
    }
    if w0_rad_s == 0.0 {
        if phi.abs() > 1e-9 && (PI - phi.abs()) > 1e-9 {
            return Err(RobustError::InvalidArgument(format!(
                "realize_perturbation: block {} has the complex value {c} at ω₀ = 0, where a real-rational Δ is real",
                j + 1
            )));
        }
        return Ok((None, if phi.abs() <= PI / 2.0 { mag } else { -mag }));
    }
    if phi.abs() <= PHASE_TOL {
        return Ok((None, mag));
    }
    if PI - phi.abs() <= PHASE_TOL {
        return Ok((None, -mag));
    }
    // Phase of (a − jω₀)/(a + jω₀) is −2·atan(ω₀/a) ∈ (−π, 0); a positive phase takes the negated
    // all-pass, whose phase is π more.
    let (gain, target) = if phi < 0.0 { (mag, phi) } else { (-mag, phi - PI) };
    let a = w0_rad_s / (-target / 2.0).tan();
    Ok((Some(a), gain))
}

/// A SISO stable system with value `c` at jω₀ and constant gain |c|.
fn siso_allpass(c: c64, w0_rad_s: f64, j: usize) -> Result<StateSpace> {
    Ok(match allpass_parts(c, w0_rad_s, j)? {
        (None, g) => StateSpace::gain(Mat::from_fn(1, 1, |_, _| g), 0.0)?,
        // g·(a − s)/(a + s) = −g + 2a·g/(s + a).
        (Some(a), g) => StateSpace::from_rows(&[vec![-a]], &[vec![1.0]], &[vec![2.0 * a * g]], &[vec![-g]], 0.0)?,
    })
}

/// The phase θ that puts arg(uᵢ) + θ and arg(vh_q) − θ farthest from multiples of π: the middle of
/// the widest gap between the forbidden values −arg(uᵢ) and arg(vh_q) (mod π). Entries of rounding
/// size are skipped (they are realized as constants anyway).
fn common_phase(u: &[c64], vh: &[c64]) -> f64 {
    let big = u.iter().chain(vh).fold(0.0f64, |m, z| m.max(z.norm()));
    let tiny = 1e-14 * big;
    let mut f: Vec<f64> = u
        .iter()
        .filter(|z| z.norm() > tiny)
        .map(|z| (-z.arg()).rem_euclid(PI))
        .chain(vh.iter().filter(|z| z.norm() > tiny).map(|z| z.arg().rem_euclid(PI)))
        .collect();
    if f.is_empty() {
        return 0.0;
    }
    f.sort_by(f64::total_cmp);
    let mut best = (f[0] + PI - f[f.len() - 1], f[f.len() - 1]);
    for w in f.windows(2) {
        if w[1] - w[0] > best.0 {
            best = (w[1] - w[0], w[0]);
        }
    }
    best.1 + best.0 / 2.0
}

/// A full `rows × cols` block: its rank-one part σ·u·vᴴ realized as σ·u(s)·vᴴ(s); returns the system and
/// the dropped relative singular value σ₂/σ₁.
fn full_block(sub: &Mat<c64>, rows: usize, cols: usize, w0_rad_s: f64, j: usize) -> Result<(StateSpace, f64)> {
    if w0_rad_s == 0.0 {
        // A real constant matrix keeps every singular value: no truncation is needed.
        let tol = 1e-9 * max_abs(sub.as_ref()).max(f64::MIN_POSITIVE);
        let mut re = Mat::<f64>::zeros(rows, cols);
        for q in 0..cols {
            for p in 0..rows {
                if sub[(p, q)].im.abs() > tol {
                    return Err(RobustError::InvalidArgument(format!(
                        "realize_perturbation: block {} is complex at ω₀ = 0, where a real-rational Δ is real",
                        j + 1
                    )));
                }
                re[(p, q)] = sub[(p, q)].re;
            }
        }
        return Ok((StateSpace::gain(re, 0.0)?, 0.0));
    }
    let svd = sub
        .svd()
        .map_err(|_| RobustError::Numerical("realize_perturbation: SVD of a full block did not converge".into()))?;
    let k = rows.min(cols);
    let sig: Vec<f64> = (0..k).map(|i| svd.S()[i].re).collect();
    let s1 = sig[0];
    if s1 == 0.0 {
        return Ok((StateSpace::gain(Mat::zeros(rows, cols), 0.0)?, 0.0));
    }
    let dropped = if k > 1 { sig[1] / s1 } else { 0.0 };
    // u·vᴴ = (u·e^{jθ})·(v·e^{jθ})ᴴ for any θ: choose θ to keep every entry's phase away from 0 and
    // ±π, where the all-pass corner a = ω₀/tan(−φ/2) would run off to ∞ or 0 and spread the poles over
    // many decades (which ruins the conditioning of everything the Δ is closed around).
    let u0: Vec<c64> = (0..rows).map(|i| svd.U()[(i, 0)]).collect();
    // vᴴ's entries are the conjugates of v's.
    let vh0: Vec<c64> = (0..cols).map(|i| svd.V()[(i, 0)].conj()).collect();
    let theta = common_phase(&u0, &vh0);
    let rot = c64::from_polar(1.0, theta);
    let u: Vec<c64> = u0.iter().map(|&z| z * rot).collect();
    let vh: Vec<c64> = vh0.iter().map(|&z| z * rot.conj()).collect();
    // States: one per non-real entry of vᴴ (the input side), then one per non-real entry of u.
    let pv: Vec<(Option<f64>, f64)> = vh
        .iter()
        .map(|&c| allpass_parts(c, w0_rad_s, j))
        .collect::<Result<_>>()?;
    let pu: Vec<(Option<f64>, f64)> = u
        .iter()
        .map(|&c| allpass_parts(c, w0_rad_s, j))
        .collect::<Result<_>>()?;
    let nv = pv.iter().filter(|p| p.0.is_some()).count();
    let nu = pu.iter().filter(|p| p.0.is_some()).count();
    let n = nv + nu;
    let (mut a, mut b, mut c, mut d) = (
        Mat::<f64>::zeros(n, n),
        Mat::<f64>::zeros(n, cols),
        Mat::<f64>::zeros(rows, n),
        Mat::<f64>::zeros(rows, cols),
    );
    // Scalar w = σ·vᴴ(s)·x = Cw·ξ_v + Dw·x with ξ_v' = −a ξ_v + x_q.
    let mut cw = vec![0.0; n];
    let mut dw = vec![0.0; cols];
    let mut k_state = 0;
    for (q, &(pole, g)) in pv.iter().enumerate() {
        match pole {
            Some(av) => {
                a[(k_state, k_state)] = -av;
                b[(k_state, q)] = 1.0;
                cw[k_state] = 2.0 * av * g * s1;
                dw[q] = -g * s1;
                k_state += 1;
            }
            None => dw[q] = g * s1,
        }
    }
    // Output p = u_p(s)·w: ξ_u' = −a ξ_u + w, y_p = 2a·g·ξ_u − g·w.
    for (p, &(pole, g)) in pu.iter().enumerate() {
        // Coefficient of w in y_p: −g through the all-pass's feedthrough, g for a constant entry.
        let cp = match pole {
            Some(au) => {
                a[(k_state, k_state)] = -au;
                for m in 0..nv {
                    a[(k_state, m)] += cw[m];
                }
                for q in 0..cols {
                    b[(k_state, q)] += dw[q];
                }
                c[(p, k_state)] = 2.0 * au * g;
                k_state += 1;
                -g
            }
            None => g,
        };
        for m in 0..nv {
            c[(p, m)] += cp * cw[m];
        }
        for q in 0..cols {
            d[(p, q)] += cp * dw[q];
        }
    }
    Ok((StateSpace::new(a, b, c, d, 0.0)?, dropped))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mu::{mu_system, robust_stability, MuOptions};
    use crate::uncertainty::sample::sample_delta;
    use rand::SeedableRng;
    use skyloop_lti::freqresp::evalfr;
    use skyloop_lti::interconnect::lft_upper;
    use skyloop_lti::norms::hinf_norm;
    use skyloop_lti::poles_zeros::poles;

    fn sigma_max(m: &Mat<c64>) -> f64 {
        m.singular_values().expect("svd")[0]
    }

    fn check(delta: &Mat<c64>, s: &BlockStructure, w0: f64) -> StateSpace {
        let sys = realize_perturbation(delta.as_ref(), s, w0).expect("realizes");
        assert_eq!((sys.ny(), sys.nu()), (s.m_cols(), s.m_rows()));
        // Δ(jω₀) = Δ₀ (the defining interpolation condition).
        let at = evalfr(&sys, c64::new(0.0, w0)).expect("eval");
        for q in 0..delta.ncols() {
            for p in 0..delta.nrows() {
                assert!(
                    (at[(p, q)] - delta[(p, q)]).norm() < 1e-9,
                    "Δ(jω₀)({p},{q}) = {} vs {}",
                    at[(p, q)],
                    delta[(p, q)]
                );
            }
        }
        // Stable, and ‖Δ‖∞ = σ̄(Δ₀): all-pass entries keep the gain at every frequency.
        assert!(poles(&sys).expect("poles").iter().all(|z| z.re < 0.0));
        let (n, _) = hinf_norm(&sys).expect("norm");
        let smax = sigma_max(delta);
        assert!((n - smax).abs() <= 1e-6 * smax.max(1.0), "‖Δ‖∞ {n} vs σ̄ {smax}");
        // Structure kept: zero outside the blocks at other frequencies too.
        for w in [0.0, 0.3 * w0 + 0.1, 10.0 * w0 + 1.0] {
            let g = evalfr(&sys, c64::new(0.0, w)).expect("eval");
            for p in 0..g.nrows() {
                for q in 0..g.ncols() {
                    let in_any = (0..s.len()).any(|k| s.col_range(k).contains(&p) && s.row_range(k).contains(&q));
                    if !in_any {
                        assert!(g[(p, q)].norm() < 1e-14, "off-block entry ({p},{q}) at {w}");
                    }
                }
            }
            for j in 0..s.len() {
                if let BlockKind::ComplexScalar { .. } | BlockKind::RealScalar { .. } = s.blocks()[j] {
                    let (cr, rr) = (s.col_range(j), s.row_range(j));
                    for (a, b) in cr.clone().zip(rr.clone()).skip(1) {
                        assert!((g[(a, b)] - g[(cr.start, rr.start)]).norm() < 1e-12, "δ·I kept");
                    }
                }
            }
        }
        sys
    }

    /// A rank-one full block from outer products (as the μ lower bound returns it).
    fn rank_one(rows: usize, cols: usize, sigma: f64, seed: u64) -> Mat<c64> {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let s = BlockStructure::parse(&format!("f{rows}x1,f1x{cols}")).expect("spec");
        let d = sample_delta(&s, &mut rng, true);
        let u = Mat::<c64>::from_fn(rows, 1, |i, _| d[(i, 0)]);
        let v = Mat::<c64>::from_fn(1, cols, |_, q| d[(rows, 1 + q)]);
        let o = &u * &v;
        let n = sigma_max(&o);
        Mat::from_fn(rows, cols, |p, q| o[(p, q)] * (sigma / n))
    }

    #[test]
    fn mixed_structures_interpolate_and_keep_the_norm() {
        let s = BlockStructure::parse("c1x1,f3x2,r1,c2r,f1x1").expect("spec");
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        for (trial, w0) in [0.7, 3.0, 25.0].into_iter().enumerate() {
            let mut d = sample_delta(&s, &mut rng, false);
            // Replace the full blocks by rank-one ones, the largest one setting σ̄.
            let f = rank_one(3, 2, 1.3, trial as u64);
            let (cr, rr) = (s.col_range(1), s.row_range(1));
            for p in 0..3 {
                for q in 0..2 {
                    d[(cr.start + p, rr.start + q)] = f[(p, q)];
                }
            }
            // Phases 0 and π must come out as constants.
            d[(0, 0)] = c64::new(-0.4, 0.0);
            let sys = check(&d, &s, w0);
            assert!(sys.nx() <= 1 + 5 + 2 + 1);
            // The common phase of the full block keeps its corners within a few decades of ω₀
            // (the scalar blocks' corners depend on their phases alone, so only check the full block).
            let fb = realize_perturbation(f.as_ref(), &BlockStructure::parse("f3x2").expect("spec"), w0).expect("ok");
            for z in poles(&fb).expect("poles") {
                assert!(z.norm() < 100.0 * w0 && z.norm() > 0.01 * w0, "pole {z} for ω₀ = {w0}");
            }
        }
    }

    #[test]
    fn every_phase_quadrant_and_the_real_axis() {
        let s = BlockStructure::parse("c1x1").expect("spec");
        for k in 0..16 {
            let phi = -PI + (k as f64 + 0.5) * PI / 8.0;
            check(&Mat::from_fn(1, 1, |_, _| c64::from_polar(0.8, phi)), &s, 2.0);
        }
        for v in [0.5, -0.5, 0.0] {
            let sys = check(&Mat::from_fn(1, 1, |_, _| c64::new(v, 0.0)), &s, 2.0);
            assert_eq!(sys.nx(), 0);
        }
    }

    #[test]
    fn zero_frequency_gives_a_constant_real_matrix() {
        let s = BlockStructure::parse("f2x2,c1x1,r1").expect("spec");
        let mut d = Mat::<c64>::zeros(4, 4);
        d[(0, 0)] = c64::new(0.3, 0.0);
        d[(0, 1)] = c64::new(-0.2, 0.0);
        d[(1, 1)] = c64::new(0.5, 0.0);
        d[(2, 2)] = c64::new(-0.7, 0.0);
        d[(3, 3)] = c64::new(0.1, 0.0);
        let sys = check(&d, &s, 0.0);
        assert_eq!(sys.nx(), 0);
        d[(2, 2)] = c64::new(0.0, 0.7);
        assert!(realize_perturbation(d.as_ref(), &s, 0.0).is_err());
    }

    #[test]
    fn a_full_rank_block_is_truncated_to_rank_one_and_says_so() {
        let s = BlockStructure::parse("f2x2").expect("spec");
        let d = Mat::<c64>::from_fn(2, 2, |p, q| {
            if p == q {
                c64::new([1.0, 0.25][p], 0.3)
            } else {
                c64::new(0.0, 0.0)
            }
        });
        let r = realize_perturbation_detailed(d.as_ref(), &s, 1.0).expect("realizes");
        // σ(Δ₀) = |1 + 0.3j|, |0.25 + 0.3j|: the ratio is what was dropped.
        let want = c64::new(0.25, 0.3).norm() / c64::new(1.0, 0.3).norm();
        assert!((r.dropped_rel - want).abs() < 1e-12);
        let (n, _) = hinf_norm(&r.sys).expect("norm");
        assert!((n - c64::new(1.0, 0.3).norm()).abs() < 1e-6);
    }

    #[test]
    fn bad_input_is_an_error() {
        let s = BlockStructure::parse("c2r,r1").expect("spec");
        let mut d = Mat::<c64>::identity(3, 3);
        assert!(realize_perturbation(d.as_ref(), &s, -1.0).is_err());
        assert!(realize_perturbation(d.as_ref(), &s, f64::NAN).is_err());
        assert!(realize_perturbation(d.as_ref(), &s, f64::INFINITY).is_err());
        assert!(realize_perturbation(Mat::<c64>::identity(2, 3).as_ref(), &s, 1.0).is_err());
        d[(0, 2)] = c64::new(0.1, 0.0);
        assert!(realize_perturbation(d.as_ref(), &s, 1.0).is_err(), "off-diagonal");
        d[(0, 2)] = c64::new(0.0, 0.0);
        d[(1, 1)] = c64::new(0.5, 0.0);
        assert!(realize_perturbation(d.as_ref(), &s, 1.0).is_err(), "not δ·I");
        d[(1, 1)] = c64::new(1.0, 0.0);
        d[(2, 2)] = c64::new(0.0, 1.0);
        assert!(realize_perturbation(d.as_ref(), &s, 1.0).is_err(), "complex real block");
        d[(2, 2)] = c64::new(f64::NAN, 0.0);
        assert!(realize_perturbation(d.as_ref(), &s, 1.0).is_err(), "NaN");
    }

    /// M(s) with two extra external channels so that the LFT keeps one input and one output.
    fn m_with_io() -> StateSpace {
        // Two lightly damped modes coupled through B and C; loop channels first, then one external.
        StateSpace::from_rows(
            &[
                vec![0.0, 1.0, 0.0, 0.0],
                vec![-4.0, -0.4, 0.0, 0.0],
                vec![0.0, 0.0, 0.0, 1.0],
                vec![0.0, 0.0, -1.0, -0.3],
            ],
            &[
                vec![0.0, 0.0, 0.0],
                vec![1.0, 0.5, 1.0],
                vec![0.0, 0.0, 0.0],
                vec![-0.3, 1.0, 0.0],
            ],
            &[
                vec![1.0, 0.2, 0.5, 0.0],
                vec![0.0, 0.3, 1.0, 0.4],
                vec![1.0, 0.0, 0.0, 0.0],
            ],
            &[vec![0.0; 3], vec![0.0; 3], vec![0.0; 3]],
            0.0,
        )
        .expect("model")
    }

    fn abscissa(sys: &StateSpace) -> f64 {
        poles(sys)
            .expect("poles")
            .iter()
            .fold(f64::NEG_INFINITY, |m, z| m.max(z.re))
    }

    #[test]
    fn the_worst_case_perturbation_destabilizes_just_beyond_the_margin() {
        let g = m_with_io();
        let m = StateSpace::new(
            g.a.clone(),
            Mat::from_fn(4, 2, |i, j| g.b[(i, j)]),
            Mat::from_fn(2, 4, |i, j| g.c[(i, j)]),
            Mat::zeros(2, 2),
            0.0,
        )
        .expect("M11");
        assert!(abscissa(&g) < 0.0, "M nominally stable");
        let w = skyloop_lti::freqresp::logspace(-1.0, 1.0, 200);
        for spec in ["c1x1,c1x1", "f2x2", "c2r"] {
            let s = BlockStructure::parse(spec).expect("spec");
            let opts = MuOptions::default();
            let sweep = mu_system(&m, &w, &s, &opts).expect("mu");
            let margin = robust_stability(&sweep);
            // 2S + F ≤ 3 for all three: the upper bound is exact, so the lower bound's Δ sits on the margin.
            assert!(
                (margin.upper - margin.lower) <= 1e-3 * margin.lower,
                "{spec}: {} vs {}",
                margin.lower,
                margin.upper
            );
            let dwc = realize_perturbation(margin.delta.as_ref(), &s, margin.w_rad_s).expect("realizes");
            let (n, _) = hinf_norm(&dwc).expect("norm");
            assert!((n - margin.upper).abs() < 1e-6 * margin.upper, "{spec}: ‖Δ‖ {n}");
            let scaled = |k: f64| {
                let mut d = dwc.clone();
                d.c = Mat::from_fn(d.c.nrows(), d.c.ncols(), |i, j| k * dwc.c[(i, j)]);
                d.d = Mat::from_fn(d.d.nrows(), d.d.ncols(), |i, j| k * dwc.d[(i, j)]);
                d
            };
            let eps = 0.02;
            let below = abscissa(&lft_upper(&g, &scaled(1.0 - eps)).expect("lft"));
            let above = abscissa(&lft_upper(&g, &scaled(1.0 + eps)).expect("lft"));
            assert!(below < 0.0, "{spec}: (1−ε)Δ_wc gives max Re {below}");
            assert!(above > 0.0, "{spec}: (1+ε)Δ_wc gives max Re {above}");
        }
    }
}
