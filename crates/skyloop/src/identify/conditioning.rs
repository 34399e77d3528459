//! Whether the throttle is conditioned out of an `--axis` identification's spectra: only where it
//! makes the estimate more exact.
//!
//! Removing a measured disturbance helps when it drives the gyro on its own (a yaw axis whose motors
//! and props differ, a frame whose centre of gravity is off): the gyro's unexplained part shrinks.
//! It hurts when the pilot moves the throttle with the stick (forward flight: pitch down and throttle
//! up together), since the part of the setpoint that moves with the throttle is removed too. The
//! estimate's own random error tells the two apart, so both are estimated and the more exact kept.

use super::estimate::Estimator;
use super::remarks::Remarks;
use super::request::IdentifyRequest;
use super::segments::Selection;
use super::Channels;
use super::PILOT_LOOP_HZ;
use crate::error::Result;
use skyloop_sysid::spectral::Frf;

/// The conditioned estimate is kept when its equivalent random error ([`equivalent_error`]) is at
/// most this fraction of the plain estimate's: a gain within the estimates' own scatter is not worth
/// the extra input.
pub(crate) const MIN_ERROR_RATIO: f64 = 0.9;

/// The estimate's equivalent random error of |G| over the points at or above [`PILOT_LOOP_HZ`]:
/// 1/√(mean of 1/e²), e the point's [`Frf::rel_std`]. The mean of inverse variances is the
/// information a weighted fit draws from the points, so the measure follows the points that decide
/// the fit, not the many poorly determined ones far above the rate loop's band. Infinite without
/// points.
pub(crate) fn equivalent_error(frf: &Frf) -> f64 {
    let info: Vec<f64> = frf
        .freq_hz
        .iter()
        .zip(frf.rel_std())
        .filter(|(f, e)| **f >= PILOT_LOOP_HZ && e.is_finite() && *e > 0.0)
        .map(|(_, e)| 1.0 / (e * e))
        .collect();
    if info.is_empty() {
        return f64::INFINITY;
    }
    (info.len() as f64 / info.iter().sum::<f64>()).sqrt()
}

/// Drops the preset's disturbance from `ch` unless conditioning on it lowers the equivalent random
/// error to [`MIN_ERROR_RATIO`] of the plain estimate's or less; a disturbance the request named
/// (`--disturbance`) is kept as asked. Notes the choice with both errors.
///
/// # Errors
/// Options the estimator refuses (the same the identification itself would refuse).
pub(crate) fn choose(
    a: &IdentifyRequest,
    ch: &mut Channels,
    sel: &Selection,
    fmax_hz: Option<f64>,
    rm: &mut Remarks,
) -> Result<()> {
    let Some(d) = ch.disturbance.clone() else {
        return Ok(());
    };
    let has_r = ch.excitation.is_some();
    let mut scratch = Remarks::default();
    let frf = |with: bool, scratch: &mut Remarks| -> Result<Frf> {
        Estimator::new(
            a,
            &sel.data,
            &sel.ranges,
            has_r,
            with,
            ch.preset.is_none(),
            fmax_hz,
            scratch,
        )?
        .frf_of(&sel.ranges)
    };
    if a.disturbance.is_some() {
        let with = frf(true, &mut scratch)?;
        rm.note(format!(
            "measured disturbance {d} (as asked): its linear effect on the output is removed from the spectra (equivalent random error above {PILOT_LOOP_HZ} Hz {:.2})",
            equivalent_error(&with)
        ));
        return Ok(());
    }
    let plain = equivalent_error(&frf(false, &mut scratch)?);
    let with = frf(true, &mut scratch).map_or(f64::INFINITY, |f| equivalent_error(&f));
    if with <= MIN_ERROR_RATIO * plain {
        rm.note(format!(
            "throttle {d} conditioned out of the spectra (its linear effect on the gyro removed: unequal motors and props or an offset centre of gravity make throttle changes torque the frame): the equivalent random error above {PILOT_LOOP_HZ} Hz falls from {plain:.2} to {with:.2}"
        ));
    } else {
        rm.note(format!(
            "throttle {d} not conditioned out: removing it would leave the equivalent random error above {PILOT_LOOP_HZ} Hz at {with:.2} against {plain:.2} without (the throttle moves with this axis' stick, or drives no torque)"
        ));
        ch.disturbance = None;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex64 as C64;

    fn frf(freq_hz: Vec<f64>, coherence: Vec<f64>) -> Frf {
        let n = freq_hz.len();
        Frf {
            freq_hz,
            response: vec![C64::new(1.0, 0.0); n],
            coherence,
            dof: vec![20.0; n],
            bandwidth_hz: vec![0.0; n],
        }
    }

    /// The equivalent error is the inverse-variance mean over the points from 2 Hz: the exact points
    /// decide it, the many poor ones far above the band hardly move it, and points below 2 Hz do not
    /// count.
    #[test]
    fn equivalent_error_follows_the_exact_points() {
        let one = frf(vec![1.0, 3.0, 10.0], vec![0.99, 0.5, 0.5]);
        let e = one.rel_std()[1];
        assert!((equivalent_error(&one) - e).abs() < 1e-12 * e);
        let with_poor = frf(vec![3.0, 10.0, 100.0, 200.0], vec![0.5, 0.5, 0.005, 0.005]);
        let e_poor = with_poor.rel_std()[2];
        assert!(e_poor > 10.0 * e);
        let want = (4.0 / (2.0 / (e * e) + 2.0 / (e_poor * e_poor))).sqrt();
        assert!((equivalent_error(&with_poor) - want).abs() < 1e-12 * want);
        assert!(equivalent_error(&with_poor) < 1.5 * e);
        assert!(equivalent_error(&frf(vec![1.0], vec![0.5])).is_infinite());
    }
}
