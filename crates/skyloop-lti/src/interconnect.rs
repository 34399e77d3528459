//! Interconnection of state-space models: series, parallel, feedback, append, lower/upper LFT.
//!
//! Delays stay exact where the result is still a delayed state-space model (delays on external
//! channels, or a uniform delay between two models in series); a delay inside a feedback loop has no
//! finite-dimensional form, so it is an error (replace it by `StateSpace::pade` first).

use crate::error::{LtiError, Result};
use crate::ss::StateSpace;
use faer::linalg::solvers::Solve;
use faer::Mat;

fn same_dt(a: &StateSpace, b: &StateSpace) -> Result<f64> {
    if a.dt != b.dt {
        return Err(LtiError::InvalidArgument(format!(
            "sample times differ: {} s and {} s",
            a.dt, b.dt
        )));
    }
    Ok(a.dt)
}

/// Copies `src` into `dst` at (r, c).
fn put(dst: &mut Mat<f64>, r: usize, c: usize, src: &Mat<f64>) {
    for j in 0..src.ncols() {
        for i in 0..src.nrows() {
            dst[(r + i, c + j)] = src[(i, j)];
        }
    }
}

/// Block-diagonal combination: inputs and outputs of `g1` first, then of `g2` (MATLAB `append`).
pub fn append(g1: &StateSpace, g2: &StateSpace) -> Result<StateSpace> {
    let dt = same_dt(g1, g2)?;
    let (n1, n2) = (g1.nx(), g2.nx());
    let mut a = Mat::zeros(n1 + n2, n1 + n2);
    put(&mut a, 0, 0, &g1.a);
    put(&mut a, n1, n1, &g2.a);
    let mut b = Mat::zeros(n1 + n2, g1.nu() + g2.nu());
    put(&mut b, 0, 0, &g1.b);
    put(&mut b, n1, g1.nu(), &g2.b);
    let mut c = Mat::zeros(g1.ny() + g2.ny(), n1 + n2);
    put(&mut c, 0, 0, &g1.c);
    put(&mut c, g1.ny(), n1, &g2.c);
    let mut d = Mat::zeros(g1.ny() + g2.ny(), g1.nu() + g2.nu());
    put(&mut d, 0, 0, &g1.d);
    put(&mut d, g1.ny(), g1.nu(), &g2.d);
    StateSpace::new(a, b, c, d, dt)?.with_delays(
        [g1.input_delay.clone(), g2.input_delay.clone()].concat(),
        [g1.output_delay.clone(), g2.output_delay.clone()].concat(),
    )
}

/// `g2 · g1`: the outputs of `g1` drive the inputs of `g2` (MATLAB `series(g1, g2)`).
///
/// Delays on the connecting signals must be equal (then they move to the inputs of `g1`).
///
/// # Errors
/// Dimensions that do not match, different sample times, or unequal delays on the connecting signals.
///
/// # Examples
/// ```
/// use skyloop_lti::{expr::parse_model, interconnect::series};
/// let g = series(&parse_model("1/(s+1)")?, &parse_model("2")?)?;
/// assert!((skyloop_lti::poles_zeros::dcgain(&g)?[(0, 0)] - 2.0).abs() < 1e-12);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn series(g1: &StateSpace, g2: &StateSpace) -> Result<StateSpace> {
    let dt = same_dt(g1, g2)?;
    if g1.ny() != g2.nu() {
        return Err(LtiError::Dimension(format!(
            "series: the first model has {} outputs but the second has {} inputs",
            g1.ny(),
            g2.nu()
        )));
    }
    let mid: Vec<f64> = (0..g1.ny()).map(|k| g1.output_delay[k] + g2.input_delay[k]).collect();
    let tau = mid.first().copied().unwrap_or(0.0);
    if mid.iter().any(|&t| (t - tau).abs() > 1e-12 * tau.max(1e-300)) {
        return Err(LtiError::Unsupported(
            "series: unequal delays on the connecting signals have no exact state-space form".into(),
        ));
    }
    let (n1, n2) = (g1.nx(), g2.nx());
    let mut a = Mat::zeros(n1 + n2, n1 + n2);
    put(&mut a, 0, 0, &g1.a);
    put(&mut a, n1, n1, &g2.a);
    put(&mut a, n1, 0, &(&g2.b * &g1.c));
    let mut b = Mat::zeros(n1 + n2, g1.nu());
    put(&mut b, 0, 0, &g1.b);
    put(&mut b, n1, 0, &(&g2.b * &g1.d));
    let mut c = Mat::zeros(g2.ny(), n1 + n2);
    put(&mut c, 0, 0, &(&g2.d * &g1.c));
    put(&mut c, 0, n1, &g2.c);
    let d = &g2.d * &g1.d;
    let input_delay = g1.input_delay.iter().map(|t| t + tau).collect();
    StateSpace::new(a, b, c, d, dt)?.with_delays(input_delay, g2.output_delay.clone())
}

