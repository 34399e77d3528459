//! Four frequencies per pass over the Schur factor.
//!
//! Why: at one frequency the back-substitution through the quasi-triangular `T` is a chain of
//! short column updates (average length n/2) behind one complex division per diagonal block, so
//! it is bound by latency, not by arithmetic; AVX2 alone did not speed it up. Four frequencies
//! share every entry of `T`, and their four solves are independent, so carrying them side by side
//! (lane `l` of every `[f64; LANES]` belongs to frequency `l`) fills the vector registers and
//! hides the latency. Each lane performs exactly the operations of
//! [`FreqEvaluator::eval_into`] in the same order, so the values are identical to it bit for bit
//! (the test `flat_freqresp_is_pointwise_evaluation_in_row_major_order` checks this).

use super::{cinv, Form, FreqEvaluator};
use crate::error::{LtiError, Result};
use faer::c64;

/// Frequencies evaluated together.
pub(super) const LANES: usize = 4;

type Lane = [f64; LANES];

/// Scratch space of [`FreqEvaluator::eval_lanes`]: the solution `X` of `(xI − T)X = QᵀB`, column
/// by column (nu columns of n lane vectors).
pub(super) struct LaneWorkspace {
    x_re: Vec<Lane>,
    x_im: Vec<Lane>,
}

impl LaneWorkspace {
    pub(super) fn new(n: usize, nu: usize) -> Self {
        LaneWorkspace {
            x_re: vec![[0.0; LANES]; n * nu],
            x_im: vec![[0.0; LANES]; n * nu],
        }
    }
}

#[inline(always)]
fn lane_mul(a: c64, b: c64) -> c64 {
    // The product num-complex computes, written out so the lane code visibly matches it.
    c64::new(a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re)
}

impl FreqEvaluator {
    /// Whether [`FreqEvaluator::eval_lanes`] applies (a Schur factor was computed).
    pub(super) fn has_lanes(&self) -> bool {
        // The lanes solve without the refinement step: models that need it take the scalar path.
        matches!(self.form, Form::Schur { .. }) && self.refine.is_none()
    }

