//! Conversions between state-space and transfer-function models.

use crate::error::{LtiError, Result};
use crate::poles_zeros::{poles, zeros};
use crate::poly::Poly;
use crate::ss::StateSpace;
use crate::tf::TransferFunction;
use faer::linalg::solvers::Solve;
use faer::{c64, Mat};

/// State-space realization of a proper transfer function, keeping its delays exact.
///
/// Each SISO entry is realized in scaled controllable canonical form (minimal when the entry's
/// numerator and denominator are coprime; exactly common roots are cancelled first); MIMO entries
/// are stacked block-diagonally, which is not minimal in general. Entry delays must be expressible as
/// input or output delays.
pub fn tf_to_ss(tf: &TransferFunction) -> Result<StateSpace> {
    tf.validate()?;
    if !tf.is_proper() {
        return Err(LtiError::Unsupported(
            "the transfer function is improper (numerator degree above denominator degree); it has no state-space form"
                .into(),
        ));
    }
    let (ny, nu) = (tf.ny(), tf.nu());
    let (in_extra, out_extra) = split_io_delays(&tf.io_delay)?;
    let blocks: Vec<Vec<Realization>> = (0..ny)
        .map(|i| {
            (0..nu)
                .map(|j| siso_realization(&tf.num[i][j], &tf.den[i][j]))
                .collect()
        })
        .collect();
    let nx: usize = blocks.iter().flatten().map(|b| b.0.nrows()).sum();
    let mut a = Mat::<f64>::zeros(nx, nx);
    let mut b = Mat::<f64>::zeros(nx, nu);
    let mut c = Mat::<f64>::zeros(ny, nx);
    let mut d = Mat::<f64>::zeros(ny, nu);
    let mut off = 0;
    for i in 0..ny {
        for j in 0..nu {
            let (ab, bb, cb, db) = &blocks[i][j];
            let n = ab.nrows();
            for r in 0..n {
                for k in 0..n {
                    a[(off + r, off + k)] = ab[(r, k)];
                }
                b[(off + r, j)] = bb[(r, 0)];
                c[(i, off + r)] = cb[(0, r)];
            }
            d[(i, j)] = *db;
            off += n;
        }
    }
    let input_delay = (0..nu).map(|j| tf.input_delay[j] + in_extra[j]).collect();
    let output_delay = (0..ny).map(|i| tf.output_delay[i] + out_extra[i]).collect();
    StateSpace::new(a, b, c, d, tf.dt)?.with_delays(input_delay, output_delay)
}

/// Zeros, poles and gain of entry (output i, input j) of a state-space model, with pole-zero pairs
/// that coincide to 1e-8 relative removed (after the entry is restricted to its controllable and observable part).
pub fn ss_entry_zpk(sys: &StateSpace, i: usize, j: usize) -> Result<(Vec<c64>, Vec<c64>, f64)> {
    if i >= sys.ny() || j >= sys.nu() {
        return Err(LtiError::Dimension(format!(
            "entry ({i},{j}) outside {}x{}",
            sys.ny(),
            sys.nu()
        )));
    }
    // Keep only the controllable and observable part of this entry (SISO Krylov staircase), so
    // decoupled modes do not show up as pole-zero pairs that cancel only to rounding.
    let bj = Mat::from_fn(sys.nx(), 1, |r, _| sys.b[(r, j)]);
    let (a1, b1, c1t) = krylov_part(&sys.a, &bj, &Mat::from_fn(sys.nx(), 1, |r, _| sys.c[(i, r)]));
    let (a2t, c2t, b2) = krylov_part(&a1.transpose().to_owned(), &c1t, &b1);
    let a2 = a2t.transpose().to_owned();
    let n = a2.nrows();
    let sub = StateSpace::new(
        a2.clone(),
        b2.clone(),
        c2t.transpose().to_owned(),
        Mat::from_fn(1, 1, |_, _| sys.d[(i, j)]),
        sys.dt,
    )?;
    let mut z = zeros(&sub)?;
    let mut p = poles(&sub)?;
    // Remove decoupling zeros: each zero that matches a pole to 1e-8 relative cancels it.
    let mut kept = Vec::new();
    for zz in z.drain(..) {
        match p.iter().position(|pp| (pp - zz).norm() <= 1e-8 * (1.0 + zz.norm())) {
            Some(k) => {
                p.remove(k);
            }
            None => kept.push(zz),
        }
    }
    let z = kept;
    // Gain from one evaluation at a point away from every pole and zero.
    let r = p.iter().chain(&z).map(|x| x.norm()).fold(1.0, f64::max);
    let s0 = c64::new(0.37 * r, 1.3 * r);
    let m = Mat::<c64>::from_fn(n, n, |a, b| if a == b { s0 } else { c64::new(0.0, 0.0) } - a2[(a, b)]);
    let bc = Mat::<c64>::from_fn(n, 1, |r, _| c64::new(b2[(r, 0)], 0.0));
    let x = m.partial_piv_lu().solve(&bc);
    let mut g = c64::new(sys.d[(i, j)], 0.0);
    for q in 0..n {
        g += c2t[(q, 0)] * x[(q, 0)];
    }
    let zp: c64 = z.iter().map(|zz| s0 - zz).product();
    let pp: c64 = p.iter().map(|x| s0 - x).product();
    let k = (g * pp / zp).re;
    if g.norm() == 0.0 || !k.is_finite() {
        return Ok((Vec::new(), Vec::new(), 0.0));
    }
    Ok((z, p, k))
}

