//! Continuous ↔ discrete conversion: zoh, foh, tustin (with prewarp), matched; d2c for zoh and tustin.
//!
//! State-space formulas follow scipy's `cont2discrete` (as python-control's `sample_system`), so
//! matrices compare one to one; delays become whole sample delays, and for zoh a fractional input
//! delay is exact through one extra state per delayed input (Franklin–Powell, modified z-transform).

use crate::error::{LtiError, Result};
use crate::poles_zeros::{dcgain, poles, zeros};
use crate::ss::StateSpace;
use crate::zpk::{zpk_sections_ss, Zpk};
use faer::linalg::solvers::Solve;
use faer::{c64, Mat};
use skyloop_linalg::expm::expm;
use skyloop_linalg::logm::{has_no_real_logarithm, logm};

/// Discretization method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    /// Zero-order hold on the inputs (exact for piecewise-constant inputs).
    Zoh,
    /// First-order (triangle) hold.
    Foh,
    /// Bilinear transform; `prewarp_rad_s` makes the match exact at that frequency.
    Tustin {
        /// Frequency in rad/s where the continuous and discrete responses agree exactly.
        prewarp_rad_s: Option<f64>,
    },
    /// Pole-zero matching (SISO), gain matched at DC (python-control convention).
    Matched,
}

impl std::str::FromStr for Method {
    type Err = LtiError;
    fn from_str(s: &str) -> Result<Method> {
        match s.to_ascii_lowercase().as_str() {
            "zoh" => Ok(Method::Zoh),
            "foh" => Ok(Method::Foh),
            "tustin" | "bilinear" => Ok(Method::Tustin { prewarp_rad_s: None }),
            "matched" => Ok(Method::Matched),
            other => Err(LtiError::InvalidArgument(format!(
                "unknown discretization method '{other}' (expected zoh, foh, tustin or matched)"
            ))),
        }
    }
}

fn block(m: &Mat<f64>, r0: usize, c0: usize, r: usize, c: usize) -> Mat<f64> {
    Mat::from_fn(r, c, |i, j| m[(r0 + i, c0 + j)])
}

