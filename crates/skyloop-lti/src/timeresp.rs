//! Time responses: step, impulse and lsim, exact for held (piecewise-constant) inputs.
//!
//! A continuous model is discretized once with an exact zero-order hold at the grid spacing
//! (`c2d` zoh, fractional input delays included); delays then are whole-sample shifts, so a step
//! response is exact at every grid point, delays included.

use crate::discretize::{c2d, Method};
use crate::error::{LtiError, Result};
use crate::freqresp::dot;
use crate::poles_zeros::poles;
use crate::ss::StateSpace;
use skyloop_linalg::expm::expm;

/// Responses to a step or impulse on each input: `y[output][input][k]` at times `t_s[k]` seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeResponse {
    /// Sample times in seconds, uniform, starting at 0.
    pub t_s: Vec<f64>,
    /// Output values indexed \[output\]\[input\]\[sample\].
    pub y: Vec<Vec<Vec<f64>>>,
}

/// Response of a simulation: `y[k][output]` and `x[k][state]` at `t_s[k]`.
#[derive(Debug, Clone, PartialEq)]
pub struct SimResponse {
    /// Sample times in seconds.
    pub t_s: Vec<f64>,
    /// Outputs indexed \[sample\]\[output\].
    pub y: Vec<Vec<f64>>,
}

/// A uniform grid 0, h, 2h, … from a final time (and sample time), or chosen from the poles:
/// about 7 time constants of the slowest stable pole, 20 points per period of the fastest pole.
pub fn auto_grid(sys: &StateSpace, t_final_s: Option<f64>) -> Result<Vec<f64>> {
    let p = poles(sys)?;
    let max_delay =
        sys.input_delay.iter().fold(0.0f64, |a, &b| a.max(b)) + sys.output_delay.iter().fold(0.0f64, |a, &b| a.max(b));
    // Continuous-equivalent poles for a discrete model.
    let pc: Vec<_> = if sys.is_continuous() {
        p
    } else {
        p.iter().filter(|z| z.norm() > 0.0).map(|z| z.ln() / sys.dt).collect()
    };
    let scale = pc.iter().map(|z| z.norm()).fold(0.0f64, f64::max);
    let tf = match t_final_s {
        Some(t) if t.is_finite() && t > 0.0 => t,
        Some(t) => return Err(LtiError::InvalidArgument(format!("final time must be > 0, got {t}"))),
        None => {
            let slow = pc
                .iter()
                .filter(|z| z.re < -1e-9 * scale.max(1e-300))
                .map(|z| -z.re)
                .fold(f64::INFINITY, f64::min);
            let any_marginal = pc.iter().any(|z| z.re >= -1e-9 * scale.max(1e-300));
            let nonzero = pc
                .iter()
                .map(|z| z.norm())
                .filter(|&r| r > 1e-9 * scale)
                .fold(f64::INFINITY, f64::min);
            let base = if slow.is_finite() && !any_marginal {
                7.0 / slow
            } else if nonzero.is_finite() {
                10.0 / nonzero
            } else {
                10.0
            };
            base + 1.2 * max_delay
        }
    };
    if !sys.is_continuous() {
        let n = (tf / sys.dt).ceil().min(1e6) as usize;
        return Ok((0..=n).map(|k| k as f64 * sys.dt).collect());
    }
    let mut h = tf / 1000.0;
    if scale > 0.0 {
        h = h.min(2.0 * std::f64::consts::PI / (20.0 * scale));
    }
    let n = (tf / h).ceil().min(1e6) as usize;
    let h = tf / n as f64;
    Ok((0..=n).map(|k| k as f64 * h).collect())
}

/// Checks a time grid is uniform from 0 and returns its spacing.
fn grid_step(t: &[f64], sys: &StateSpace) -> Result<f64> {
    if t.len() < 2 {
        return Err(LtiError::InvalidArgument(
            "the time grid needs at least two points".into(),
        ));
    }
    let h = t[1] - t[0];
    if t[0] != 0.0 || !(h > 0.0 && h.is_finite()) {
        return Err(LtiError::InvalidArgument(
            "the time grid must start at 0 and increase".into(),
        ));
    }
    for (k, &tk) in t.iter().enumerate() {
        if (tk - k as f64 * h).abs() > 1e-9 * h * (k as f64).max(1.0) {
            return Err(LtiError::InvalidArgument(format!(
                "the time grid is not uniform at index {k}"
            )));
        }
    }
    if !sys.is_continuous() && (h - sys.dt).abs() > 1e-9 * sys.dt {
        return Err(LtiError::InvalidArgument(format!(
            "a discrete model needs the grid spacing equal to dt = {} s",
            sys.dt
        )));
    }
    Ok(h)
}

