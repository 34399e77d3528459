//! Stability margins of a SISO loop transfer L (convention u = C(r − y), L = P·C), exact with delays.
//!
//! Crossings are located on a dense, adaptively refined logarithmic grid of the exact response
//! L(jω) (delays included) and refined to machine precision with Brent's method. Definitions follow
//! MATLAB: `allmargin` (every crossing), `margin` (the smallest-magnitude pair), the delay margin
//! min over gain crossovers of PM/ω, and `diskmargin` with skew σ = 0 (balanced, α = 1/‖S − 1/2‖∞).
//! Closed-loop stability comes from the Nyquist criterion on the exact L (see [`nyquist_stable`]).
//!
//! Search range: from two decades below to two decades above the model's characteristic frequencies
//! (poles, 1/delay), widened until no gain crossover can lie outside; for delayed continuous loops the
//! phase crossovers (infinitely many) are listed up to one decade above the fastest dynamics or
//! gain crossover. Discrete loops are searched up to the Nyquist frequency π/dt.

use crate::error::{LtiError, Result};
use crate::freqresp::{dynamics_range, pole_summary, FreqEvaluator, Workspace};
use crate::roots::{brent_root, golden_max};
use crate::ss::StateSpace;
use faer::c64;
use std::f64::consts::PI;

/// A gain margin read at a phase crossover (phase of L ≡ −180° mod 360°).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GainMargin {
    /// Gain margin in dB: −20·log10|L(jω)| (negative when the loop gain may only decrease).
    pub gm_db: f64,
    /// Phase-crossover frequency, rad/s.
    pub w_rad_s: f64,
}

/// A phase margin read at a gain crossover (|L(jω)| = 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseMargin {
    /// Phase margin in degrees, in (−180, 180]: the angle from −1 to L(jω).
    pub pm_deg: f64,
    /// Gain-crossover frequency, rad/s.
    pub w_rad_s: f64,
    /// Extra loop delay (s) that brings this crossover onto −1: (PM mod 360°)/ω.
    pub delay_margin_s: f64,
}

/// Every crossing of the loop (MATLAB `allmargin`).
#[derive(Debug, Clone, PartialEq)]
pub struct AllMargins {
    /// Gain margins at every phase crossover, by increasing frequency.
    pub gain_margins: Vec<GainMargin>,
    /// Phase margins at every gain crossover, by increasing frequency.
    pub phase_margins: Vec<PhaseMargin>,
    /// Smallest delay margin over the gain crossovers, s (0 when the closed loop is unstable,
    /// infinite without gain crossover).
    pub delay_margin_s: f64,
    /// True when the closed loop 1/(1 + L) is stable (Nyquist criterion, valid with delays).
    pub stable: bool,
    /// The frequency band searched for crossings, rad/s (see the module documentation).
    pub w_range_rad_s: (f64, f64),
}

/// The classic margin pair (MATLAB `margin`): the gain and phase margins of smallest magnitude.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Margins {
    /// Gain margin, dB (+∞ when the phase never crosses −180°).
    pub gm_db: f64,
    /// Its phase-crossover frequency, rad/s (NaN when none).
    pub gm_w_rad_s: f64,
    /// Phase margin, degrees (+∞ when the gain never crosses 1).
    pub pm_deg: f64,
    /// Its gain-crossover frequency, rad/s (NaN when none).
    pub pm_w_rad_s: f64,
    /// Delay margin, s (see [`AllMargins::delay_margin_s`]).
    pub delay_margin_s: f64,
    /// Closed-loop stability (Nyquist).
    pub stable: bool,
}

/// Symmetric (skew σ = 0) disk margin, MATLAB `diskmargin` for a SISO loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiskMargin {
    /// Disk size α = 1 / max_ω |S − 1/2| with S = 1/(1 + L) (0 when the closed loop is unstable).
    pub alpha: f64,
    /// Tolerated gain variation [low, high] in dB: 20·log10((2 ∓ α)/(2 ± α)) (±∞ when α ≥ 2).
    pub gain_db: [f64; 2],
    /// Tolerated phase variation ± degrees: 2·atan(α/2).
    pub phase_deg: f64,
    /// Frequency where the margin is smallest, rad/s (NaN when the closed loop is unstable).
    pub w_rad_s: f64,
}

