//! One log's side of a comparison, per axis: the closed-loop tracking response setpoint → gyro
//! (SPAFDR on a grid both logs share, with its random error), the plant PID sum → gyro
//! ([`crate::identify::identify_log`], the `identify --axis` preset), the causal step
//! ([`crate::tune::fir_step::causal_step`]) and the gyro noise spectrum
//! ([`crate::noise::analyze_log`]). Each part that cannot be had is kept as its reason.

use super::{Measured, NoiseBands, Plant, StepSummary, Tracking, COHERENCE_MIN};
use crate::error::{Error, Result};
use crate::firmware::Axis;
use crate::identify::airborne_segments;
use crate::identify::{identify_log, IdentifyRequest};
use crate::noise::{AxisNoise, NoiseAnalysis};
use skyloop_lti::timeresp::stepinfo;
use skyloop_sysid::logs::Span;
use skyloop_sysid::logs::{Log, UniformData};
use skyloop_sysid::spectral::{estimate_records, IoData, Method, Options};
use std::ops::Range;

/// Length of the step response, s (PID-Analyzer's 0.5 s).
pub const STEP_RESPONSE_S: f64 = 0.5;
/// Frequencies of the tracking response (logarithmic, SPAFDR).
pub const TRACKING_POINTS: usize = 80;
/// Lowest frequency of the tracking response, Hz.
pub const TRACKING_FMIN_HZ: f64 = 1.0;
/// Highest frequency of the tracking response, Hz (at most 1/2.5 of either log's rate).
pub const TRACKING_FMAX_HZ: f64 = 150.0;
/// Lower edge of the high noise band, Hz (motor and frame noise; below it, flight motion).
pub const NOISE_SPLIT_HZ: f64 = 100.0;
/// Lower edge of the low noise band, Hz.
pub const NOISE_LOW_HZ: f64 = 20.0;

/// The setpoint, gyro and airborne ranges of one axis, resampled.
pub struct AxisData {
    /// Setpoint and gyro, uniform.
    pub data: UniformData,
    /// Sample ranges of the airborne segments.
    pub ranges: Vec<Range<usize>>,
    /// The airborne time, s.
    pub airborne_s: f64,
    /// The gyro's unit.
    pub unit: &'static str,
}

/// The setpoint and gyro of `axis` over the airborne segments `identify --axis` uses.
///
/// # Errors
/// A log without the axis' channels (named), or without an airborne segment.
pub fn axis_data(log: &Log, axis: Axis) -> Result<AxisData> {
    let ch = crate::firmware::rate_loop_channels(log, axis)?;
    let crit = crate::firmware::airborne_criteria(log)?;
    let data = log.uniform(&[ch.instrument.as_str(), ch.output.as_str()], None, None, None)?;
    if data.len() < 2 {
        return Err(Error::Input(format!(
            "{}: fewer than 2 samples of {}",
            log.source, ch.output
        )));
    }
    let t_end = data.t0_s + (data.len() - 1) as f64 * data.dt_s;
    let air = airborne_segments(log, &ch.output, &crit, Some(data.t0_s), Some(t_end))?;
    let ranges: Vec<Range<usize>> = air
        .segments
        .iter()
        .map(|s| data.range_of(s))
        .filter(|r| r.len() > 1)
        .collect();
    if ranges.is_empty() {
        return Err(Error::Input(format!("{}: no airborne segment", log.source)));
    }
    Ok(AxisData {
        data,
        ranges,
        airborne_s: air.segments.iter().map(Span::len_s).sum(),
        unit: ch.output_unit,
    })
}

/// The tracking response setpoint → gyro on `fmin_hz..fmax_hz` (SPAFDR, [`TRACKING_POINTS`]
/// logarithmic frequencies, so two logs share the grid whatever their rates).
///
/// # Errors
/// Too little airborne data for the estimate.
pub fn tracking(d: &AxisData, fmax_hz: f64) -> Result<Tracking> {
    let recs: Vec<IoData> = d
        .ranges
        .iter()
        .filter(|r| r.len() > 64)
        .map(|r| IoData {
            u: &d.data.columns[0][r.clone()],
            y: &d.data.columns[1][r.clone()],
            r: None,
            dist: None,
            dt_s: d.data.dt_s,
        })
        .collect();
    let opts = Options {
        method: Method::Spafdr,
        fmin_hz: Some(TRACKING_FMIN_HZ),
        fmax_hz: Some(fmax_hz),
        n_freq: TRACKING_POINTS,
        ..Options::default()
    };
    let frf = estimate_records(&recs, &opts)?;
    let db = 20.0 / std::f64::consts::LN_10;
    let std_db: Vec<f64> = frf.rel_std().iter().map(|e| db * e).collect();
    let std_deg: Vec<f64> = frf.rel_std().iter().map(|e| e.to_degrees()).collect();
    Ok(Tracking::new(
        frf.freq_hz.clone(),
        frf.mag_db(),
        anchor_phase(&frf.phase_deg(), &frf.coherence),
        std_db,
        std_deg,
        frf.coherence.clone(),
    ))
}