/// A discrete model in row-major arrays with whole-sample input and output delays.
struct Discrete {
    n: usize,
    m: usize,
    p: usize,
    a: Vec<f64>,
    b: Vec<f64>,
    c: Vec<f64>,
    d: Vec<f64>,
    in_shift: Vec<usize>,
    out_shift: Vec<usize>,
}

impl Discrete {
    fn new(sys: &StateSpace, h: f64) -> Result<Discrete> {
        let sd = if sys.is_continuous() {
            c2d(sys, h, Method::Zoh)?
        } else {
            sys.clone()
        };
        let rows = |m: &faer::Mat<f64>| -> Vec<f64> {
            (0..m.nrows())
                .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
                .collect()
        };
        let shift = |t: &f64| -> Result<usize> {
            let r = t / sd.dt;
            if (r - r.round()).abs() > 1e-9 * r.max(1.0) {
                return Err(LtiError::Unsupported(format!(
                    "delay {t} s is not a whole number of samples of {} s",
                    sd.dt
                )));
            }
            Ok(r.round() as usize)
        };
        Ok(Discrete {
            n: sd.nx(),
            m: sd.nu(),
            p: sd.ny(),
            a: rows(&sd.a),
            b: rows(&sd.b),
            c: rows(&sd.c),
            d: rows(&sd.d),
            in_shift: sd.input_delay.iter().map(shift).collect::<Result<_>>()?,
            out_shift: sd.output_delay.iter().map(shift).collect::<Result<_>>()?,
        })
    }

    /// Simulates `nt` samples from `x0` with input `u(k, j)`; returns y\[i\]\[k\] (output-major).
    fn run(&self, nt: usize, x0: &[f64], u: impl Fn(usize, usize) -> f64) -> Vec<Vec<f64>> {
        let (n, m, p) = (self.n, self.m, self.p);
        let mut x = x0.to_vec();
        let mut xn = vec![0.0; n];
        let mut uk = vec![0.0; m];
        let mut y = vec![vec![0.0; nt]; p];
        for k in 0..nt {
            for (j, v) in uk.iter_mut().enumerate() {
                let s = self.in_shift[j];
                *v = if k >= s { u(k - s, j) } else { 0.0 };
            }
            for (i, yi) in y.iter_mut().enumerate() {
                let k_out = k + self.out_shift[i];
                if k_out < nt {
                    yi[k_out] = dot(&self.c[i * n..(i + 1) * n], &x) + dot(&self.d[i * m..(i + 1) * m], &uk);
                }
            }
            for (i, v) in xn.iter_mut().enumerate() {
                *v = dot(&self.a[i * n..(i + 1) * n], &x) + dot(&self.b[i * m..(i + 1) * m], &uk);
            }
            std::mem::swap(&mut x, &mut xn);
        }
        y
    }
}

/// Unit step on each input in turn, zero initial state; `t_s` uniform from 0 (auto when None).
///
/// # Errors
/// A time grid that is not uniform from 0, or a model that cannot be discretized on it.
///
/// # Examples
/// ```
/// let g = skyloop_lti::expr::parse_model("1/(s+1)")?;
/// let t: Vec<f64> = (0..=500).map(|k| k as f64 * 0.01).collect();
/// let r = skyloop_lti::timeresp::step(&g, Some(&t))?;
/// assert!((r.y[0][0][500] - (1.0 - (-5.0f64).exp())).abs() < 1e-9);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn step(sys: &StateSpace, t_s: Option<&[f64]>) -> Result<TimeResponse> {
    let t = match t_s {
        Some(t) => t.to_vec(),
        None => auto_grid(sys, None)?,
    };
    let h = grid_step(&t, sys)?;
    let dm = Discrete::new(sys, h)?;
    let x0 = vec![0.0; dm.n];
    let mut y = vec![vec![Vec::new(); sys.nu()]; sys.ny()];
    for j in 0..sys.nu() {
        let r = dm.run(t.len(), &x0, |_, q| f64::from(u8::from(q == j)));
        for (yi, ri) in y.iter_mut().zip(r) {
            yi[j] = ri;
        }
    }
    Ok(TimeResponse { t_s: t, y })
}