/// Evaluates a SISO loop at frequencies along the imaginary axis and nearby points.
struct Loop {
    ev: FreqEvaluator,
    ws: Workspace,
    out: [c64; 1],
    dt: f64,
}

impl Loop {
    fn new(sys: &StateSpace) -> Result<Self> {
        if sys.ny() != 1 || sys.nu() != 1 {
            return Err(LtiError::Dimension(format!(
                "margins need a SISO loop transfer, got {} outputs and {} inputs",
                sys.ny(),
                sys.nu()
            )));
        }
        let ev = FreqEvaluator::new(sys)?;
        let ws = ev.workspace();
        Ok(Loop {
            ev,
            ws,
            out: [c64::new(0.0, 0.0)],
            dt: sys.dt,
        })
    }

    fn at_s(&mut self, s: c64) -> Result<c64> {
        self.ev.eval_into(s, &mut self.ws, &mut self.out)?;
        Ok(self.out[0])
    }

    fn at(&mut self, w: f64) -> Result<c64> {
        self.at_s(c64::new(0.0, w))
    }

    /// L(jω), or infinity at a pole (used only where a value is needed for sign tests).
    fn at_or_inf(&mut self, w: f64) -> c64 {
        self.at(w).unwrap_or(c64::new(f64::INFINITY, 0.0))
    }
}

/// The sampled loop: frequencies (rad/s, increasing) and L at each.
struct Grid {
    w: Vec<f64>,
    l: Vec<c64>,
}

/// Search bounds (rad/s) for crossings: see the module documentation.
fn search_range(sys: &StateSpace, lp: &mut Loop) -> Result<(f64, f64)> {
    let (lo, hi) = dynamics_range(sys)?;
    let nyquist = if sys.dt > 0.0 { PI / sys.dt } else { f64::INFINITY };
    let mut w_lo = (lo / 100.0).min(nyquist / 1e4);
    let delayed = sys.has_delay() && sys.dt == 0.0;
    let mut w_hi = (if delayed { hi * 10.0 } else { hi * 100.0 }).min(nyquist);
    let logmag = |lp: &mut Loop, w: f64| lp.at_or_inf(w).norm().ln();
    // Widen until the magnitude moves away from 0 dB beyond the ends (asymptotic region).
    for _ in 0..30 {
        let (m1, m0) = (logmag(lp, w_lo), logmag(lp, w_lo / 10.0));
        if (m0 > 0.0) == (m1 > 0.0) && m0.abs() >= m1.abs() && m1 != 0.0 {
            break;
        }
        w_lo /= 10.0;
    }
    if w_hi < nyquist {
        for _ in 0..30 {
            let (m1, m2) = (logmag(lp, w_hi), logmag(lp, w_hi * 10.0));
            if ((m2 > 0.0) == (m1 > 0.0) && m2.abs() >= m1.abs() && m1 != 0.0) || (m1 - m2).abs() < 1e-9 {
                break;
            }
            w_hi = (w_hi * 10.0).min(nyquist);
            if w_hi >= nyquist {
                break;
            }
        }
    }
    Ok((w_lo, w_hi))
}

/// Samples L on [w_lo, w_hi] (100 points/decade), then bisects every interval whose phase moves
/// more than 10° or whose magnitude moves more than 0.1 neper, so no crossing can hide between samples.
fn sample(lp: &mut Loop, w_lo: f64, w_hi: f64) -> Result<Grid> {
    let decades = (w_hi / w_lo).log10().max(0.1);
    let n0 = ((decades * 100.0).ceil() as usize).max(20);
    let base = crate::freqresp::logspace(w_lo.log10(), w_hi.log10(), n0);
    let mut w = Vec::with_capacity(2 * n0);
    let mut l = Vec::with_capacity(2 * n0);
    let first = lp.at(base[0])?;
    w.push(base[0]);
    l.push(first);
    for &wb in &base[1..] {
        let lb = lp.at(wb)?;
        // Depth-first bisection between the last accepted point and wb.
        let mut stack = vec![(wb, lb, 0u32)];
        while let Some(&(wr, lr, depth)) = stack.last() {
            let (wl, ll) = (*w.last().unwrap_or(&wr), *l.last().unwrap_or(&lr));
            let dphi = (lr / ll).arg().abs();
            let dmag = (lr.norm().ln() - ll.norm().ln()).abs();
            if depth < 40 && (dphi > 10f64.to_radians() || dmag > 0.1) && wr - wl > 1e-14 * wr {
                let wm = (wl * wr).sqrt();
                let lm = lp.at(wm)?;
                stack.push((wm, lm, depth + 1));
                // The right half is re-examined after the left one is accepted.
                let n = stack.len();
                stack[n - 2].2 = depth + 1;
            } else {
                w.push(wr);
                l.push(lr);
                stack.pop();
            }
        }
    }
    Ok(Grid { w, l })
}