/// Restriction of (A, b, c) to the Krylov space of (A, b), the controllable subspace of a single
/// input: an orthonormal basis by Arnoldi with full re-orthogonalization, stopped when the new
/// direction is below n·1e-13 of the data scale (the rank tolerance of SLICOT AB01ND is n·ε·‖[A B]‖). Returns (QᵀAQ, Qᵀb, Qᵀc) with c given as a column.
fn krylov_part(a: &Mat<f64>, b: &Mat<f64>, c: &Mat<f64>) -> (Mat<f64>, Mat<f64>, Mat<f64>) {
    let n = a.nrows();
    let scale = a.norm_l2().max(b.norm_l2()).max(f64::MIN_POSITIVE);
    let mut q: Vec<Vec<f64>> = Vec::new();
    let mut v: Vec<f64> = (0..n).map(|r| b[(r, 0)]).collect();
    while q.len() < n {
        for _ in 0..2 {
            for qk in &q {
                let h: f64 = qk.iter().zip(&v).map(|(x, y)| x * y).sum();
                v.iter_mut().zip(qk).for_each(|(x, y)| *x -= h * y);
            }
        }
        let nv = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if nv <= 1e-13 * n as f64 * scale {
            break;
        }
        let qn: Vec<f64> = v.iter().map(|x| x / nv).collect();
        v = (0..n).map(|r| (0..n).map(|k| a[(r, k)] * qn[k]).sum()).collect();
        q.push(qn);
    }
    let k = q.len();
    let qm = Mat::<f64>::from_fn(n, k, |r, s| q[s][r]);
    (qm.transpose() * a * &qm, qm.transpose() * b, qm.transpose() * c)
}

/// Transfer-function form of a state-space model, entry by entry from its zeros, poles and gain
/// (not the Leverrier recursion, which loses accuracy beyond a few states); delays are kept.
pub fn ss_to_tf(sys: &StateSpace) -> Result<TransferFunction> {
    let (ny, nu) = (sys.ny(), sys.nu());
    let mut num = vec![vec![Poly::zero(); nu]; ny];
    let mut den = vec![vec![Poly::one(); nu]; ny];
    for i in 0..ny {
        for j in 0..nu {
            let (z, p, k) = ss_entry_zpk(sys, i, j)?;
            num[i][j] = Poly::from_roots(&z).scale(k);
            den[i][j] = Poly::from_roots(&p);
        }
    }
    let mut tf = TransferFunction::new(num, den, sys.dt)?;
    tf.input_delay = sys.input_delay.clone();
    tf.output_delay = sys.output_delay.clone();
    Ok(tf)
}