/// Impulse response on each input in turn. Continuous time: `C e^{A(t−τ)} B` after the delay τ (the
/// Dirac part of D is left out, as python-control does); discrete time: the unit pulse u\[0\] = 1.
#[allow(clippy::needless_range_loop)]
pub fn impulse(sys: &StateSpace, t_s: Option<&[f64]>) -> Result<TimeResponse> {
    let t = match t_s {
        Some(t) => t.to_vec(),
        None => auto_grid(sys, None)?,
    };
    let h = grid_step(&t, sys)?;
    let nt = t.len();
    let mut y = vec![vec![vec![0.0; nt]; sys.nu()]; sys.ny()];
    if !sys.is_continuous() {
        let dm = Discrete::new(sys, h)?;
        let x0 = vec![0.0; dm.n];
        for j in 0..sys.nu() {
            let r = dm.run(nt, &x0, |k, q| f64::from(u8::from(q == j && k == 0)));
            for (yi, ri) in y.iter_mut().zip(r) {
                yi[j] = ri;
            }
        }
        return Ok(TimeResponse { t_s: t, y });
    }
    let n = sys.nx();
    let phi = expm((&sys.a * faer::Scale(h)).as_ref())?;
    for j in 0..sys.nu() {
        for i in 0..sys.ny() {
            let tau = sys.input_delay[j] + sys.output_delay[i];
            let k0 = (tau / h - 1e-9).ceil().max(0.0) as usize;
            if k0 >= nt {
                continue;
            }
            let e0 = expm((&sys.a * faer::Scale(k0 as f64 * h - tau)).as_ref())?;
            let mut x: Vec<f64> = (0..n)
                .map(|r| (0..n).map(|q| e0[(r, q)] * sys.b[(q, j)]).sum())
                .collect();
            for k in k0..nt {
                y[i][j][k] = (0..n).map(|q| sys.c[(i, q)] * x[q]).sum();
                x = (0..n).map(|r| (0..n).map(|q| phi[(r, q)] * x[q]).sum()).collect();
            }
        }
    }
    Ok(TimeResponse { t_s: t, y })
}

/// Response to sampled inputs `u[k][input]` held constant between the uniform times `t_s[k]`
/// (zero-order hold), from initial state `x0` (zeros when None).
pub fn lsim(sys: &StateSpace, u: &[Vec<f64>], t_s: &[f64], x0: Option<&[f64]>) -> Result<SimResponse> {
    let h = grid_step(t_s, sys)?;
    if u.len() != t_s.len() || u.iter().any(|r| r.len() != sys.nu()) {
        return Err(LtiError::Dimension(format!(
            "lsim: u must have {} rows of {} inputs",
            t_s.len(),
            sys.nu()
        )));
    }
    let dm = Discrete::new(sys, h)?;
    let mut x = vec![0.0; dm.n];
    if let Some(x0) = x0 {
        if x0.len() != sys.nx() {
            return Err(LtiError::Dimension(format!("lsim: x0 must have {} entries", sys.nx())));
        }
        x[..sys.nx()].copy_from_slice(x0);
    }
    let by_output = dm.run(t_s.len(), &x, |k, j| u[k][j]);
    let y = (0..t_s.len())
        .map(|k| by_output.iter().map(|yi| yi[k]).collect())
        .collect();
    Ok(SimResponse { t_s: t_s.to_vec(), y })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::parse_model;

    #[test]
    fn first_order_with_delay_closed_form() {
        // 2·e^{-0.25 s}/(s+1): step 2(1 − e^{−(t−0.25)}), impulse 2e^{−(t−0.25)} for t > 0.25.
        let g = parse_model("2*exp(-0.25*s)/(s+1)").unwrap();
        let t: Vec<f64> = (0..=100).map(|k| k as f64 * 0.1).collect();
        let s = step(&g, Some(&t)).unwrap();
        let im = impulse(&g, Some(&t)).unwrap();
        for (k, &tk) in t.iter().enumerate() {
            let (ws, wi) = if tk > 0.25 {
                (2.0 * (1.0 - (-(tk - 0.25)).exp()), 2.0 * (-(tk - 0.25)).exp())
            } else {
                (0.0, 0.0)
            };
            assert!((s.y[0][0][k] - ws).abs() < 1e-13, "step t={tk}");
            assert!((im.y[0][0][k] - wi).abs() < 1e-13, "impulse t={tk}");
        }
    }

    #[test]
    fn auto_grid_covers_settling() {
        let g = parse_model("1/(s+0.5)").unwrap();
        let r = step(&g, None).unwrap();
        let tf = *r.t_s.last().unwrap();
        assert!(tf >= 14.0 - 1e-9, "7 time constants of 2 s: {tf}");
        // Final value within e^{-7} of the DC gain 2 (closed form).
        assert!((r.y[0][0].last().unwrap() - 2.0).abs() < 2.0 * 1e-3);
    }

    #[test]
    fn lsim_matches_step_and_rejects_bad_input() {
        let g = parse_model("(s+3)/(s^2+2*s+5)").unwrap();
        let t: Vec<f64> = (0..50).map(|k| k as f64 * 0.05).collect();
        let u = vec![vec![1.0]; t.len()];
        let l = lsim(&g, &u, &t, None).unwrap();
        let s = step(&g, Some(&t)).unwrap();
        for k in 0..t.len() {
            assert!((l.y[k][0] - s.y[0][0][k]).abs() < 1e-15);
        }
        assert!(lsim(&g, &u[..10], &t, None).is_err());
        let bad_t = vec![0.0, 0.1, 0.3];
        assert!(lsim(&g, &u[..3], &bad_t, None).is_err());
        assert!(step(&g, Some(&[1.0, 2.0])).is_err());
    }
}