/// e^M for a block upper-triangular M = [[M₁₁, M₁₂], [0, N]] whose n×n block M₁₁ comes first and
/// whose trailing block N is nilpotent with N² = 0 (the hold blocks of zoh and foh), so e^{Nt} =
/// I + N·t exactly. M is scaled to norm ≤ 1, exponentiated, and squared back with the trailing block
/// reset to its exact value after each squaring: a plain expm carries the Padé rounding of that block
/// (1 − ε on its diagonal) into (1 − ε)^(2^k), which at dt·‖A‖ = 1e20 drove the zoh input matrix
/// of 1/(s+1) to 0 instead of 1.
fn expm_hold(m: &Mat<f64>, n: usize) -> Result<Mat<f64>> {
    let size = (0..m.ncols())
        .map(|j| m.col(j).iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    if !size.is_finite() {
        return Err(LtiError::InvalidArgument(
            "the sample time times the model's coefficients overflows the floating-point range".into(),
        ));
    }
    let k = if size > 1.0 { size.log2().ceil() as i32 } else { 0 };
    let mut t = 2f64.powi(-k);
    let mut e = expm((m * faer::Scale(t)).as_ref())?;
    let r = m.nrows() - n;
    for _ in 0..k {
        e = &e * &e;
        t *= 2.0;
        for i in 0..r {
            for j in 0..m.ncols() {
                let exact = if j < n {
                    0.0
                } else {
                    f64::from(u8::from(i == j - n)) + m[(n + i, j)] * t
                };
                e[(n + i, j)] = exact;
            }
        }
    }
    Ok(e)
}

/// (e^{A s}, ∫₀ˢ e^{Aη} dη · B) from the exponential of the block matrix [[A, B], [0, 0]]·s.
fn zoh_pair(a: &Mat<f64>, b: &Mat<f64>, s: f64) -> Result<(Mat<f64>, Mat<f64>)> {
    let (n, m) = (a.nrows(), b.ncols());
    let em = Mat::<f64>::from_fn(n + m, n + m, |i, j| {
        if i < n && j < n {
            a[(i, j)] * s
        } else if i < n {
            b[(i, j - n)] * s
        } else {
            0.0
        }
    });
    let e = expm_hold(&em, n)?;
    Ok((block(&e, 0, 0, n, n), block(&e, 0, n, n, m)))
}

/// Number of whole samples in `t_s` when it is a multiple of `dt` (to 1e-9 relative), else None.
fn whole_samples(t_s: f64, dt: f64) -> Option<usize> {
    let r = t_s / dt;
    ((r - r.round()).abs() <= 1e-9 * r.abs().max(1.0)).then(|| r.round() as usize)
}

/// Discretizes a continuous model with sample time `dt` seconds.
///
/// # Errors
/// A discrete model, a non-positive `dt`, or a method that does not apply (matched on a MIMO model).
///
/// # Examples
/// ```
/// use skyloop_lti::discretize::{c2d, Method};
/// // Zero-order hold of 1/(s+1) at 0.1 s: x⁺ = e^{−0.1}·x + (1 − e^{−0.1})·u.
/// let g = skyloop_lti::expr::parse_model("1/(s+1)")?;
/// let d = c2d(&g, 0.1, Method::Zoh)?;
/// assert!((d.a[(0, 0)] - (-0.1f64).exp()).abs() < 1e-12);
/// assert_eq!(d.dt, 0.1);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn c2d(sys: &StateSpace, dt: f64, method: Method) -> Result<StateSpace> {
    if !sys.is_continuous() {
        return Err(LtiError::InvalidArgument("c2d needs a continuous-time model".into()));
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(LtiError::InvalidArgument(format!(
            "sample time must be finite and > 0, got {dt}"
        )));
    }
    // A common output delay (and any output delay of a single-output model) commutes to the inputs.
    let mut sys = sys.clone();
    let out0 = sys.output_delay.first().copied().unwrap_or(0.0);
    if sys.output_delay.iter().all(|&t| t == out0) && out0 > 0.0 {
        for t in sys.input_delay.iter_mut() {
            *t += out0;
        }
        sys.output_delay.iter_mut().for_each(|t| *t = 0.0);
    }
    let frac: Vec<(usize, f64)> = sys
        .input_delay
        .iter()
        .enumerate()
        .filter(|(_, &t)| whole_samples(t, dt).is_none())
        .map(|(j, &t)| (j, t))
        .collect();
    if sys.output_delay.iter().any(|&t| whole_samples(t, dt).is_none()) {
        return Err(LtiError::Unsupported(format!(
            "c2d: output delays {:?} s are not whole multiples of dt = {dt} s",
            sys.output_delay
        )));
    }
    if !frac.is_empty() && method != Method::Zoh {
        return Err(LtiError::Unsupported(format!(
            "c2d: input delays {:?} s are not whole multiples of dt = {dt} s; only zoh handles fractional delays exactly",
            sys.input_delay
        )));
    }
    let delay_free = StateSpace::new(sys.a.clone(), sys.b.clone(), sys.c.clone(), sys.d.clone(), 0.0)?;
    if !frac.is_empty() {
        return zoh_fractional(&sys, dt);
    }
    let d = match method {
        Method::Zoh => {
            let (ad, bd) = zoh_pair(&sys.a, &sys.b, dt)?;
            StateSpace::new(ad, bd, sys.c.clone(), sys.d.clone(), dt)?
        }
        Method::Foh => foh(&delay_free, dt)?,
        Method::Tustin { prewarp_rad_s } => {
            let tw = match prewarp_rad_s {
                None => dt,
                Some(w) if w > 0.0 && w * dt < std::f64::consts::PI => 2.0 * (w * dt / 2.0).tan() / w,
                Some(w) => {
                    return Err(LtiError::InvalidArgument(format!(
                        "prewarp frequency must be in (0, π/dt) rad/s, got {w}"
                    )))
                }
            };
            bilinear(&delay_free, tw, dt)?
        }
        Method::Matched => matched(&delay_free, dt)?,
    };
    d.with_delays(sys.input_delay.clone(), sys.output_delay.clone())
}