/// Every gain margin and phase margin of the SISO loop `l` (MATLAB `allmargin`), exact with delays.
pub fn allmargin(l: &StateSpace) -> Result<AllMargins> {
    let mut lp = Loop::new(l)?;
    let (w_lo, w_hi) = search_range(l, &mut lp)?;
    let g = sample(&mut lp, w_lo, w_hi)?;
    let stable = nyquist_stable(l)?;
    let mut gain_margins = Vec::new();
    let mut phase_margins = Vec::new();

    // DC: a finite, real, negative L(0) is a phase crossover at ω = 0 (as MATLAB and python-control).
    let integrators = pole_summary(l)?.origin > 0;
    if let (false, Ok(l0)) = (integrators, lp.at(0.0)) {
        if l0.re < 0.0 && l0.im.abs() <= 1e-12 * l0.norm() {
            gain_margins.push(GainMargin {
                gm_db: -20.0 * l0.norm().log10(),
                w_rad_s: 0.0,
            });
        }
    }
    let tol = |a: f64, b: f64| 1e-15 * a.abs().max(b.abs());
    for k in 0..g.w.len() - 1 {
        let (wa, wb) = (g.w[k], g.w[k + 1]);
        let (la, lb) = (g.l[k], g.l[k + 1]);
        // Phase crossover: Im L changes sign where Re L < 0 (sin(arg L) is bounded and smooth there).
        if (la.im > 0.0) != (lb.im > 0.0) && (la.re < 0.0 || lb.re < 0.0) {
            let wc = brent_root(
                |w| {
                    let v = lp.at_or_inf(w);
                    v.im / v.norm()
                },
                wa,
                wb,
                tol(wa, wb),
            );
            let v = lp.at(wc)?;
            if v.re < 0.0 {
                gain_margins.push(GainMargin {
                    gm_db: -20.0 * v.norm().log10(),
                    w_rad_s: wc,
                });
            }
        }
        // Gain crossover: ln|L| changes sign.
        if (la.norm() > 1.0) != (lb.norm() > 1.0) {
            let wc = brent_root(|w| lp.at_or_inf(w).norm().ln(), wa, wb, tol(wa, wb));
            let v = lp.at(wc)?;
            let pm = (-v).arg();
            let pm_pos = if pm < 0.0 { pm + 2.0 * PI } else { pm };
            phase_margins.push(PhaseMargin {
                pm_deg: pm.to_degrees(),
                w_rad_s: wc,
                delay_margin_s: pm_pos / wc,
            });
        }
    }
    let delay_margin_s = if !stable {
        0.0
    } else {
        phase_margins
            .iter()
            .map(|p| p.delay_margin_s)
            .fold(f64::INFINITY, f64::min)
    };
    Ok(AllMargins {
        gain_margins,
        phase_margins,
        delay_margin_s,
        stable,
        w_range_rad_s: (w_lo, w_hi),
    })
}

/// The gain and phase margins of smallest magnitude (MATLAB `margin` semantics: min |GM in dB|, min |PM|).
pub fn margin(l: &StateSpace) -> Result<Margins> {
    let all = allmargin(l)?;
    Ok(margin_from(&all))
}

