//! The setpoint feedforward (Betaflight's F, PX4's `MC_*RATE_FF`) for a tuned feedback loop.
//!
//! The feedforward acts on the setpoint only, so it changes no margin; it decides how closely
//! the rate follows a stick move. The reference path is affine in its gain f,
//! C_r = C_r0 + f·C_f (Betaflight: C_f = s/(T·s + 1) on the setpoint, T the loop period; PX4:
//! C_f = 1), so the rate's response to a setpoint move is y(f) = y0 + f·y1 exactly, with y0 and y1
//! the responses of P·C_r0/(1 + P·C_fb) and P·C_f/(1 + P·C_fb).
//!
//! The move is the one the nonlinear check flies ([`super::flight`]): 0 → 1 as a staircase of
//! 1 ms steps over 25 ms (a fast stick move after RC smoothing). The gain:
//! 1. minimizes the integral of the squared tracking error (ISE) over the move and 0.3 s after,
//!    in closed form (a least-squares problem in one unknown);
//! 2. is then lowered, if needed, until the predicted overshoot is at most
//!    [`OVERSHOOT_MAX_PCT`] (the overshoot is the maximum of functions affine in f, so the gains
//!    that keep it are an interval, found exactly);
//! 3. is kept within the firmware's range.
//!
//! Delays inside the loop are Padé approximants of order 6 here (as the predicted step); the
//! linear model has no motor saturation, which the nonlinear check then adds.

use crate::error::{Error, Result};
use skyloop_lti::interconnect::{feedback, series};
use skyloop_lti::timeresp::lsim;
use skyloop_lti::StateSpace;

/// Largest predicted overshoot of the ramped move the feedforward may cause, % of the move.
/// (or the loop's own overshoot, where that is larger).
pub const OVERSHOOT_MAX_PCT: f64 = 10.0;
/// The move's ramp: steps of 1 ms over this many milliseconds (as the nonlinear check).
const RAMP_MS: usize = 25;
/// The span the error is integrated over (ramp included) for a loop that crosses over above
/// 61.5 rad/s, s; slower loops get 20/ω_c.
const SPAN_S: f64 = 0.325;

/// The chosen feedforward gain and what it predicts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeedforwardFit {
    /// The gain f (C_r = C_r0 + f·C_f), in the path's own unit.
    pub gain: f64,
    /// The gain of least ISE, before the overshoot cap and the range.
    pub ise_optimal: f64,
    /// Predicted overshoot of the move with `gain`, % of the move.
    pub overshoot_pct: f64,
    /// ISE of the move with `gain` over the ISE without feedforward (< 1: tracks better).
    pub ise_ratio: f64,
    /// Predicted overshoot of the move without feedforward, % of the move.
    pub overshoot_without_pct: f64,
    /// What set the gain: `"tracking error"` (the ISE optimum), `"overshoot"` (the cap) or
    /// `"range"`.
    pub limited_by: &'static str,
}

/// Fits the feedforward gain in `[0, max_gain]` (see the module documentation).
///
/// `plant` is the loop's plant (hold delay included), `c_fb` the feedback controller (y → u),
/// `c_r0` the reference path without feedforward (r → u) and `c_f` the feedforward's unit path.
///
/// # Errors
/// Non-SISO models, an unstable loop (the move would not settle), or a simulation error.
///
/// # Examples
/// ```
/// use skyloop::lti::expr::parse_model;
/// use skyloop::tune::feedforward::fit;
/// // A PI loop around 100/(s(0.01s+1)): a constant feedforward speeds the move up.
/// let p = parse_model("100/(s*(0.01*s+1))")?;
/// let c = parse_model("0.3+0.2/s")?;
/// let ff = fit(&p, &c, &c, &parse_model("1")?, 10.0)?;
/// assert!(ff.gain > 0.0 && ff.ise_ratio < 1.0 && ff.overshoot_pct <= 10.0 + 1e-9);
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn fit(
    plant: &StateSpace,
    c_fb: &StateSpace,
    c_r0: &StateSpace,
    c_f: &StateSpace,
    max_gain: f64,
) -> Result<FeedforwardFit> {
    check_siso(&[("plant", plant), ("C_fb", c_fb), ("C_r0", c_r0), ("C_f", c_f)])?;
    if !(max_gain.is_finite() && max_gain >= 0.0) {
        return Err(Error::Input(format!(
            "feedforward fit: the largest gain must be finite and >= 0, got {max_gain}"
        )));
    }
    let (r, ys) = responses(plant, c_fb, &[c_r0, c_f])?;
    let cap = cap_of(&ys[0]);
    Ok(best_gain(&r, &ys[0], &ys[1], max_gain, cap))
}