/// (A, B, C, D) of one SISO entry.
pub(crate) type Realization = (Mat<f64>, Mat<f64>, Mat<f64>, f64);

/// Splits an [output][input] delay matrix into per-input plus per-output delays when possible.
fn split_io_delays(io: &[Vec<f64>]) -> Result<(Vec<f64>, Vec<f64>)> {
    let ny = io.len();
    let nu = io.first().map_or(0, |r| r.len());
    // Take the smallest delay of each column as an input delay, the rest per row as output delay.
    let col_min: Vec<f64> = (0..nu)
        .map(|j| (0..ny).map(|i| io[i][j]).fold(f64::INFINITY, f64::min))
        .map(|t| if t.is_finite() { t } else { 0.0 })
        .collect();
    let row_rest: Vec<f64> = (0..ny)
        .map(|i| (0..nu).map(|j| io[i][j] - col_min[j]).fold(0.0, f64::max))
        .collect();
    for i in 0..ny {
        for j in 0..nu {
            let t = col_min[j] + row_rest[i];
            if (t - io[i][j]).abs() > 1e-12 * io[i][j].abs().max(1e-300) {
                return Err(LtiError::Unsupported(format!(
                    "entry delays cannot be written as input plus output delays (entry ({i},{j}))"
                )));
            }
        }
    }
    Ok((col_min, row_rest))
}

/// Removes roots shared (to rounding) by numerator and denominator; returns the inputs unchanged
/// when there are none, so coefficients are only rebuilt from roots when a cancellation happens.
pub fn cancel_common_roots(num: &Poly, den: &Poly) -> Result<(Poly, Poly)> {
    cancel_within(num, den, 1e-10)
}

/// `cancel_common_roots` with a relative root-distance tolerance.
fn cancel_within(num: &Poly, den: &Poly, tol: f64) -> Result<(Poly, Poly)> {
    if num.is_zero() {
        return Ok((Poly::zero(), Poly::one()));
    }
    if num.degree() == 0 || den.degree() == 0 {
        return Ok((num.clone(), den.clone()));
    }
    let zr = num.roots()?;
    let mut pr = den.roots()?;
    let mut kept_z = Vec::new();
    let mut cancelled = false;
    for z in zr {
        let hit = pr.iter().position(|p| (p - z).norm() <= tol * (1.0 + z.norm()));
        match hit {
            Some(k) => {
                pr.remove(k);
                cancelled = true;
            }
            None => kept_z.push(z),
        }
    }
    if !cancelled {
        return Ok((num.clone(), den.clone()));
    }
    Ok((
        Poly::from_roots(&kept_z).scale(num.leading()),
        Poly::from_roots(&pr).scale(den.leading()),
    ))
}