/// Picks the MATLAB `margin` pair out of `allmargin` results.
pub fn margin_from(all: &AllMargins) -> Margins {
    let gm = all
        .gain_margins
        .iter()
        .min_by(|a, b| a.gm_db.abs().total_cmp(&b.gm_db.abs()));
    let pm = all
        .phase_margins
        .iter()
        .min_by(|a, b| a.pm_deg.abs().total_cmp(&b.pm_deg.abs()));
    Margins {
        gm_db: gm.map_or(f64::INFINITY, |g| g.gm_db),
        gm_w_rad_s: gm.map_or(f64::NAN, |g| g.w_rad_s),
        pm_deg: pm.map_or(f64::INFINITY, |p| p.pm_deg),
        pm_w_rad_s: pm.map_or(f64::NAN, |p| p.w_rad_s),
        delay_margin_s: all.delay_margin_s,
        stable: all.stable,
    }
}

/// Delay margin of the loop in seconds: the smallest extra loop delay that destabilizes it
/// (min over gain crossovers of (PM mod 360°)/ω; the loop's own delays are already in its phase).
pub fn delay_margin(l: &StateSpace) -> Result<f64> {
    Ok(allmargin(l)?.delay_margin_s)
}

/// Symmetric disk margin of the SISO loop `l` (skew σ = 0), exact with delays.
pub fn diskmargin(l: &StateSpace) -> Result<DiskMargin> {
    let mut lp = Loop::new(l)?;
    if !nyquist_stable(l)? {
        return Ok(DiskMargin {
            alpha: 0.0,
            gain_db: [0.0, 0.0],
            phase_deg: 0.0,
            w_rad_s: f64::NAN,
        });
    }
    let (w_lo, w_hi) = search_range(l, &mut lp)?;
    let g = sample(&mut lp, w_lo, w_hi)?;
    let f = |v: c64| ((1.0 - v) / (2.0 * (1.0 + v))).norm();
    let mut best = (f64::NAN, 0.0);
    if pole_summary(l)?.origin == 0 {
        if let Ok(l0) = lp.at(0.0) {
            best = (0.0, f(l0));
        }
    }
    let mut kbest = None;
    for (k, &v) in g.l.iter().enumerate() {
        let fv = f(v);
        if fv > best.1 {
            best = (g.w[k], fv);
            kbest = Some(k);
        }
    }
    if let Some(k) = kbest {
        let a = g.w[k.saturating_sub(1)];
        let b = g.w[(k + 1).min(g.w.len() - 1)];
        let (x, fx) = golden_max(|w| f(lp.at_or_inf(w)), a, b, 1e-13);
        if fx > best.1 {
            best = (x, fx);
        }
    }
    // With no peak (f ≤ 1/2 asymptotes), the supremum is read at the grid end.
    let alpha = if best.1 > 0.0 { 1.0 / best.1 } else { f64::INFINITY };
    Ok(disk_from_alpha(alpha, best.0))
}

fn disk_from_alpha(alpha: f64, w: f64) -> DiskMargin {
    let low = (2.0 - alpha) / (2.0 + alpha);
    let high = (2.0 + alpha) / (2.0 - alpha);
    DiskMargin {
        alpha,
        gain_db: [
            if low > 0.0 {
                20.0 * low.log10()
            } else {
                f64::NEG_INFINITY
            },
            if high > 0.0 { 20.0 * high.log10() } else { f64::INFINITY },
        ],
        phase_deg: (2.0 * (alpha / 2.0).atan()).to_degrees(),
        w_rad_s: w,
    }
}