/// `g1 + g2` (same inputs, outputs summed); both must carry the same input and output delays.
pub fn parallel(g1: &StateSpace, g2: &StateSpace) -> Result<StateSpace> {
    let dt = same_dt(g1, g2)?;
    if (g1.ny(), g1.nu()) != (g2.ny(), g2.nu()) {
        return Err(LtiError::Dimension(format!(
            "parallel: {}x{} and {}x{} models",
            g1.ny(),
            g1.nu(),
            g2.ny(),
            g2.nu()
        )));
    }
    if g1.input_delay != g2.input_delay || g1.output_delay != g2.output_delay {
        return Err(LtiError::Unsupported(
            "parallel: the two models have different delays; their sum has no exact state-space form".into(),
        ));
    }
    let (n1, n2) = (g1.nx(), g2.nx());
    let mut a = Mat::zeros(n1 + n2, n1 + n2);
    put(&mut a, 0, 0, &g1.a);
    put(&mut a, n1, n1, &g2.a);
    let mut b = Mat::zeros(n1 + n2, g1.nu());
    put(&mut b, 0, 0, &g1.b);
    put(&mut b, n1, 0, &g2.b);
    let mut c = Mat::zeros(g1.ny(), n1 + n2);
    put(&mut c, 0, 0, &g1.c);
    put(&mut c, 0, n1, &g2.c);
    let d = &g1.d + &g2.d;
    StateSpace::new(a, b, c, d, dt)?.with_delays(g1.input_delay.clone(), g1.output_delay.clone())
}

/// Closes constant loops around `base`: its inputs are `v = K·y + E·w`, the result's outputs `Sz·y`.
///
/// Fails when `I − K·D` is singular (an ill-posed algebraic loop).
fn close_loops(base: &StateSpace, k: &Mat<f64>, e: &Mat<f64>, sz: &Mat<f64>) -> Result<StateSpace> {
    let nv = base.nu();
    let ikd = Mat::<f64>::from_fn(nv, nv, |i, j| f64::from(u8::from(i == j))) - k * &base.d;
    let lu = ikd.full_piv_lu();
    // Reject ill-posed loops by a reciprocal-condition estimate from the LU pivots.
    let u = lu.U();
    let (mut big, mut small) = (0.0f64, f64::INFINITY);
    for i in 0..nv {
        big = big.max(u[(i, i)].abs());
        small = small.min(u[(i, i)].abs());
    }
    if nv > 0 && (small <= 1e-13 * big.max(1.0) || !small.is_finite()) {
        return Err(LtiError::Unsupported(
            "the interconnection is not well posed: I - K*D (algebraic loop) is singular".into(),
        ));
    }
    let fk = lu.solve(k);
    let fe = lu.solve(e);
    let a = &base.a + &base.b * &fk * &base.c;
    let b = &base.b * &fe;
    let c = sz * (&base.c + &base.d * &fk * &base.c);
    let d = sz * &base.d * &fe;
    StateSpace::new(a, b, c, d, base.dt)
}