fn check_siso(models: &[(&str, &StateSpace)]) -> Result<()> {
    for (name, m) in models {
        if m.ny() != 1 || m.nu() != 1 || m.dt != 0.0 {
            return Err(Error::Input(format!(
                "feedforward fit: {name} must be a continuous SISO model"
            )));
        }
    }
    Ok(())
}

/// The overshoot cap for responses around `y0`: [`OVERSHOOT_MAX_PCT`], or y0's own peak where
/// that is higher.
fn cap_of(y0: &[f64]) -> f64 {
    let peak0 = y0.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b));
    (1.0 + OVERSHOOT_MAX_PCT / 100.0).max(peak0)
}

/// The ramp and the closed loop's response to it through each reference path.
fn responses(plant: &StateSpace, c_fb: &StateSpace, paths: &[&StateSpace]) -> Result<(Vec<f64>, Vec<Vec<f64>>)> {
    let pp = plant.try_pade(6)?;
    let closed = feedback(&pp, c_fb, -1.0)?;
    if skyloop_lti::poles_zeros::poles(&closed)?.iter().any(|l| l.re >= 0.0) {
        return Err(Error::Failed(
            "feedforward fit: the feedback loop is unstable, a setpoint move would not settle".into(),
        ));
    }
    // A rate loop settles within the span; a slower loop gets 20/ω_c at most 2000 samples (the
    // ramp then is a step within one sample).
    let wc = skyloop_lti::margins::margin(&series(c_fb, &pp)?)
        .map(|m| m.pm_w_rad_s)
        .unwrap_or(f64::NAN);
    let span = if wc.is_finite() && wc > 0.0 {
        (20.0 / wc).clamp(SPAN_S, 1e4)
    } else {
        SPAN_S
    };
    let dt = (span / 2000.0).max(1e-3);
    let n = (span / dt).ceil() as usize;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
    let r: Vec<f64> = (0..n)
        .map(|k| ((k + 1) as f64 * dt / (RAMP_MS as f64 * 1e-3)).min(1.0))
        .collect();
    let u: Vec<Vec<f64>> = r.iter().map(|&v| vec![v]).collect();
    let ys = paths
        .iter()
        .map(|c| -> Result<Vec<f64>> {
            Ok(lsim(&series(c, &closed)?, &u, &t, None)?
                .y
                .into_iter()
                .map(|row| row[0])
                .collect())
        })
        .collect::<Result<_>>()?;
    Ok((r, ys))
}