/// Triangle hold (scipy `cont2discrete(method="foh")`).
fn foh(sys: &StateSpace, dt: f64) -> Result<StateSpace> {
    let (n, m) = (sys.nx(), sys.nu());
    let em = Mat::<f64>::from_fn(n + 2 * m, n + 2 * m, |i, j| {
        if i < n && j < n {
            sys.a[(i, j)] * dt
        } else if i < n && j < n + m {
            sys.b[(i, j - n)] * dt
        } else if i >= n && i < n + m && j == i + m {
            1.0
        } else {
            0.0
        }
    });
    let e = expm_hold(&em, n)?;
    let ms11 = block(&e, 0, 0, n, n);
    let ms12 = block(&e, 0, n, n, m);
    let ms13 = block(&e, 0, n + m, n, m);
    let bd = &ms12 - &ms13 + &ms11 * &ms13;
    let dd = &sys.d + &sys.c * &ms13;
    StateSpace::new(ms11, bd, sys.c.clone(), dd, dt)
}

/// Bilinear transform with effective period `tw` (= dt, or the prewarped 2·tan(ωdt/2)/ω).
fn bilinear(sys: &StateSpace, tw: f64, dt: f64) -> Result<StateSpace> {
    let n = sys.nx();
    let eye = Mat::<f64>::identity(n, n);
    let ima = &eye - &sys.a * faer::Scale(tw / 2.0);
    let lu = ima.full_piv_lu();
    check_regular(&lu, n, "tustin: I - A·dt/2 is singular (pole at s = 2/dt)")?;
    let ad = lu.solve(&eye + &sys.a * faer::Scale(tw / 2.0));
    let bd = lu.solve(&sys.b * faer::Scale(tw));
    let cd = lu.solve_transpose(sys.c.transpose()).transpose().to_owned();
    let dd = &sys.d + &sys.c * &bd * faer::Scale(0.5);
    StateSpace::new(ad, bd, cd, dd, dt)
}

fn check_regular(lu: &faer::linalg::solvers::FullPivLu<f64>, n: usize, what: &str) -> Result<()> {
    let u = lu.U();
    let big = (0..n).map(|i| u[(i, i)].abs()).fold(0.0, f64::max);
    let small = (0..n).map(|i| u[(i, i)].abs()).fold(f64::INFINITY, f64::min);
    if n > 0 && small <= 1e-14 * big.max(f64::MIN_POSITIVE) {
        return Err(LtiError::Numerical(what.into()));
    }
    Ok(())
}

/// Pole-zero matching for SISO models: z = e^{sT} for every finite pole and zero, DC gain matched
/// (for a pole at s = 0 the gain is matched at the real point s₀ = 0.1/dt instead).
pub fn matched_zpk(sys: &StateSpace, dt: f64) -> Result<Zpk> {
    if sys.nu() != 1 || sys.ny() != 1 {
        return Err(LtiError::Unsupported(
            "matched discretization is defined for SISO models only".into(),
        ));
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(LtiError::InvalidArgument(format!(
            "sample time must be finite and > 0, got {dt}"
        )));
    }
    let z: Vec<c64> = zeros(sys)?.into_iter().map(|s| (s * dt).exp()).collect();
    let p: Vec<c64> = poles(sys)?.into_iter().map(|s| (s * dt).exp()).collect();
    // Evaluate the discrete gain in product form: expanded polynomials lose the digits of
    // factors (1 − e^{pT}) that are small when poles cluster near z = 1.
    let root_ratio = |x: f64| -> f64 {
        let zx = c64::new(x, 0.0);
        let n: c64 = z.iter().map(|r| zx - r).product();
        let d: c64 = p.iter().map(|r| zx - r).product();
        (n / d).re
    };
    let g0 = dcgain(sys)?[(0, 0)];
    let (gc, gd) = if g0.is_finite() && g0 != 0.0 {
        (g0, root_ratio(1.0))
    } else {
        let s0 = 0.1 / dt;
        let gc = eval_real(sys, s0)?;
        (gc, root_ratio((s0 * dt).exp()))
    };
    if gc == 0.0 || !gd.is_finite() || gd == 0.0 {
        return Err(LtiError::Numerical(
            "matched: cannot match the gain (zero or infinite)".into(),
        ));
    }
    let mut out = Zpk::siso(z, p, gc / gd, dt);
    out.input_delay = sys.input_delay.clone();
    out.output_delay = sys.output_delay.clone();
    Ok(out)
}