/// The causal FIR step of the setpoint → gyro, with its 10–90 % rise time and overshoot against
/// the response's final value (the mean of its last quarter).
///
/// # Errors
/// Too little data with stick input.
pub fn step(d: &AxisData) -> Result<StepSummary> {
    let s = crate::tune::fir_step::causal_step(
        &d.data.columns[0],
        &d.data.columns[1],
        d.data.dt_s,
        &d.ranges,
        STEP_RESPONSE_S,
    )?;
    // The last taps absorb whatever the response does beyond the window (a spike at the end):
    // they are dropped, as is everything after 90 % of the window.
    let keep = (s.y.len() * 9 / 10).max(2).min(s.y.len());
    let (t_s, y, y_std) = (s.t_s[..keep].to_vec(), s.y[..keep].to_vec(), s.y_std[..keep].to_vec());
    let n = y.len();
    let tail = &y[n - (n / 4).max(1)..];
    let final_value = tail.iter().sum::<f64>() / tail.len() as f64;
    let info = stepinfo(&t_s, &y, Some(final_value));
    let peak = (0..n).max_by(|&a, &b| y[a].total_cmp(&y[b])).unwrap_or(0);
    Ok(StepSummary {
        rise_time_ms: info.rise_time_s.map(|t| 1e3 * t),
        overshoot_pct: info.overshoot_pct,
        overshoot_std_pct: if final_value > 0.0 {
            100.0 * y_std[peak] / final_value
        } else {
            f64::NAN
        },
        final_value,
        acausal_fraction: s.acausal_fraction,
        t_s,
        y,
        y_std,
    })
}

/// The plant PID sum → gyro as `identify LOG --axis` gives it.
///
/// # Errors
/// The identification's own refusals (too little excitation, a poor fit).
pub fn plant(log: &Log, path: &std::path::Path, session: Option<usize>, axis: Axis) -> Result<Plant> {
    let req = IdentifyRequest {
        data: path.to_path_buf(),
        axis: Some(axis.name().to_string()),
        session,
        ..Default::default()
    };
    let id = identify_log(log, &req)?;
    let (_, fit) = id
        .fit
        .as_ref()
        .ok_or_else(|| Error::Failed("the identification gave no parametric fit".into()))?;
    let get = |n: &str| -> (f64, f64) {
        (
            fit.params.get(n).copied().unwrap_or(f64::NAN),
            fit.stderr.get(n).copied().unwrap_or(f64::NAN),
        )
    };
    let db = 20.0 / std::f64::consts::LN_10;
    Ok(Plant {
        freq_hz: id.frf.freq_hz.clone(),
        mag_db: id.frf.mag_db(),
        phase_deg: anchor_phase(&id.frf.phase_deg(), &id.frf.coherence),
        std_db: id.frf.rel_std().iter().map(|e| db * e).collect(),
        coherence: id.frf.coherence.clone(),
        k: get("K"),
        tau_s: get("tau"),
        td_s: get("Td"),
        tz_s: fit.params.contains_key("Tz").then(|| get("Tz")),
        fit_percent: fit.fit_percent,
        gain_unit: id
            .units
            .as_ref()
            .and_then(|u| u.params.get("K").cloned())
            .unwrap_or_default(),
        fit_band_hz: id.fit_band_hz,
    })
}

/// The gyro noise of `axis` from the noise picture: the logged (filtered) gyro's PSD and its
/// power in [`NOISE_LOW_HZ`]..[`NOISE_SPLIT_HZ`] and from there to `top_hz` (the lower of the two
/// logs' Nyquist frequencies, so that both bands span the same frequencies).
pub fn noise(analysis: &Measured<NoiseAnalysis>, axis: Axis, top_hz: f64) -> Measured<NoiseBands> {
    let an = analysis.as_ref().map_err(Clone::clone)?;
    let a: &AxisNoise = an
        .axes
        .iter()
        .find(|x| x.axis.name() == axis.name())
        .ok_or_else(|| format!("no {} axis in the noise picture", axis.name()))?;
    let (_, psd) = a
        .spectra
        .iter()
        .find(|(n, _)| *n == "gyro")
        .ok_or_else(|| "the noise picture holds no gyro spectrum".to_string())?;
    let band = |lo: f64, hi: f64| band_power_db(&a.freq_hz, psd, lo, hi);
    let nyq = a.freq_hz.last().copied().unwrap_or(0.0);
    let top = nyq.min(top_hz);
    Ok(NoiseBands {
        freq_hz: a.freq_hz.clone(),
        psd_db: psd.clone(),
        low_db: band(NOISE_LOW_HZ, NOISE_SPLIT_HZ),
        // Up to and including the top bin.
        high_db: band(NOISE_SPLIT_HZ, top + 1e-9),
        high_top_hz: top,
        nyquist_hz: nyq,
        unit: an.units[0],
        frames: an.frames,
    })
}