/// Step-response characteristics as MATLAB's `stepinfo` reports them. Times in seconds, overshoot
/// and undershoot in percent of the final value; a characteristic the response never shows (no
/// rise to 90 %, no settling inside the window) is `None`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StepInfo {
    /// The value the response settles to (the reference for the percentages and the band).
    pub final_value: f64,
    /// Rise time, s: from `rise_limits.0` to `rise_limits.1` of the final value.
    pub rise_time_s: Option<f64>,
    /// Fractions of the final value between which the rise time is measured (MATLAB: 0.1, 0.9).
    pub rise_limits: (f64, f64),
    /// Settling time, s: after it the response stays within `settling_band` of the final value.
    pub settling_time_s: Option<f64>,
    /// Half-width of the settling band as a fraction of the final value (MATLAB: 0.02).
    pub settling_band: f64,
    /// Overshoot, % of the final value.
    pub overshoot_pct: Option<f64>,
    /// Undershoot (the largest excursion the opposite way of the final value), %.
    pub undershoot_pct: Option<f64>,
    /// Peak value (largest |y|, with its sign) and its time, s.
    pub peak: Option<(f64, f64)>,
}

impl StepInfo {
    /// No characteristics yet, MATLAB's limits (10–90 % rise, 2 % settling) and the final value.
    pub fn new(final_value: f64) -> Self {
        StepInfo {
            final_value,
            rise_time_s: None,
            rise_limits: (0.1, 0.9),
            settling_time_s: None,
            settling_band: 0.02,
            overshoot_pct: None,
            undershoot_pct: None,
            peak: None,
        }
    }
}