fn matched(sys: &StateSpace, dt: f64) -> Result<StateSpace> {
    let z = matched_zpk(sys, dt)?;
    zpk_sections_ss(&z.z[0][0], &z.p[0][0], z.k[0][0], dt)
}

/// C (s₀I − A)⁻¹ B + D at a real point s₀ for a SISO model.
fn eval_real(sys: &StateSpace, s0: f64) -> Result<f64> {
    let n = sys.nx();
    let m = Mat::<f64>::from_fn(n, n, |i, j| f64::from(u8::from(i == j)) * s0 - sys.a[(i, j)]);
    let x = m.full_piv_lu().solve(&sys.b);
    let g = (&sys.d + &sys.c * &x)[(0, 0)];
    if g.is_finite() {
        Ok(g)
    } else {
        Err(LtiError::Numerical(
            "matched: the model has a pole at the gain-matching point".into(),
        ))
    }
}

/// Converts a discrete model back to continuous time (zoh via the matrix logarithm, or tustin).
pub fn d2c(sys: &StateSpace, method: Method) -> Result<StateSpace> {
    if sys.is_continuous() {
        return Err(LtiError::InvalidArgument("d2c needs a discrete-time model".into()));
    }
    let dt = sys.dt;
    let (n, m) = (sys.nx(), sys.nu());
    let c = match method {
        Method::Zoh => {
            let big = Mat::<f64>::from_fn(n + m, n + m, |i, j| {
                if i < n && j < n {
                    sys.a[(i, j)]
                } else if i < n {
                    sys.b[(i, j - n)]
                } else {
                    f64::from(u8::from(i == j))
                }
            });
            // A pole at z = 0 or on the negative real axis has no real ZOH preimage (e^(A·dt) is
            // never singular, and a real logarithm of a negative eigenvalue does not exist): name
            // the pole and the way out instead of the matrix logarithm's words.
            if let Some(p) = crate::freqresp::balanced_eigenvalues(&sys.a)?
                .into_iter()
                .find(|&z| has_no_real_logarithm(z))
            {
                return Err(LtiError::InvalidArgument(format!(
                    "d2c zoh: the model has a pole at z = {:.6} (zero or negative real), which no continuous model has as its zero-order-hold equivalent; use --method tustin",
                    p.re
                )));
            }
            let l = logm(big.as_ref())? * faer::Scale(1.0 / dt);
            StateSpace::new(
                block(&l, 0, 0, n, n),
                block(&l, 0, n, n, m),
                sys.c.clone(),
                sys.d.clone(),
                0.0,
            )?
        }
        Method::Tustin { prewarp_rad_s } => {
            // Inverse bilinear: A = (2/T)(Ad + I)⁻¹(Ad − I), B = (2/T)... with T the effective period.
            let tw = match prewarp_rad_s {
                None => dt,
                Some(w) if w > 0.0 && w * dt < std::f64::consts::PI => 2.0 * (w * dt / 2.0).tan() / w,
                Some(w) => return Err(LtiError::InvalidArgument(format!("bad prewarp frequency {w} rad/s"))),
            };
            let eye = Mat::<f64>::identity(n, n);
            let ipa = &eye + &sys.a;
            let lu = ipa.full_piv_lu();
            check_regular(&lu, n, "d2c tustin: the model has a pole at z = -1")?;
            let k = 2.0 / tw;
            let a = lu.solve(&sys.a - &eye) * faer::Scale(k);
            // From Bd = (I − A·T/2)⁻¹·B·T: B = (I − A·T/2)·Bd / T, and D = Dd − C_c·... via Cd.
            let ima = &eye - &a * faer::Scale(tw / 2.0);
            let b = &ima * &sys.b * faer::Scale(1.0 / tw);
            let cc = &sys.c * &ima;
            let d = &sys.d - &cc * &sys.b * faer::Scale(0.5);
            StateSpace::new(a, b, cc, d, 0.0)?
        }
        _ => {
            return Err(LtiError::Unsupported("d2c supports the zoh and tustin methods".into()));
        }
    };
    c.with_delays(sys.input_delay.clone(), sys.output_delay.clone())
}