    /// G(jω) at the [`LANES`] frequencies `w` (rad/s) into `out` (ny·nu values per frequency,
    /// row-major, frequency after frequency). Errors as `eval_into` when a frequency is a pole.
    #[inline(always)]
    pub(super) fn eval_lanes(&self, w: &[f64; LANES], ws: &mut LaneWorkspace, out: &mut [c64]) -> Result<()> {
        let Form::Schur { t, blocks } = &self.form else {
            return Err(LtiError::Numerical("no Schur factor for the lane evaluation".into()));
        };
        let (n, nu, ny) = (self.n, self.nu, self.ny);
        let s: [c64; LANES] = std::array::from_fn(|l| c64::new(0.0, w[l]));
        let x: [c64; LANES] = std::array::from_fn(|l| if self.dt > 0.0 { (s[l] * self.dt).exp() } else { s[l] });
        let (x_re, x_im) = (&mut ws.x_re, &mut ws.x_im);
        for (dst, &b) in x_re.iter_mut().zip(&self.b) {
            *dst = [b; LANES];
        }
        x_im.fill([0.0; LANES]);
        let pole = |z: c64| {
            LtiError::Numerical(format!(
                "the model has a pole at s = {}{:+}j (frequency response is infinite there)",
                z.re, z.im
            ))
        };
        let mut end = n;
        for &nb in blocks.iter().rev() {
            let i = end - nb;
            end = i;
            if nb == 1 {
                let mut inv = [c64::new(0.0, 0.0); LANES];
                for l in 0..LANES {
                    let den = x[l] - t[i * n + i];
                    inv[l] = cinv(den);
                    if den == c64::new(0.0, 0.0) || !(inv[l].re.is_finite() && inv[l].im.is_finite()) {
                        return Err(pole(x[l]));
                    }
                }
                let col = &t[i * n..i * n + i];
                for k in 0..nu {
                    let (yr, yi) = (&mut x_re[k * n..(k + 1) * n], &mut x_im[k * n..(k + 1) * n]);
                    let (mut vr, mut vi) = ([0.0; LANES], [0.0; LANES]);
                    for l in 0..LANES {
                        let v = lane_mul(c64::new(yr[i][l], yi[i][l]), inv[l]);
                        (vr[l], vi[l]) = (v.re, v.im);
                    }
                    yr[i] = vr;
                    yi[i] = vi;
                    for ((r, m), &tj) in yr[..i].iter_mut().zip(yi[..i].iter_mut()).zip(col) {
                        for l in 0..LANES {
                            r[l] += tj * vr[l];
                            m[l] += tj * vi[l];
                        }
                    }
                }
            } else {
                // (xI − T_kk) = [[p, −t12], [−t21, q]], inverse by its adjugate (as eval_into).
                let (t11, t22) = (t[i * n + i], t[(i + 1) * n + i + 1]);
                let (t12, t21) = (t[(i + 1) * n + i], t[i * n + i + 1]);
                let mut p = [c64::new(0.0, 0.0); LANES];
                let mut q = p;
                let mut inv = p;
                for l in 0..LANES {
                    (p[l], q[l]) = (x[l] - t11, x[l] - t22);
                    let det = lane_mul(p[l], q[l]) - t12 * t21;
                    inv[l] = cinv(det);
                    if det == c64::new(0.0, 0.0)
                        || !(det.re.is_finite() && det.im.is_finite())
                        || !(inv[l].re.is_finite() && inv[l].im.is_finite())
                    {
                        return Err(pole(x[l]));
                    }
                }
                let (c0, c1) = (&t[i * n..i * n + i], &t[(i + 1) * n..(i + 1) * n + i]);
                for k in 0..nu {
                    let (yr, yi) = (&mut x_re[k * n..(k + 1) * n], &mut x_im[k * n..(k + 1) * n]);
                    let (mut v0r, mut v0i, mut v1r, mut v1i) = ([0.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
                    for l in 0..LANES {
                        let r0 = c64::new(yr[i][l], yi[i][l]);
                        let r1 = c64::new(yr[i + 1][l], yi[i + 1][l]);
                        let v0 = lane_mul(lane_mul(q[l], r0) + t12 * r1, inv[l]);
                        let v1 = lane_mul(t21 * r0 + lane_mul(p[l], r1), inv[l]);
                        (v0r[l], v0i[l], v1r[l], v1i[l]) = (v0.re, v0.im, v1.re, v1.im);
                    }
                    (yr[i], yi[i], yr[i + 1], yi[i + 1]) = (v0r, v0i, v1r, v1i);
                    for (((r, m), &a0), &a1) in yr[..i].iter_mut().zip(yi[..i].iter_mut()).zip(c0).zip(c1) {
                        for l in 0..LANES {
                            r[l] += a0 * v0r[l] + a1 * v1r[l];
                            m[l] += a0 * v0i[l] + a1 * v1i[l];
                        }
                    }
                }
            }
        }
        let per = ny * nu;
        for i in 0..ny {
            let crow = &self.c[i * n..(i + 1) * n];
            for j in 0..nu {
                let re = lane_dot(crow, &x_re[j * n..(j + 1) * n]);
                let im = lane_dot(crow, &x_im[j * n..(j + 1) * n]);
                for l in 0..LANES {
                    out[l * per + i * nu + j] = c64::new(re[l] + self.d[(i, j)], im[l]);
                }
            }
        }
        for l in 0..LANES {
            self.apply_delays(s[l], &mut out[l * per..(l + 1) * per]);
        }
        Ok(())
    }
}

/// `super::dot` in every lane, with its summation order (four partial sums, then the tail).
#[inline(always)]
fn lane_dot(a: &[f64], b: &[Lane]) -> Lane {
    let mut acc = [[0.0f64; LANES]; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            for l in 0..LANES {
                acc[k][l] += x[k] * y[k][l];
            }
        }
    }
    let mut tail = [0.0f64; LANES];
    for (x, y) in ra.iter().zip(rb) {
        for l in 0..LANES {
            tail[l] += x * y[l];
        }
    }
    std::array::from_fn(|l| (acc[0][l] + acc[1][l]) + (acc[2][l] + acc[3][l]) + tail[l])
}