/// MATLAB's `stepinfo` of a sampled step response `y(t)` starting from 0: rise time (10→90 %),
/// settling time (2 % band, interpolated at the last exit), overshoot, undershoot and peak, against
/// `final_value` (the DC gain when the response is stable; pass `None` to take the last sample).
///
/// A zero or non-finite final value (an integrating or unstable response) leaves every
/// characteristic `None` but the peak, since percentages of it mean nothing.
///
/// # Examples
/// ```
/// let t: Vec<f64> = (0..=1000).map(|k| k as f64 * 0.01).collect();
/// let y: Vec<f64> = t.iter().map(|t| 1.0 - (-t).exp()).collect();
/// let s = skyloop_lti::timeresp::stepinfo(&t, &y, Some(1.0));
/// // First order: rise ln 9 = 2.197 s, 2 % settling ln 50 = 3.912 s, no overshoot.
/// assert!((s.rise_time_s.unwrap() - 9f64.ln()).abs() < 1e-3);
/// assert!((s.settling_time_s.unwrap() - 50f64.ln()).abs() < 1e-3);
/// assert_eq!(s.overshoot_pct, Some(0.0));
/// ```
pub fn stepinfo(t: &[f64], y: &[f64], final_value: Option<f64>) -> StepInfo {
    let n = t.len().min(y.len());
    let (t, y) = (&t[..n], &y[..n]);
    let yf = final_value.unwrap_or_else(|| y.last().copied().unwrap_or(f64::NAN));
    let mut info = StepInfo::new(yf);
    let peak = (0..n)
        .filter(|&k| y[k].is_finite())
        .max_by(|&a, &b| y[a].abs().total_cmp(&y[b].abs()));
    info.peak = peak.map(|k| (y[k], t[k]));
    if !(yf.is_finite() && yf != 0.0) || n < 2 {
        return info;
    }
    // Work on y/yf so that a negative final value reads the same way as a positive one.
    let r: Vec<f64> = y.iter().map(|v| v / yf).collect();
    let cross = |level: f64| {
        (1..n).find_map(|k| {
            (r[k - 1] < level && r[k] >= level)
                .then(|| t[k - 1] + (level - r[k - 1]) / (r[k] - r[k - 1]) * (t[k] - t[k - 1]))
        })
    };
    let (lo, hi) = info.rise_limits;
    let t_lo = if r[0] >= lo { Some(t[0]) } else { cross(lo) };
    info.rise_time_s = match (t_lo, cross(hi)) {
        (Some(a), Some(b)) => Some(b - a),
        _ => None,
    };
    let band = info.settling_band;
    info.settling_time_s = match (0..n).rev().find(|&k| (r[k] - 1.0).abs() > band) {
        None => Some(t[0]),
        // Still outside the band at the end of the window: not settled.
        Some(k) if k + 1 == n => None,
        Some(k) => {
            // Interpolate where the response enters the band for the last time.
            let edge = if r[k] > 1.0 { 1.0 + band } else { 1.0 - band };
            let f = (edge - r[k]) / (r[k + 1] - r[k]);
            Some(t[k] + f.clamp(0.0, 1.0) * (t[k + 1] - t[k]))
        }
    };
    let max_r = r
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    let min_r = r
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(f64::INFINITY, f64::min);
    info.overshoot_pct = Some(100.0 * (max_r - 1.0).max(0.0));
    // `+ 0.0` turns a −0 (a response starting exactly at 0) into 0.
    info.undershoot_pct = Some(100.0 * (-min_r).max(0.0) + 0.0);
    info
}

#[cfg(test)]
mod stepinfo_tests {
    use super::*;

    /// Second order, ζ = 0.5, ωn = 1: overshoot exp(−πζ/√(1−ζ²)) = 16.30 %, peak at π/ωd = 3.628 s.
    #[test]
    fn second_order_matches_closed_forms() {
        let g = crate::expr::parse_model("1/(s^2+s+1)").unwrap();
        let t: Vec<f64> = (0..=4000).map(|k| k as f64 * 0.005).collect();
        let r = step(&g, Some(&t)).unwrap();
        let s = stepinfo(&t, &r.y[0][0], Some(1.0));
        assert!((s.overshoot_pct.unwrap() - 16.303).abs() < 0.01, "{s:?}");
        let (peak, tp) = s.peak.unwrap();
        assert!((peak - 1.16303).abs() < 1e-4 && (tp - 3.6276).abs() < 0.006, "{s:?}");
        // scipy.signal.step on a 5e-5 s grid, crossings interpolated: rise 1.6376 s, last exit from
        // the 2 % band at 8.0763 s.
        assert!((s.rise_time_s.unwrap() - 1.6376).abs() < 2e-3, "{s:?}");
        assert!((s.settling_time_s.unwrap() - 8.0763).abs() < 1e-2, "{s:?}");
        assert_eq!(s.undershoot_pct, Some(0.0));
    }

    /// A non-minimum-phase response dips the wrong way first; a negative gain reads the same.
    #[test]
    fn undershoot_and_negative_gain() {
        let g = crate::expr::parse_model("-(1-s)/((s+1)*(0.5*s+1))").unwrap();
        let t: Vec<f64> = (0..=3000).map(|k| k as f64 * 0.005).collect();
        let r = step(&g, Some(&t)).unwrap();
        let s = stepinfo(&t, &r.y[0][0], Some(-1.0));
        let us = s.undershoot_pct.unwrap();
        assert!(us > 5.0 && us < 50.0, "{s:?}");
        assert!(s.rise_time_s.is_some() && s.settling_time_s.is_some());
    }

    /// Not settled in the window, and a zero final value: honest Nones.
    #[test]
    fn unsettled_and_zero_final() {
        let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.1).collect();
        let ramp: Vec<f64> = t.clone();
        let s = stepinfo(&t, &ramp, Some(20.0));
        assert_eq!(s.settling_time_s, None);
        let z = stepinfo(&t, &vec![0.0; 100], Some(0.0));
        assert_eq!(z.rise_time_s, None);
        assert_eq!(z.overshoot_pct, None);
    }
}
