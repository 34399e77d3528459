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
/// The span the error is integrated over after the ramp, s.
const SETTLE_S: f64 = 0.3;

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
    for (name, m) in [("plant", plant), ("C_fb", c_fb), ("C_r0", c_r0), ("C_f", c_f)] {
        if m.ny() != 1 || m.nu() != 1 || m.dt != 0.0 {
            return Err(Error::Input(format!(
                "feedforward fit: {name} must be a continuous SISO model"
            )));
        }
    }
    if !(max_gain.is_finite() && max_gain >= 0.0) {
        return Err(Error::Input(format!(
            "feedforward fit: the largest gain must be finite and >= 0, got {max_gain}"
        )));
    }
    let pp = plant.try_pade(6)?;
    let closed = feedback(&pp, c_fb, -1.0)?;
    if skyloop_lti::poles_zeros::poles(&closed)?.iter().any(|l| l.re >= 0.0) {
        return Err(Error::Failed(
            "feedforward fit: the feedback loop is unstable, a setpoint move would not settle".into(),
        ));
    }
    let n = RAMP_MS + (SETTLE_S * 1e3).round() as usize;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
    let r: Vec<f64> = (0..n).map(|k| ((k + 1) as f64 / RAMP_MS as f64).min(1.0)).collect();
    let u: Vec<Vec<f64>> = r.iter().map(|&v| vec![v]).collect();
    let run = |c: &StateSpace| -> Result<Vec<f64>> {
        Ok(lsim(&series(c, &closed)?, &u, &t, None)?
            .y
            .into_iter()
            .map(|row| row[0])
            .collect())
    };
    let y0 = run(c_r0)?;
    let y1 = run(c_f)?;
    // The ramp's own samples lead the output by design; ISE over the whole span.
    let e0: Vec<f64> = r.iter().zip(&y0).map(|(r, y)| r - y).collect();
    let num: f64 = e0.iter().zip(&y1).map(|(e, d)| e * d).sum();
    let den: f64 = y1.iter().map(|d| d * d).sum();
    let ise_optimal = if den > 0.0 { num / den } else { 0.0 };
    // y0 + f·y1 ≤ cap for every sample: an interval of f, holding f = 0.
    let peak0 = y0.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b));
    let cap = (1.0 + OVERSHOOT_MAX_PCT / 100.0).max(peak0);
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for (a, b) in y0.iter().zip(&y1) {
        if *b > 0.0 {
            hi = hi.min((cap - a) / b);
        } else if *b < 0.0 {
            lo = lo.max((cap - a) / b);
        }
    }
    let peak_at = |f: f64| {
        y0.iter()
            .zip(&y1)
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
    let ise = |f: f64| -> f64 { e0.iter().zip(&y1).map(|(e, d)| (e - f * d).powi(2)).sum() };
    let peak = peak_at(gain);
    let base = ise(0.0);
    Ok(FeedforwardFit {
        gain,
        ise_optimal,
        overshoot_pct: 100.0 * (peak - 1.0).max(0.0),
        ise_ratio: if base > 0.0 { ise(gain) / base } else { 1.0 },
        overshoot_without_pct: 100.0 * (peak0 - 1.0).max(0.0),
        limited_by,
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use skyloop_lti::expr::parse_model;

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
            let t: Vec<f64> = (0..325).map(|k| k as f64 * 1e-3).collect();
            let u: Vec<Vec<f64>> = (0..325).map(|k| vec![((k + 1) as f64 / 25.0).min(1.0)]).collect();
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