/// Zoh with fractional input delays: τ_j = d_j·dt + θ_j (0 < θ_j < dt) adds one state holding the
/// previous (integer-delayed) input j; the integer part stays as an input delay of d_j samples.
fn zoh_fractional(sys: &StateSpace, dt: f64) -> Result<StateSpace> {
    let (n, m, p) = (sys.nx(), sys.nu(), sys.ny());
    let (phi, gamma) = zoh_pair(&sys.a, &sys.b, dt)?;
    let mut extra = Vec::new(); // (input j, Γa column, Γb column)
    let mut int_delay = vec![0.0; m];
    let mut gb = gamma.clone();
    for j in 0..m {
        let t = sys.input_delay[j];
        if whole_samples(t, dt).is_some() {
            int_delay[j] = t;
            continue;
        }
        let d = (t / dt).floor();
        let theta = t - d * dt;
        int_delay[j] = d * dt;
        let bj = Mat::<f64>::from_fn(n, 1, |i, _| sys.b[(i, j)]);
        let (e_rest, g_rest) = zoh_pair(&sys.a, &bj, dt - theta)?;
        let (_, g_theta) = zoh_pair(&sys.a, &bj, theta)?;
        let ga = &e_rest * &g_theta;
        for i in 0..n {
            gb[(i, j)] = g_rest[(i, 0)];
        }
        extra.push((j, ga));
    }
    let ne = extra.len();
    let mut a = Mat::<f64>::zeros(n + ne, n + ne);
    let mut b = Mat::<f64>::zeros(n + ne, m);
    let mut c = Mat::<f64>::zeros(p, n + ne);
    let mut d = sys.d.clone();
    for i in 0..n {
        for k in 0..n {
            a[(i, k)] = phi[(i, k)];
        }
        for j in 0..m {
            b[(i, j)] = gb[(i, j)];
        }
    }
    for i in 0..p {
        for k in 0..n {
            c[(i, k)] = sys.c[(i, k)];
        }
    }
    for (e, (j, ga)) in extra.iter().enumerate() {
        for i in 0..n {
            a[(i, n + e)] = ga[(i, 0)];
        }
        b[(n + e, *j)] = 1.0;
        // At a sample instant the fractionally delayed input still equals the previous sample.
        for i in 0..p {
            c[(i, n + e)] = sys.d[(i, *j)];
            d[(i, *j)] = 0.0;
        }
    }
    StateSpace::new(a, b, c, d, dt)?.with_delays(int_delay, sys.output_delay.clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::parse_model;

    #[test]
    fn zoh_with_a_huge_sample_time_keeps_the_input_gain() {
        // 1/(s+1) held for dt: x⁺ = e^{−dt}·x + (1 − e^{−dt})·u, so b → 1 as dt grows.
        for dt in [10.0, 1e5, 1e10, 1e20, 1e100] {
            let g = crate::expr::parse_model("1/(s+1)").unwrap();
            let d = c2d(&g, dt, Method::Zoh).unwrap();
            let want_b = -(-dt).exp_m1();
            assert!(
                (d.b[(0, 0)] * d.c[(0, 0)] - want_b).abs() < 1e-12,
                "dt {dt:e}: b {}",
                d.b[(0, 0)]
            );
            assert!((d.a[(0, 0)] - (-dt).exp()).abs() < 1e-12);
            // Triangle hold: Γ₁ = 1 − e^{−T}, Γ₂ = (T − 1 + e^{−T})/T, b = Γ₁ − Γ₂ + e^{−T}·Γ₂, d = Γ₂.
            let f = c2d(&g, dt, Method::Foh).unwrap();
            let (g1, g2) = (-(-dt).exp_m1(), (dt + (-dt).exp_m1()) / dt);
            let (bd, dd) = (f.b[(0, 0)] * f.c[(0, 0)], f.d[(0, 0)]);
            let want_b = g1 - g2 + (-dt).exp() * g2;
            assert!(
                (dd - g2).abs() < 1e-12 && (bd - want_b).abs() < 1e-12,
                "foh dt {dt:e}: {bd} {dd}"
            );
        }
    }

    #[test]
    fn zoh_first_order_closed_form() {
        // 1/(s+1) with zoh: a_d = e^{-T}, b_d·c = 1 − e^{-T} (closed form).
        let g = parse_model("1/(s+1)").unwrap();
        let t = 0.1;
        let d = c2d(&g, t, Method::Zoh).unwrap();
        assert!((d.a[(0, 0)] - (-t).exp()).abs() < 1e-15);
        assert!((d.b[(0, 0)] * d.c[(0, 0)] - (1.0 - (-t).exp())).abs() < 1e-15);
        let back = d2c(&d, Method::Zoh).unwrap();
        assert!((back.a[(0, 0)] + 1.0).abs() < 1e-13);
        let tu = c2d(&g, t, Method::Tustin { prewarp_rad_s: None }).unwrap();
        let back = d2c(&tu, Method::Tustin { prewarp_rad_s: None }).unwrap();
        assert!((back.a[(0, 0)] - g.a[(0, 0)]).abs() < 1e-13);
        assert!((back.b[(0, 0)] * back.c[(0, 0)] - g.b[(0, 0)] * g.c[(0, 0)]).abs() < 1e-13);
        assert!((back.d[(0, 0)] - g.d[(0, 0)]).abs() < 1e-13);
    }

    #[test]
    fn delays() {
        let g = parse_model("exp(-0.032*s)/(s+1)").unwrap();
        let d = c2d(&g, 0.001, Method::Zoh).unwrap();
        assert_eq!((d.nx(), d.input_delay[0]), (1, 0.032));
        let d = c2d(&g, 0.0025, Method::Zoh).unwrap();
        // 0.032 = 12 samples of 2.5 ms + 0.8 sample: one extra state.
        assert_eq!(d.nx(), 2);
        assert!((d.input_delay[0] - 0.03).abs() < 1e-15);
        // Step response at t = 0.0325 + k·T of the exact delayed model: 1 − e^{-(t − 0.032)}.
        let mut x = [0.0, 0.0];
        let mut y = Vec::new();
        for _ in 0..30 {
            y.push(d.c[(0, 0)] * x[0] + d.c[(0, 1)] * x[1] + d.d[(0, 0)]);
            x = [
                d.a[(0, 0)] * x[0] + d.a[(0, 1)] * x[1] + d.b[(0, 0)],
                d.a[(1, 0)] * x[0] + d.a[(1, 1)] * x[1] + d.b[(1, 0)],
            ];
        }
        // Input reaches the model after the integer delay 0.03 s; sample k is at t = 0.03 + k·T.
        for (k, yk) in y.iter().enumerate() {
            let t = 0.03 + k as f64 * 0.0025;
            let want = if t > 0.032 { 1.0 - (-(t - 0.032)).exp() } else { 0.0 };
            assert!((yk - want).abs() < 1e-14, "k = {k}: {yk} vs {want}");
        }
        assert!(c2d(&g, 0.0025, Method::Tustin { prewarp_rad_s: None }).is_err());
    }

    #[test]
    fn bad_input() {
        let g = parse_model("1/(s+1)").unwrap();
        assert!(c2d(&g, 0.0, Method::Zoh).is_err());
        assert!(c2d(&g, -1.0, Method::Zoh).is_err());
        assert!("zohh".parse::<Method>().is_err());
        assert!(d2c(&g, Method::Zoh).is_err());
        assert!(c2d(
            &g,
            0.1,
            Method::Tustin {
                prewarp_rad_s: Some(100.0)
            }
        )
        .is_err());
    }
}
