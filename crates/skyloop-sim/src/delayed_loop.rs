//! The unity negative-feedback loop around a SISO loop transfer L(s) = L₀(s)·e^{−τs}, simulated with
//! the delay kept exact: a delay line of n whole steps and a fractional step f folded into the
//! sampled dynamics (the modified z-transform of a held input), so no Padé approximant changes the
//! response. The error signal is held over each inner step δ, chosen well below the delay and the
//! fastest time constant of L₀, so the only approximation is that hold.

use crate::error::{Result, SimError};
use faer::Mat;
use skyloop_lti::StateSpace;

/// Most inner steps one response may take (bounds time and memory on hostile inputs).
pub const MAX_STEPS: usize = 20_000_000;

/// Φ(t) = e^{A t} and Γ(t) = ∫₀ᵗ e^{A s} ds·B, from one exponential of [[A, B], [0, 0]]·t (Van Loan).
fn phi_gamma(a: &Mat<f64>, b: &Mat<f64>, t: f64) -> Result<(Mat<f64>, Mat<f64>)> {
    let n = a.nrows();
    let m = Mat::from_fn(n + 1, n + 1, |i, j| match (i < n, j < n) {
        (true, true) => a[(i, j)] * t,
        (true, false) => b[(i, 0)] * t,
        _ => 0.0,
    });
    let e = skyloop_linalg::expm::expm(m.as_ref()).map_err(|e| SimError::Param(format!("expm: {e}")))?;
    Ok((
        Mat::from_fn(n, n, |i, j| e[(i, j)]),
        Mat::from_fn(n, 1, |i, _| e[(i, n)]),
    ))
}

/// Output y(t) of the loop u = r − y, y = L·u, for a unit step r at t = 0 from rest, at the times
/// `t_s` (uniform from 0, seconds). `l` is a continuous SISO loop transfer; its input and output
/// delays are summed into one loop delay.
///
/// # Errors
/// A MIMO or discrete `l`, a grid that is not uniform from 0, an algebraic loop (1 + D = 0), or a
/// grid that would need more than [`MAX_STEPS`] inner steps.
///
/// # Examples
/// L = e^{−0.1 s}/s: the closed loop is y' = 1 − y(t − 0.1) from rest, so y stays 0 until 0.1 s
/// and then rises as t − 0.1 until 0.2 s.
/// ```
/// let l = skyloop_lti::expr::parse_model("exp(-0.1*s)/s")?;
/// let t: Vec<f64> = (0..=200).map(|k| k as f64 * 0.001).collect();
/// let y = skyloop_sim::delayed_loop::closed_loop_step(&l, &t)?;
/// assert!(y[100].abs() < 1e-12);
/// assert!((y[200] - 0.1).abs() < 1e-9);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn closed_loop_step(l: &StateSpace, t_s: &[f64]) -> Result<Vec<f64>> {
    if l.nu() != 1 || l.ny() != 1 || !l.is_continuous() {
        return Err(SimError::Param(format!(
            "a closed-loop step needs a continuous SISO loop transfer, got {}×{} with dt = {}",
            l.ny(),
            l.nu(),
            l.dt
        )));
    }
    if t_s.len() < 2 || t_s[0] != 0.0 {
        return Err(SimError::Param(
            "the time grid must start at 0 s and hold at least 2 points".into(),
        ));
    }
    let h = t_s[1] - t_s[0];
    let uniform = t_s
        .windows(2)
        .all(|w| ((w[1] - w[0]) - h).abs() <= 1e-9 * h.max(w[1].abs()));
    if !(h > 0.0 && h.is_finite() && uniform) {
        return Err(SimError::Param("the time grid must be uniform and increasing".into()));
    }
    let tau = l.input_delay.first().copied().unwrap_or(0.0) + l.output_delay.first().copied().unwrap_or(0.0);
    let core = StateSpace::new(l.a.clone(), l.b.clone(), l.c.clone(), l.d.clone(), 0.0)
        .map_err(|e| SimError::Param(e.to_string()))?;
    let d = if core.d.nrows() == 1 { core.d[(0, 0)] } else { 0.0 };
    // Inner step: a hundredth of the fastest time constant and of the delay, and a whole fraction of
    // h; the hold of the error signal then costs O(δ) ≈ 1e-4 relative.
    let w_max = skyloop_lti::poles_zeros::poles(&core)
        .map_err(|e| SimError::Param(e.to_string()))?
        .iter()
        .map(|p| p.norm())
        .fold(0.0, f64::max);
    let mut delta = h;
    if w_max > 0.0 {
        delta = delta.min(0.01 / w_max);
    }
    if tau > 0.0 {
        delta = delta.min(tau / 100.0);
    }
    let sub = (h / delta).ceil().max(1.0);
    let steps = sub * (t_s.len() - 1) as f64;
    if !(steps.is_finite() && steps <= MAX_STEPS as f64) {
        return Err(SimError::Param(format!(
            "the response would need {steps:.3e} inner steps (limit {MAX_STEPS}): shorten the time grid"
        )));
    }
    let sub = sub as usize;
    let delta = h / sub as f64;
    let whole = (tau / delta).floor();
    let frac = tau / delta - whole;
    let (n_del, frac) = if frac > 1.0 - 1e-9 {
        (whole as usize + 1, 0.0)
    } else {
        (whole as usize, frac)
    };
    if tau == 0.0 && (1.0 + d).abs() < 1e-12 {
        return Err(SimError::Param("1 + D = 0: the loop is algebraic and singular".into()));
    }
    let nx = core.nx();
    let (phi, _) = phi_gamma(&core.a, &core.b, delta)?;
    // x⁺ = Φ(δ)x + Φ((1−f)δ)Γ(fδ)·u[k−n−1] + Γ((1−f)δ)·u[k−n].
    let (phi_late, gamma_late) = phi_gamma(&core.a, &core.b, (1.0 - frac) * delta)?;
    let (_, gamma_early) = phi_gamma(&core.a, &core.b, frac * delta)?;
    let g_old = &phi_late * &gamma_early;
    let g_new = gamma_late;
    // u[k] for the last n + 2 steps (zero before t = 0: the loop starts from rest).
    let mut hist = vec![0.0; n_del + 2];
    let mut head = 0usize;
    let past = |hist: &[f64], head: usize, lag: usize| hist[(head + hist.len() - lag % hist.len()) % hist.len()];
    let mut x = Mat::<f64>::zeros(nx, 1);
    let mut out = Vec::with_capacity(t_s.len());
    let total = sub * (t_s.len() - 1);
    for k in 0..=total {
        let cx = (0..nx).map(|i| core.c[(0, i)] * x[(i, 0)]).sum::<f64>();
        // The delayed input at t = kδ: u[k−n−1] within the fractional part, else u[k−n].
        let (y, u) = if n_del == 0 && frac == 0.0 {
            let y = (cx + d) / (1.0 + d);
            (y, 1.0 - y)
        } else {
            let lag = if frac > 0.0 { n_del + 1 } else { n_del };
            let v = past(&hist, head, lag);
            let y = cx + d * v;
            (y, 1.0 - y)
        };
        if k % sub == 0 {
            out.push(y);
        }
        if k == total {
            break;
        }
        // hist[head] holds u[k]; lags count back from it.
        hist[head] = u;
        let u_new = past(&hist, head, n_del);
        let u_old = past(&hist, head, n_del + 1);
        let mut xn = &phi * &x;
        for i in 0..nx {
            xn[(i, 0)] += g_old[(i, 0)] * u_old + g_new[(i, 0)] * u_new;
        }
        x = xn;
        head = (head + 1) % hist.len();
    }
    Ok(out)
}