fn zeros_like_delays(g: &StateSpace, what: &str) -> Result<()> {
    if g.has_delay() {
        return Err(LtiError::Unsupported(format!(
            "{what}: a delay inside a feedback loop has no exact state-space form (use pade first)"
        )));
    }
    Ok(())
}

/// Closed loop `y = g1·(u + sign·g2·y)`; `sign = -1.0` is negative feedback (MATLAB `feedback`).
///
/// # Errors
/// Dimensions that do not match, an algebraic loop (I − sign·D₁D₂ singular), or delays inside the loop.
///
/// # Examples
/// ```
/// use skyloop_lti::{expr::parse_model, interconnect::feedback};
/// // 1/s closed by unity negative feedback is 1/(s+1).
/// let t = feedback(&parse_model("1/s")?, &parse_model("1")?, -1.0)?;
/// assert!((skyloop_lti::poles_zeros::poles(&t)?[0].re + 1.0).abs() < 1e-12);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn feedback(g1: &StateSpace, g2: &StateSpace, sign: f64) -> Result<StateSpace> {
    let dt = same_dt(g1, g2)?;
    if sign != 1.0 && sign != -1.0 {
        return Err(LtiError::InvalidArgument(format!(
            "feedback sign must be +1 or -1, got {sign}"
        )));
    }
    if g2.nu() != g1.ny() || g2.ny() != g1.nu() {
        return Err(LtiError::Dimension(format!(
            "feedback: forward path is {}x{}, feedback path must be {}x{} but is {}x{}",
            g1.ny(),
            g1.nu(),
            g1.nu(),
            g1.ny(),
            g2.ny(),
            g2.nu()
        )));
    }
    zeros_like_delays(g1, "feedback")?;
    zeros_like_delays(g2, "feedback")?;
    let base = append(g1, g2)?;
    let (nu1, ny1) = (g1.nu(), g1.ny());
    // Inputs v = [e; r2], outputs y = [y1; y2]: e = u + sign·y2, r2 = y1.
    let k = Mat::<f64>::from_fn(nu1 + ny1, ny1 + nu1, |i, j| {
        if i < nu1 && j == ny1 + i {
            sign
        } else if i >= nu1 && j == i - nu1 {
            1.0
        } else {
            0.0
        }
    });
    let e = Mat::<f64>::from_fn(nu1 + ny1, nu1, |i, j| f64::from(u8::from(i == j)));
    let sz = Mat::<f64>::from_fn(ny1, ny1 + nu1, |i, j| f64::from(u8::from(i == j)));
    let mut out = close_loops(&base, &k, &e, &sz)?;
    out.dt = dt;
    Ok(out)
}

/// Lower LFT `F_l(P, K)`: the last `K.nu()` outputs of P drive K, whose outputs drive the last
/// `K.ny()` inputs of P (MATLAB `lft(P, K)`, the hinfsyn convention u = K·y).
///
/// Delays on P's remaining (external) channels are kept; delays in the loop are an error.
pub fn lft_lower(p: &StateSpace, k: &StateSpace) -> Result<StateSpace> {
    same_dt(p, k)?;
    let (nu_k, ny_k) = (k.ny(), k.nu()); // P's control inputs and measured outputs
    if nu_k > p.nu() || ny_k > p.ny() {
        return Err(LtiError::Dimension(format!(
            "lft_lower: K is {}x{} but P has only {} inputs and {} outputs",
            k.ny(),
            k.nu(),
            p.nu(),
            p.ny()
        )));
    }
    let (nw, nz) = (p.nu() - nu_k, p.ny() - ny_k);
    star(p, k, nw, nz, true)
}