/// Closed-loop stability of the unity negative feedback around `l` by the Nyquist criterion on the
/// exact L (delays included): the winding of 1 + L(s) along the imaginary axis (unit circle for
/// discrete loops), indented to the right of open-loop poles on the axis, must equal the number of
/// open-loop poles in the right half-plane (outside the unit circle).
pub fn nyquist_stable(l: &StateSpace) -> Result<bool> {
    let mut lp = Loop::new(l)?;
    let dt = lp.dt;
    let poles = pole_summary(l)?;
    let unstable = poles.unstable;
    let (lo, hi) = dynamics_range(l)?;
    let mut w_end = if dt > 0.0 { PI / dt } else { hi * 1e4 };
    if dt == 0.0 {
        // Past w_end the rational part must have died out, so the tail adds no winding.
        let (d, tau) = (l.d[(0, 0)], l.input_delay[0] + l.output_delay[0]);
        for _ in 0..40 {
            let v = lp.at(w_end).unwrap_or(c64::new(f64::INFINITY, 0.0));
            if (v - d * c64::new(0.0, -w_end * tau).exp()).norm() <= 1e-3 {
                break;
            }
            w_end *= 10.0;
        }
    }
    if dt == 0.0 && l.has_delay() && l.d[(0, 0)].abs() >= 1.0 {
        return Err(LtiError::Unsupported(
            "a delayed loop with |D| >= 1 is a neutral system; its Nyquist test is not decided".into(),
        ));
    }
    let mut axis = poles.axis_w.clone();
    axis.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs().max(1.0));
    let mut total = 0.0;
    let mut prev: Option<c64> = None;
    let add = |v: c64, prev: &mut Option<c64>, total: &mut f64| -> bool {
        let f = 1.0 + v;
        if !(f.re.is_finite() && f.im.is_finite()) || f.norm() == 0.0 {
            return false;
        }
        if let Some(p) = *prev {
            *total += (f / p).arg();
        }
        *prev = Some(f);
        true
    };
    // Path: segments on the axis between indentations; each piece refined so that the phase of
    // 1 + L moves less than 30° per step.
    let mut pieces: Vec<Piece> = Vec::new();
    let mut w0 = 0.0;
    if poles.origin > 0 {
        // Radius far outside the integrators' numerical scatter, far inside the other dynamics.
        let eps0 = (poles.origin_radius.max(1e-12 * lo) * lo).sqrt();
        pieces.push(Piece::Arc {
            center: 0.0,
            radius: eps0,
            from: 0.0,
            to: PI / 2.0,
        });
        w0 = eps0;
    }
    for (k, &wp) in axis.iter().enumerate() {
        if wp > w_end * (1.0 + 1e-12) || wp <= w0 {
            continue;
        }
        let gap = [k.checked_sub(1).map(|i| axis[i]), axis.get(k + 1).copied()]
            .into_iter()
            .flatten()
            .map(|o| (o - wp).abs())
            .fold(wp, f64::min);
        let eps = (1e-4 * wp).min(1e-2 * gap).max(1e-10 * wp);
        pieces.push(Piece::Axis { from: w0, to: wp - eps });
        let to = if wp >= w_end * (1.0 - 1e-12) { 0.0 } else { PI / 2.0 };
        pieces.push(Piece::Arc {
            center: wp,
            radius: eps,
            from: -PI / 2.0,
            to,
        });
        w0 = wp + eps;
    }
    if w0 < w_end {
        pieces.push(Piece::Axis { from: w0, to: w_end });
    }
    for piece in pieces {
        let pt = |t: f64| piece.point(t);
        let n0 = 400usize;
        let mut tprev = 0.0;
        let Ok(v0) = lp.at_s(pt(0.0)) else {
            return Ok(false);
        };
        if !add(v0, &mut prev, &mut total) {
            return Ok(false);
        }
        let mut fprev = 1.0 + v0;
        for k in 1..=n0 {
            let t = k as f64 / n0 as f64;
            let mut stack = vec![(t, 0u32)];
            while let Some(&(tr, depth)) = stack.last() {
                let v = match lp.at_s(pt(tr)) {
                    Ok(v) => v,
                    Err(_) => return Ok(false),
                };
                let f = 1.0 + v;
                if (f / fprev).arg().abs() > PI / 6.0 && depth < 50 {
                    stack.push((0.5 * (tprev + tr), depth + 1));
                    continue;
                }
                if !add(v, &mut prev, &mut total) {
                    return Ok(false);
                }
                tprev = tr;
                fprev = f;
                stack.pop();
            }
        }
    }
    let winding = total / PI;
    let w_int = winding.round();
    if (winding - w_int).abs() > 0.25 {
        // 1 + L passes (numerically) through 0 or the tail did not settle: marginal at best.
        return Ok(false);
    }
    Ok(w_int as i64 == unstable as i64)
}

/// One piece of the upper half of the Nyquist contour, parametrized by t ∈ [0, 1].
#[derive(Clone, Copy)]
enum Piece {
    /// s = jω with ω from `from` to `to` (log-spaced when both are positive).
    Axis { from: f64, to: f64 },
    /// s = j·center + radius·e^{jθ}, θ from `from` to `to` (to the right of the axis).
    Arc {
        center: f64,
        radius: f64,
        from: f64,
        to: f64,
    },
}