/// The gain f in [0, max_gain] of least ISE for y = y0 + f·y1 with every sample ≤ `cap`
/// (`cap` ≥ max y0, so f = 0 is allowed).
fn best_gain(r: &[f64], y0: &[f64], y1: &[f64], max_gain: f64, cap: f64) -> FeedforwardFit {
    // The ramp's own samples lead the output by design; ISE over the whole span.
    let e0: Vec<f64> = r.iter().zip(y0).map(|(r, y)| r - y).collect();
    let num: f64 = e0.iter().zip(y1).map(|(e, d)| e * d).sum();
    let den: f64 = y1.iter().map(|d| d * d).sum();
    let ise_optimal = if den > 0.0 { num / den } else { 0.0 };
    // y0 + f·y1 ≤ cap for every sample: an interval of f, holding f = 0.
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for (a, b) in y0.iter().zip(y1) {
        if *b > 0.0 {
            hi = hi.min((cap - a) / b);
        } else if *b < 0.0 {
            lo = lo.max((cap - a) / b);
        }
    }
    let peak_at = |f: f64| {
        y0.iter()
            .zip(y1)
            .map(|(a, b)| a + f * b)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let (lo, hi) = (lo.max(0.0), hi.min(max_gain));
    let (gain, limited_by) = if ise_optimal > hi {
        (hi, if hi == max_gain { "range" } else { "overshoot" })
    } else if ise_optimal < lo {
        (lo, "range")
    } else {
        (ise_optimal, "tracking error")
    };
    let ise = |f: f64| -> f64 { e0.iter().zip(y1).map(|(e, d)| (e - f * d).powi(2)).sum() };
    let base = ise(0.0);
    FeedforwardFit {
        gain,
        ise_optimal,
        overshoot_pct: 100.0 * (peak_at(gain) - 1.0).max(0.0),
        ise_ratio: if base > 0.0 { ise(gain) / base } else { 1.0 },
        overshoot_without_pct: 100.0 * (peak_at(0.0) - 1.0).max(0.0),
        limited_by,
    }
}

/// The setpoint weights of a two-degree-of-freedom PID (MATLAB's `pid2`):
/// u = kp·(b·r − y) + ki/s·(r − y) + kd·s/(tf·s + 1)·(c·r − y).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SetpointWeights {
    /// Weight of the setpoint in P, in [0, 1].
    pub b: f64,
    /// Weight of the setpoint in D, in [0, 1].
    pub c: f64,
    /// Predicted overshoot of the ramped move with (b, c), %.
    pub overshoot_pct: f64,
    /// Predicted overshoot of the one-degree-of-freedom PID (b = c = 1), %.
    pub overshoot_one_dof_pct: f64,
    /// ISE of the move with (b, c) over the one-degree-of-freedom PID's.
    pub ise_ratio_one_dof: f64,
}