/// 10·log10 of the PSD (given in dB) integrated over [lo, hi) Hz: the band's mean square in dB re
/// 1 unit²; None when the band holds fewer than 2 bins.
pub fn band_power_db(freq_hz: &[f64], psd_db: &[f64], lo: f64, hi: f64) -> Option<f64> {
    let df = match freq_hz {
        [a, b, ..] => b - a,
        _ => return None,
    };
    let inside: Vec<f64> = freq_hz
        .iter()
        .zip(psd_db)
        .filter(|(f, p)| **f >= lo && **f < hi && p.is_finite())
        .map(|(_, p)| 10f64.powf(p / 10.0))
        .collect();
    (inside.len() >= 2).then(|| 10.0 * (inside.iter().sum::<f64>() * df).log10())
}

/// The highest frequency of a noise picture, Hz (its Nyquist frequency), if any.
pub fn noise_top_hz(analysis: &Measured<NoiseAnalysis>) -> Option<f64> {
    let an = analysis.as_ref().ok()?;
    an.axes.first().and_then(|a| a.freq_hz.last().copied())
}

/// `(t, y)` sampled at `at` by linear interpolation (held at the ends).
pub fn resample(t: &[f64], y: &[f64], at: &[f64]) -> Vec<f64> {
    at.iter()
        .map(|&x| {
            let k = t.partition_point(|&v| v <= x);
            match k {
                0 => y.first().copied().unwrap_or(f64::NAN),
                k if k >= t.len() => y.last().copied().unwrap_or(f64::NAN),
                k => {
                    let s = (x - t[k - 1]) / (t[k] - t[k - 1]);
                    y[k - 1] + s * (y[k] - y[k - 1])
                }
            }
        })
        .collect()
}

/// `phase` (unwrapped, degrees) shifted by a whole number of turns so that its value at the most
/// coherent point lies in (−270°, 90°]: two logs' curves then start from the same turn.
pub fn anchor_phase(phase: &[f64], coherence: &[f64]) -> Vec<f64> {
    let k = (0..phase.len().min(coherence.len()))
        .filter(|&k| phase[k].is_finite())
        .max_by(|&a, &b| coherence[a].total_cmp(&coherence[b]));
    let Some(k) = k else {
        return phase.to_vec();
    };
    let turns = ((phase[k] - 90.0) / 360.0).ceil();
    phase.iter().map(|p| p - 360.0 * turns).collect()
}

/// True where the tracking estimate is trusted: squared coherence at least [`COHERENCE_MIN`].
pub fn coherent(c: f64) -> bool {
    c >= COHERENCE_MIN
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn band_power_of_a_flat_spectrum() {
        // 1 unit²/Hz (0 dB) over 100 Hz of 1 Hz bins: 100 unit², 20 dB.
        let f: Vec<f64> = (0..500).map(f64::from).collect();
        let p = vec![0.0; 500];
        let v = band_power_db(&f, &p, 100.0, 200.0).unwrap();
        assert!((v - 20.0).abs() < 1e-9, "{v}");
        assert!(band_power_db(&f, &p, 600.0, 700.0).is_none());
    }

    #[test]
    fn phase_is_anchored_to_one_turn() {
        let p = anchor_phase(&[170.0, 160.0, 100.0], &[0.2, 0.9, 0.5]);
        assert_eq!(p, vec![-190.0, -200.0, -260.0]);
        // Already in range at the most coherent point: unchanged.
        let p = anchor_phase(&[-10.0, -400.0], &[0.9, 0.5]);
        assert_eq!(p, vec![-10.0, -400.0]);
        // Anchored at −400°: one turn up.
        let p = anchor_phase(&[-10.0, -400.0], &[0.5, 0.9]);
        assert_eq!(p, vec![350.0, -40.0]);
    }

    #[test]
    fn resampling_interpolates_and_holds_the_ends() {
        let v = resample(&[0.0, 1.0, 2.0], &[0.0, 10.0, 20.0], &[-1.0, 0.5, 1.5, 3.0]);
        assert_eq!(v, vec![0.0, 5.0, 15.0, 20.0]);
    }
}