impl Piece {
    fn point(&self, t: f64) -> c64 {
        match *self {
            Piece::Axis { from, to } => {
                let w = if from > 0.0 {
                    from * (to / from).powf(t)
                } else {
                    // from 0: linear to a small value, then logarithmic
                    let knee = to * 1e-6;
                    if t < 0.1 {
                        knee * t / 0.1
                    } else {
                        knee * (to / knee).powf((t - 0.1) / 0.9)
                    }
                };
                c64::new(0.0, w)
            }
            Piece::Arc {
                center,
                radius,
                from,
                to,
            } => {
                let th = from + (to - from) * t;
                c64::new(radius * th.cos(), center + radius * th.sin())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    fn tf1(num: &[f64], den: &[f64], delay: f64) -> StateSpace {
        // Test-only controllable canonical realization of num/den (den monic after scaling).
        let n = den.len() - 1;
        let lead = den[0];
        let a = Mat::from_fn(n, n, |i, j| {
            if i == 0 {
                -den[j + 1] / lead
            } else if i == j + 1 {
                1.0
            } else {
                0.0
            }
        });
        let b = Mat::from_fn(n, 1, |i, _| if i == 0 { 1.0 } else { 0.0 });
        let mut nm = vec![0.0; n + 1];
        nm[n + 1 - num.len()..].copy_from_slice(num);
        let d0 = nm[0] / lead;
        let c = Mat::from_fn(1, n, |_, j| nm[j + 1] / lead - d0 * den[j + 1] / lead);
        let d = Mat::from_fn(1, 1, |_, _| d0);
        StateSpace::new(a, b, c, d, 0.0)
            .unwrap()
            .with_delays(vec![delay], vec![0.0])
            .unwrap()
    }

    #[test]
    fn third_order_type_one_loop_closed_form() {
        // L = 3/(s(s+1)(s+2)): phase crossover at ω = √2 with |L| = 1/2 (GM = 20·log10 2 dB).
        let l = tf1(&[3.0], &[1.0, 3.0, 2.0, 0.0], 0.0);
        let m = margin(&l).unwrap();
        assert!((m.gm_w_rad_s - 2f64.sqrt()).abs() < 1e-12);
        assert!((m.gm_db - 20.0 * 2f64.log10()).abs() < 1e-10);
        assert!(m.stable);
    }

    #[test]
    fn pure_delay_integrator_closed_form() {
        // L = k e^{−sτ}/s: |L| = 1 at ω = k; PM = 90° − kτ rad; closed loop stable iff kτ < π/2.
        let (k, tau) = (2.0, 0.1);
        let l = tf1(&[k], &[1.0, 0.0], tau);
        let all = allmargin(&l).unwrap();
        assert_eq!(all.phase_margins.len(), 1);
        let pm = all.phase_margins[0];
        assert!((pm.w_rad_s - k).abs() < 1e-12);
        assert!((pm.pm_deg - (90.0 - (k * tau).to_degrees())).abs() < 1e-9);
        // delay margin: (π/2 − kτ)/k
        assert!((all.delay_margin_s - (PI / 2.0 - k * tau) / k).abs() < 1e-12);
        assert!(all.stable);
        let unstable = tf1(&[20.0], &[1.0, 0.0], tau);
        assert!(!nyquist_stable(&unstable).unwrap());
    }

    #[test]
    fn nyquist_counts_open_loop_rhp_poles() {
        // L = 10(s+3)/((s−1)(s+8)): closed-loop char. poly s² + 17s + 22, stable (Routh).
        assert!(nyquist_stable(&tf1(&[10.0, 30.0], &[1.0, 7.0, -8.0], 0.0)).unwrap());
        // L = 2/(s−1)·1/(s+8): char. poly s² + 7s − 6, unstable.
        assert!(!nyquist_stable(&tf1(&[2.0], &[1.0, 7.0, -8.0], 0.0)).unwrap());
    }

    #[test]
    fn mimo_is_rejected() {
        let g = StateSpace::gain(Mat::identity(2, 2), 0.0).unwrap();
        assert!(allmargin(&g).is_err());
        assert!(diskmargin(&g).is_err());
    }
}