/// Fits the setpoint weights (b, c) ∈ [0, 1]² of a two-degree-of-freedom PID to the tuned
/// feedback loop, by the criterion of [`fit`]: the least squared tracking error of the ramped
/// move, adding no overshoot beyond [`OVERSHOOT_MAX_PCT`] (or the overshoot with b = c = 0, the
/// slowest reference path, where that is larger). The reference path is
/// `i_path + b·p_path + c·d_path`; b is solved exactly for each c on a grid of step 0.01.
///
/// # Errors
/// As [`fit`].
pub fn fit_setpoint_weights(
    plant: &StateSpace,
    c_fb: &StateSpace,
    i_path: &StateSpace,
    p_path: &StateSpace,
    d_path: &StateSpace,
) -> Result<SetpointWeights> {
    check_siso(&[
        ("plant", plant),
        ("C_fb", c_fb),
        ("I path", i_path),
        ("P path", p_path),
        ("D path", d_path),
    ])?;
    let (r, ys) = responses(plant, c_fb, &[i_path, p_path, d_path])?;
    let (yi, yp, yd) = (&ys[0], &ys[1], &ys[2]);
    let cap = cap_of(yi);
    let ise_of = |b: f64, c: f64| -> f64 {
        (0..r.len())
            .map(|k| (r[k] - yi[k] - b * yp[k] - c * yd[k]).powi(2))
            .sum()
    };
    let peak_of = |b: f64, c: f64| -> f64 {
        (0..r.len())
            .map(|k| yi[k] + b * yp[k] + c * yd[k])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let mut best: Option<(f64, f64, f64)> = None;
    for step in 0..=100 {
        let c = step as f64 / 100.0;
        let y0: Vec<f64> = yi.iter().zip(yd).map(|(a, d)| a + c * d).collect();
        if y0.iter().any(|&v| v > cap) {
            continue;
        }
        let b = best_gain(&r, &y0, yp, 1.0, cap).gain;
        let e = ise_of(b, c);
        if best.is_none_or(|(_, _, be)| e < be) {
            best = Some((b, c, e));
        }
    }
    // c = 0 with b = 0 is the I-only path, which the cap always admits.
    let (b, c, e) = best.unwrap_or((0.0, 0.0, ise_of(0.0, 0.0)));
    let one = ise_of(1.0, 1.0);
    Ok(SetpointWeights {
        b,
        c,
        overshoot_pct: 100.0 * (peak_of(b, c) - 1.0).max(0.0),
        overshoot_one_dof_pct: 100.0 * (peak_of(1.0, 1.0) - 1.0).max(0.0),
        ise_ratio_one_dof: if one > 0.0 { e / one } else { 1.0 },
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use skyloop_lti::expr::parse_model;

    /// The documented span and ramp for a loop: 0.325 s at 1 ms, or 20/ω_c in 2000 samples.
    fn ramp_grid(c_fb: &StateSpace, pp: &StateSpace) -> (Vec<f64>, Vec<Vec<f64>>) {
        let wc = skyloop_lti::margins::margin(&series(c_fb, pp).unwrap())
            .unwrap()
            .pm_w_rad_s;
        let span = (20.0 / wc).max(0.325);
        let dt = (span / 2000.0).max(1e-3);
        let n = (span / dt).ceil() as usize;
        let t = (0..n).map(|k| k as f64 * dt).collect();
        let u = (0..n).map(|k| vec![((k + 1) as f64 * dt / 0.025).min(1.0)]).collect();
        (t, u)
    }

    /// The ISE optimum against a brute-force scan of the same simulated error, for Betaflight's
    /// derivative feedforward on a roll axis in its units (where it matters: the loop alone lags
    /// a 25 ms ramp).
    #[test]
    fn the_gain_minimizes_the_tracking_error_and_respects_the_cap() {
        let p = parse_model("400*exp(-0.003*s)/(s*(0.025*s+1))").unwrap();
        let unit = parse_model("s/(0.00025*s+1)").unwrap();
        let pp = p.try_pade(6).unwrap();
        let score = |c: &StateSpace, f: f64| {
            let cr =
                skyloop_lti::interconnect::parallel(c, &parse_model(&format!("{f}*s/(0.00025*s+1)")).unwrap()).unwrap();
            let cl = series(&cr, &feedback(&pp, c, -1.0).unwrap()).unwrap();
            let (t, u) = ramp_grid(c, &pp);
            let y = lsim(&cl, &u, &t, None).unwrap().y;
            let ise: f64 = u.iter().zip(&y).map(|(r, y)| (r[0] - y[0]).powi(2)).sum();
            let peak = y.iter().map(|y| y[0]).fold(f64::NEG_INFINITY, f64::max);
            (ise, peak)
        };
        // The ISE optimum is about 1/K (the feedforward undoes the plant's integrator); a slow
        // loop takes it, a faster one is held to the cap, and one that overshoots by itself may
        // keep its own overshoot but add none.
        for (gains, limited_by) in [
            ("0.01+0.001/s", "tracking error"),
            ("0.02+0.003/s", "overshoot"),
            ("0.1+0.005/s", "overshoot"),
        ] {
            let c = parse_model(gains).unwrap();
            let ff = fit(&p, &c, &c, &unit, 1.0).unwrap();
            assert_eq!(ff.limited_by, limited_by, "{gains}: {ff:?}");
            let cap = OVERSHOOT_MAX_PCT.max(ff.overshoot_without_pct);
            assert!(ff.overshoot_pct <= cap + 1e-9, "{ff:?}");
            assert!(ff.gain > 0.0 && ff.ise_ratio < 0.995, "{ff:?}");
            assert!((ff.ise_optimal * 400.0 - 1.0).abs() < 0.15, "{ff:?}");
            let (ise, peak) = score(&c, ff.gain);
            assert!((100.0 * (peak - 1.0).max(0.0) - ff.overshoot_pct).abs() < 1e-6);
            if limited_by == "tracking error" {
                for d in [-0.05, 0.05] {
                    assert!(score(&c, ff.gain * (1.0 + d)).0 > ise, "{d}");
                }
            } else {
                assert!(ff.ise_optimal > ff.gain);
                let (_, peak) = score(&c, ff.gain * 1.01);
                assert!(100.0 * (peak - 1.0) > cap, "{peak}");
            }
        }
    }

    /// The 2-DOF weights against a brute-force grid over (b, c) of the same simulated move.
    #[test]
    fn setpoint_weights_match_a_grid_search() {
        let p = parse_model("exp(-0.05*s)/(s+1)^2").unwrap();
        let (kp, ki, kd, tf) = (2.0, 1.2, 0.8, 0.05);
        let c_fb = parse_model(&format!("{kp}+{ki}/s+{kd}*s/({tf}*s+1)")).unwrap();
        let ipath = parse_model(&format!("{ki}/s")).unwrap();
        let ppath = parse_model(&format!("{kp}")).unwrap();
        let dpath = parse_model(&format!("{kd}*s/({tf}*s+1)")).unwrap();
        let w = fit_setpoint_weights(&p, &c_fb, &ipath, &ppath, &dpath).unwrap();
        assert!((0.0..=1.0).contains(&w.b) && (0.0..=1.0).contains(&w.c), "{w:?}");
        let pp = p.try_pade(6).unwrap();
        let score = |b: f64, c: f64| {
            let cr = parse_model(&format!("{ki}/s+{}+{}*s/({tf}*s+1)", b * kp, c * kd)).unwrap();
            let cl = series(&cr, &feedback(&pp, &c_fb, -1.0).unwrap()).unwrap();
            let (t, u) = ramp_grid(&c_fb, &pp);
            let y = lsim(&cl, &u, &t, None).unwrap().y;
            let ise: f64 = u.iter().zip(&y).map(|(r, y)| (r[0] - y[0]).powi(2)).sum();
            let peak = y.iter().map(|y| y[0]).fold(f64::NEG_INFINITY, f64::max);
            (ise, peak)
        };
        let (ise, peak) = score(w.b, w.c);
        assert!((100.0 * (peak - 1.0).max(0.0) - w.overshoot_pct).abs() < 1e-6);
        let cap = 1.0 + OVERSHOOT_MAX_PCT.max(100.0 * (score(0.0, 0.0).1 - 1.0)) / 100.0;
        assert!(peak <= cap + 1e-9);
        // No admissible point of a coarse grid does better (the fit's c step is 0.01).
        for bi in 0..=10 {
            for ci in 0..=10 {
                let (e, pk) = score(bi as f64 / 10.0, ci as f64 / 10.0);
                if pk <= cap {
                    assert!(e >= ise * (1.0 - 1e-3), "b {bi} c {ci}: {e} < {ise}");
                }
            }
        }
        assert!(
            w.ise_ratio_one_dof <= 1.0 || w.overshoot_one_dof_pct > cap * 100.0 - 100.0,
            "{w:?}"
        );
    }

    #[test]
    fn range_and_unstable_loops_are_handled() {
        let p = parse_model("100/(s*(0.01*s+1))").unwrap();
        let c = parse_model("0.3+0.2/s").unwrap();
        let unit = parse_model("1").unwrap();
        let ff = fit(&p, &c, &c, &unit, 1e-3).unwrap();
        assert_eq!((ff.gain, ff.limited_by), (1e-3, "range"));
        let e = fit(&p, &parse_model("-1").unwrap(), &c, &unit, 1.0).unwrap_err();
        assert!(e.to_string().contains("unstable"), "{e}");
        let e = fit(&p, &c, &c, &unit, f64::NAN).unwrap_err();
        assert!(e.to_string().contains("largest gain"), "{e}");
    }
}
