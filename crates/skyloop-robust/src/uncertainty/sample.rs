//! Random samples of Δ for Monte Carlo: constant complex matrices in the structured unit ball, and
//! real stable dynamic blocks with ‖Δ‖∞ ≤ 1.

use super::blocks::{BlockKind, BlockStructure};
use crate::error::Result;
use faer::{c64, Mat};
use rand::Rng;
use skyloop_lti::StateSpace;

/// A random constant Δ (M cols × M rows) in the structure's unit ball: complex scalars uniform
/// in the disc, real scalars uniform in [−1, 1], full blocks Gaussian directions with σ̄ uniform
/// in [0, 1]. With `on_boundary` every block has |δ| = 1 or σ̄ = 1.
pub fn sample_delta<R: Rng>(s: &BlockStructure, rng: &mut R, on_boundary: bool) -> Mat<c64> {
    let mut d = Mat::<c64>::zeros(s.m_cols(), s.m_rows());
    for (j, blk) in s.blocks().iter().enumerate() {
        let (cr, rr) = (s.col_range(j), s.row_range(j));
        let radius = |rng: &mut R, dim: f64| {
            if on_boundary {
                1.0
            } else {
                rng.gen::<f64>().powf(1.0 / dim)
            }
        };
        match *blk {
            BlockKind::RealScalar { .. } => {
                let v = if on_boundary {
                    if rng.gen::<bool>() {
                        1.0
                    } else {
                        -1.0
                    }
                } else {
                    rng.gen_range(-1.0..=1.0)
                };
                for (p, q) in cr.zip(rr) {
                    d[(p, q)] = c64::new(v, 0.0);
                }
            }
            BlockKind::ComplexScalar { .. } => {
                // Uniform in the disc: radius √U.
                let r = radius(rng, 2.0);
                let th = rng.gen_range(0.0..std::f64::consts::TAU);
                for (p, q) in cr.zip(rr) {
                    d[(p, q)] = c64::from_polar(r, th);
                }
            }
            BlockKind::Full { rows, cols } => {
                let g = Mat::<c64>::from_fn(rows, cols, |_, _| c64::new(gauss(rng), gauss(rng)));
                let smax = g.singular_values().ok().and_then(|v| v.first().copied()).unwrap_or(0.0);
                let scale = if smax > 0.0 { radius(rng, 1.0) / smax } else { 0.0 };
                for p in 0..rows {
                    for q in 0..cols {
                        d[(cr.start + p, rr.start + q)] = g[(p, q)] * scale;
                    }
                }
            }
        }
    }
    d
}

/// Standard normal sample (Box–Muller), so no extra distribution crate is needed here.
fn gauss<R: Rng>(rng: &mut R) -> f64 {
    let u1: f64 = rng.gen::<f64>().max(f64::MIN_POSITIVE);
    let u2: f64 = rng.gen();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A random real stable `rows × cols` system with ‖Δ‖∞ ≤ 1: Δ(s) = D₀·(a − s)/(a + s), an all-pass
/// times a real matrix with σ̄(D₀) ≤ 1 (σ̄ = 1 with `on_boundary`), the corner a log-uniform in
/// [w_min_rad_s, w_max_rad_s]. Used to sample ultidyn blocks in time-domain Monte Carlo.
pub fn sample_ltidyn<R: Rng>(
    rows: usize,
    cols: usize,
    w_min_rad_s: f64,
    w_max_rad_s: f64,
    rng: &mut R,
    on_boundary: bool,
) -> Result<StateSpace> {
    if !(w_min_rad_s > 0.0 && w_max_rad_s >= w_min_rad_s && w_max_rad_s.is_finite()) || rows == 0 || cols == 0 {
        return Err(crate::error::RobustError::InvalidArgument(
            "sample_ltidyn: need positive dimensions and 0 < w_min <= w_max < inf".into(),
        ));
    }
    let a = (w_min_rad_s.ln() + rng.gen::<f64>() * (w_max_rad_s / w_min_rad_s).ln()).exp();
    let g = Mat::<f64>::from_fn(rows, cols, |_, _| gauss(rng));
    let smax = g.singular_values().ok().and_then(|v| v.first().copied()).unwrap_or(0.0);
    let r = if on_boundary { 1.0 } else { rng.gen::<f64>() };
    let scale = if smax > 0.0 { r / smax } else { 0.0 };
    let d0 = Mat::<f64>::from_fn(rows, cols, |i, j| g[(i, j)] * scale);
    // (a − s)/(a + s) = −1 + 2a/(s + a) on each input channel.
    Ok(StateSpace::new(
        Mat::from_fn(cols, cols, |i, j| if i == j { -a } else { 0.0 }),
        Mat::from_fn(cols, cols, |i, j| if i == j { 1.0 } else { 0.0 }),
        Mat::from_fn(rows, cols, |i, j| 2.0 * a * d0[(i, j)]),
        Mat::from_fn(rows, cols, |i, j| -d0[(i, j)]),
        0.0,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn samples_respect_the_structure_and_the_unit_ball() {
        let s = BlockStructure::parse("c1x1,f2x3,r1,c2r").expect("spec");
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        for k in 0..50 {
            let on_boundary = k % 2 == 0;
            let d = sample_delta(&s, &mut rng, on_boundary);
            assert_eq!((d.nrows(), d.ncols()), (s.m_cols(), s.m_rows()));
            for (j, blk) in s.blocks().iter().enumerate() {
                let (cr, rr) = (s.col_range(j), s.row_range(j));
                let sub = Mat::<c64>::from_fn(cr.len(), rr.len(), |p, q| d[(cr.start + p, rr.start + q)]);
                let smax = sub.singular_values().expect("svd")[0];
                assert!(smax <= 1.0 + 1e-12);
                if on_boundary {
                    assert!((smax - 1.0).abs() < 1e-12);
                }
                if blk.is_real() {
                    assert_eq!(sub[(0, 0)].im, 0.0);
                }
            }
            // Nothing outside the blocks: total energy equals the sum over blocks.
            let total: f64 = (0..d.nrows())
                .flat_map(|i| (0..d.ncols()).map(move |j| (i, j)))
                .map(|(i, j)| d[(i, j)].norm_sqr())
                .sum();
            let inside: f64 = (0..s.len())
                .map(|j| {
                    let mut acc = 0.0;
                    for p in s.col_range(j) {
                        for q in s.row_range(j) {
                            acc += d[(p, q)].norm_sqr();
                        }
                    }
                    acc
                })
                .sum();
            assert!((total - inside).abs() < 1e-14);
        }
    }

    #[test]
    fn ltidyn_samples_are_stable_and_bounded() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(9);
        let d = sample_ltidyn(2, 3, 0.1, 100.0, &mut rng, true).expect("sample");
        assert!((0..3).all(|i| d.a[(i, i)] < 0.0));
        // On jω the all-pass has modulus 1, so σ̄(Δ(jω)) = σ̄(D₀) = 1 at every frequency (closed form).
        for w in [0.0, 0.7, 30.0] {
            let a = -d.a[(0, 0)];
            let ap = (c64::new(a, -w)) / c64::new(a, w);
            let m = Mat::<c64>::from_fn(2, 3, |i, j| c64::new(-d.d[(i, j)], 0.0) * ap);
            assert!((m.singular_values().expect("svd")[0] - 1.0).abs() < 1e-12);
        }
        assert!(sample_ltidyn(2, 3, 0.0, 1.0, &mut rng, false).is_err());
    }
}