/// Upper LFT `F_u(P, Δ)`: the first `Δ.nu()` outputs of P drive Δ, whose outputs drive the first
/// `Δ.ny()` inputs of P (MATLAB `lft(Δ, P)`; note P comes first here).
pub fn lft_upper(p: &StateSpace, delta: &StateSpace) -> Result<StateSpace> {
    same_dt(p, delta)?;
    if delta.ny() > p.nu() || delta.nu() > p.ny() {
        return Err(LtiError::Dimension(format!(
            "lft_upper: Δ is {}x{} but P has only {} inputs and {} outputs",
            delta.ny(),
            delta.nu(),
            p.nu(),
            p.ny()
        )));
    }
    star(p, delta, delta.ny(), delta.nu(), false)
}

/// Shared LFT. `lower`: P's first `n1` inputs and `n2` outputs stay external and the rest are closed
/// by `k`; otherwise P's first `n1` inputs and `n2` outputs are closed and the rest stay external.
fn star(p: &StateSpace, k: &StateSpace, n1: usize, n2: usize, lower: bool) -> Result<StateSpace> {
    // Channel index sets of P: external (kept) and loop (closed by k).
    let (ext_in, loop_in): (Vec<usize>, Vec<usize>) = if lower {
        ((0..n1).collect(), (n1..p.nu()).collect())
    } else {
        ((n1..p.nu()).collect(), (0..n1).collect())
    };
    let (ext_out, loop_out): (Vec<usize>, Vec<usize>) = if lower {
        ((0..n2).collect(), (n2..p.ny()).collect())
    } else {
        ((n2..p.ny()).collect(), (0..n2).collect())
    };
    if loop_in.iter().any(|&j| p.input_delay[j] > 0.0) || loop_out.iter().any(|&i| p.output_delay[i] > 0.0) {
        return Err(LtiError::Unsupported(
            "lft: delays on the closed channels of P have no exact state-space form (use pade first)".into(),
        ));
    }
    zeros_like_delays(k, "lft")?;
    let pd = StateSpace::new(p.a.clone(), p.b.clone(), p.c.clone(), p.d.clone(), p.dt)?;
    let base = append(&pd, k)?;
    let (pnu, pny) = (p.nu(), p.ny());
    let nv = pnu + k.nu();
    let ny = pny + k.ny();
    // v = [P inputs; K inputs]; y = [P outputs; K outputs].
    let mut km = Mat::<f64>::zeros(nv, ny);
    for (r, &j) in loop_in.iter().enumerate() {
        km[(j, pny + r)] = 1.0; // P loop input ← K output r
    }
    for (r, &i) in loop_out.iter().enumerate() {
        km[(pnu + r, i)] = 1.0; // K input r ← P loop output
    }
    let mut e = Mat::<f64>::zeros(nv, ext_in.len());
    for (c, &j) in ext_in.iter().enumerate() {
        e[(j, c)] = 1.0;
    }
    let mut sz = Mat::<f64>::zeros(ext_out.len(), ny);
    for (r, &i) in ext_out.iter().enumerate() {
        sz[(r, i)] = 1.0;
    }
    let out = close_loops(&base, &km, &e, &sz)?;
    let in_d = ext_in.iter().map(|&j| p.input_delay[j]).collect();
    let out_d = ext_out.iter().map(|&i| p.output_delay[i]).collect();
    out.with_delays(in_d, out_d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::parse_model;
    use faer::c64;

    /// Transfer matrix C (sI − A)⁻¹ B + D at s (delays ignored), by a dense complex solve.
    fn tfm(g: &StateSpace, s: c64) -> Mat<c64> {
        let n = g.nx();
        let m = Mat::<c64>::from_fn(n, n, |i, j| if i == j { s } else { c64::new(0.0, 0.0) } - g.a[(i, j)]);
        let b = Mat::<c64>::from_fn(n, g.nu(), |i, j| c64::new(g.b[(i, j)], 0.0));
        let x = m.partial_piv_lu().solve(&b);
        Mat::<c64>::from_fn(g.ny(), g.nu(), |i, j| {
            let mut h = c64::new(g.d[(i, j)], 0.0);
            for k in 0..n {
                h += g.c[(i, k)] * x[(k, j)];
            }
            h
        })
    }

    fn close(a: c64, b: c64) -> bool {
        (a - b).norm() <= 1e-11 * (1.0 + b.norm())
    }

    #[test]
    fn siso_formulas() {
        let g1 = parse_model("(s+3)/(s^2+2*s+5)").unwrap();
        let g2 = parse_model("4/(s+7) + 0.5").unwrap();
        let s = c64::new(0.2, 1.3);
        let (h1, h2) = (tfm(&g1, s)[(0, 0)], tfm(&g2, s)[(0, 0)]);
        assert!(close(tfm(&series(&g1, &g2).unwrap(), s)[(0, 0)], h1 * h2));
        assert!(close(tfm(&parallel(&g1, &g2).unwrap(), s)[(0, 0)], h1 + h2));
        let one = c64::new(1.0, 0.0);
        assert!(close(
            tfm(&feedback(&g1, &g2, -1.0).unwrap(), s)[(0, 0)],
            h1 / (one + h1 * h2)
        ));
        assert!(close(
            tfm(&feedback(&g1, &g2, 1.0).unwrap(), s)[(0, 0)],
            h1 / (one - h1 * h2)
        ));
        let ap = append(&g1, &g2).unwrap();
        let h = tfm(&ap, s);
        assert!(close(h[(0, 0)], h1) && close(h[(1, 1)], h2) && h[(0, 1)].norm() == 0.0);
    }

    #[test]
    fn lfts_match_formulas() {
        // P = [[P11, P12],[P21, P22]] as a 2x2 block model built by append + feedthrough mixing.
        let p = StateSpace::from_rows(
            &[vec![-1.0, 2.0], vec![0.0, -3.0]],
            &[vec![1.0, 0.5], vec![0.3, 1.0]],
            &[vec![1.0, 0.0], vec![0.2, 1.0]],
            &[vec![0.1, 0.4], vec![0.7, 0.2]],
            0.0,
        )
        .unwrap();
        let k = parse_model("2/(s+4)").unwrap();
        let s = c64::new(0.0, 0.8);
        let hp = tfm(&p, s);
        let hk = tfm(&k, s)[(0, 0)];
        let one = c64::new(1.0, 0.0);
        let want_l = hp[(0, 0)] + hp[(0, 1)] * hk * hp[(1, 0)] / (one - hp[(1, 1)] * hk);
        assert!(close(tfm(&lft_lower(&p, &k).unwrap(), s)[(0, 0)], want_l));
        let want_u = hp[(1, 1)] + hp[(1, 0)] * hk * hp[(0, 1)] / (one - hp[(0, 0)] * hk);
        assert!(close(tfm(&lft_upper(&p, &k).unwrap(), s)[(0, 0)], want_u));
    }

    #[test]
    fn errors() {
        let g = parse_model("1/(s+1)").unwrap();
        let g2 = StateSpace::gain(Mat::from_fn(2, 1, |_, _| 1.0), 0.0).unwrap();
        assert!(matches!(series(&g2, &g), Err(LtiError::Dimension(_))));
        // Unity positive feedback around a unit gain: I - D1 D2 = 0.
        let one = StateSpace::gain(Mat::identity(1, 1), 0.0).unwrap();
        assert!(matches!(feedback(&one, &one, 1.0), Err(LtiError::Unsupported(_))));
        let del = parse_model("exp(-0.1*s)/(s+1)").unwrap();
        assert!(feedback(&del, &g, -1.0).is_err());
        // A delay in series is exact: it moves to the input.
        let sr = series(&g, &del).unwrap();
        assert_eq!(sr.input_delay, vec![0.1]);
        let mut gd = g.clone();
        gd.dt = 0.01;
        assert!(series(&g, &gd).is_err());
    }
}