/// Scaled controllable canonical realization (A, B, C, D) of a proper SISO `num/den`.
pub(crate) fn siso_realization(num: &Poly, den: &Poly) -> Realization {
    let (num, den) = cancel_common_roots(num, den).unwrap_or_else(|_| (num.clone(), den.clone()));
    let n = den.degree();
    let lead = den.leading();
    let a_coef: Vec<f64> = (1..=n).map(|k| den.coeffs[k] / lead).collect();
    // Numerator padded to degree n, normalized by the denominator's leading coefficient.
    let b_coef: Vec<f64> = (0..=n).map(|k| num.coeff_of_power(n - k) / lead).collect();
    let d = b_coef[0];
    if n == 0 {
        return (Mat::zeros(0, 0), Mat::zeros(0, 1), Mat::zeros(1, 0), d);
    }
    // Similarity scaling by powers of two of the characteristic frequency w: state k is divided by
    // w^k so every entry of A is of order w (exact in floating point).
    let w = (1..=n)
        .map(|k| a_coef[k - 1].abs().powf(1.0 / k as f64))
        .fold(0.0, f64::max);
    let w = if w > 0.0 && w.is_finite() {
        2f64.powi(w.log2().round() as i32)
    } else {
        1.0
    };
    let a = Mat::<f64>::from_fn(n, n, |i, j| {
        if i == 0 {
            -a_coef[j] / w.powi(j as i32)
        } else if i == j + 1 {
            w
        } else {
            0.0
        }
    });
    let mut b = Mat::<f64>::zeros(n, 1);
    b[(0, 0)] = 1.0;
    let c = Mat::<f64>::from_fn(1, n, |_, j| (b_coef[j + 1] - d * a_coef[j]) / w.powi(j as i32));
    (a, b, c, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn common_roots_cancel() {
        // (s+1)(s+2) / ((s+1)(s+3)) = (s+2)/(s+3).
        let num = &Poly::new(vec![1.0, 1.0]) * &Poly::new(vec![1.0, 2.0]);
        let den = &Poly::new(vec![1.0, 1.0]) * &Poly::new(vec![1.0, 3.0]).scale(2.0);
        let tf = TransferFunction::siso(num, den, 0.0).unwrap();
        let ss = tf_to_ss(&tf).unwrap();
        assert_eq!(ss.nx(), 1);
        // D = lim s→∞ = 1/2 (leading coefficients 1 and 2).
        assert!((ss.d[(0, 0)] - 0.5).abs() < 1e-14);
    }

    #[test]
    fn mimo_blocks_match_entries() {
        let e = |n: Vec<f64>, d: Vec<f64>| (Poly::new(n), Poly::new(d));
        let (n1, d1) = e(vec![1.0], vec![1.0, 1.0]);
        let (n2, d2) = e(vec![2.0, 0.0], vec![1.0, 3.0, 9.0]);
        let (n3, d3) = e(vec![0.0], vec![1.0]);
        let (n4, d4) = e(vec![1.0, 5.0], vec![1.0, 5.0, 0.0]);
        let mut tf =
            TransferFunction::new(vec![vec![n1, n2], vec![n3, n4]], vec![vec![d1, d2], vec![d3, d4]], 0.0).unwrap();
        tf.io_delay = vec![vec![0.1, 0.2], vec![0.1, 0.2]];
        let ss = tf_to_ss(&tf).unwrap();
        assert_eq!(ss.input_delay, vec![0.1, 0.2]);
        let s = c64::new(0.3, 2.0);
        let g = tf.eval(s);
        let n = ss.nx();
        use faer::linalg::solvers::Solve;
        let m = Mat::<c64>::from_fn(n, n, |i, j| if i == j { s } else { c64::new(0.0, 0.0) } - ss.a[(i, j)]);
        let b = Mat::<c64>::from_fn(n, 2, |i, j| c64::new(ss.b[(i, j)], 0.0));
        let x = m.partial_piv_lu().solve(&b);
        let back = ss_to_tf(&ss).unwrap();
        for i in 0..2 {
            for j in 0..2 {
                let mut h = c64::new(ss.d[(i, j)], 0.0);
                for k in 0..n {
                    h += ss.c[(i, k)] * x[(k, j)];
                }
                h *= (-s * ss.input_delay[j]).exp();
                assert!((h - g[(i, j)]).norm() < 1e-12 * (1.0 + g[(i, j)].norm()), "({i},{j})");
                // The block realization is not minimal per entry; ss_to_tf must still give G.
                let hb = back.eval(s)[(i, j)];
                assert!(
                    (hb - g[(i, j)]).norm() < 1e-9 * (1.0 + g[(i, j)].norm()),
                    "tf ({i},{j}): {hb} vs {}",
                    g[(i, j)]
                );
                assert!(
                    back.den[i][j].degree() <= tf.den[i][j].degree(),
                    "({i},{j}) not minimal"
                );
            }
        }
    }

    #[test]
    fn improper_is_error() {
        let tf = TransferFunction::siso(Poly::new(vec![1.0, 0.0, 0.0]), Poly::new(vec![1.0, 1.0]), 0.0).unwrap();
        assert!(matches!(tf_to_ss(&tf), Err(LtiError::Unsupported(_))));
    }
}
