//! The band a fit may use: where the instrument supports the estimate.

use std::ops::Range;

use skyloop_sysid::logs::segments_where;
use skyloop_sysid::spectral::Frf;

/// Squared coherence (averaged over a third of a decade) from which the instrument supports the
/// estimate: the random error of |G| is then at most √((1 − 0.2)/(2ν·0.2)), 20 % for ν = 50
/// averages. A pilot's setpoint in a real acro flight gives 0.2 to 0.5 up to about 7 Hz.
pub const COHERENT: f64 = 0.2;

/// Fewest averages behind a point of the coherent band (see [`coherent_band`]).
pub const MIN_DOF: f64 = 10.0;

/// The coherence-supported band: the widest run (in octaves) of frequencies where the coherence,
/// averaged over the points within a sixth of a decade either side, is at least [`COHERENT`] and
/// that average at least [`MIN_DOF`] times, as
/// (lowest, highest) frequency, Hz. The average keeps one noisy point from splitting the band; the
/// fit's inverse-variance weights then discount the weak points inside it.
pub fn coherent_band(frf: &Frf) -> Option<(f64, f64)> {
    let f = &frf.freq_hz;
    let smooth: Vec<f64> = (0..f.len())
        .map(|i| {
            let (lo, hi) = (f[i] * 10f64.powf(-1.0 / 6.0), f[i] * 10f64.powf(1.0 / 6.0));
            let near: Vec<f64> = (0..f.len())
                .filter(|&k| f[k] >= lo && f[k] <= hi)
                .map(|k| frf.coherence[k])
                .collect();
            near.iter().sum::<f64>() / near.len().max(1) as f64
        })
        .collect();
    // A coherence estimate from ν averages is biased up by about 1/ν (it is 1 for a single
    // periodogram), so points with fewer than MIN_DOF averages cannot vouch for themselves.
    let mask: Vec<bool> = (0..f.len())
        .map(|i| smooth[i] >= COHERENT && f[i] > 0.0 && frf.dof.get(i).copied().unwrap_or(0.0) >= MIN_DOF)
        .collect();
    let r = segments_where(&mask, 2).into_iter().max_by(|a, b| {
        let w = |r: &Range<usize>| f[r.end - 1] / f[r.start];
        w(a).total_cmp(&w(b))
    })?;
    Some((f[r.start], f[r.end - 1]))
}

/// Largest random error of |G| (normalized, one standard deviation; also the phase's in rad) a point
/// of the band [`supported_band`] chooses may have, averaged over a third of a decade: 25 % is about
/// ±2 dB and ±14°. What counts is the error, not the coherence alone: a long flight's many averages
/// make a point of low coherence as exact as a short test's point of high coherence.
pub const MAX_REL_ERR: f64 = 0.5;

/// Lowest frequency the `--axis` preset fits, Hz. A pilot flies an attitude loop around the rate loop:
/// below about 2 Hz the sticks answer the craft's motion and the disturbances acting on it, so the
/// setpoint is correlated with the noise and no longer an unbiased instrument. On the acro flight of
/// `btfl_all.bbl` the estimate below 2 Hz is flat in magnitude with more than 90° of lag, which no
/// rate loop (an integrator behind a lag) has; from 2 Hz up it follows one.
pub const PILOT_LOOP_HZ: f64 = 2.0;

/// The band an estimate supports: the widest run (in octaves) of frequencies at or above `fmin_hz`
/// where the random error of |G| ([`Frf::rel_std`], root-mean-square over the points within a sixth
/// of a decade either side) is at most [`MAX_REL_ERR`] and the estimate averages at least [`MIN_DOF`]
/// times, as (lowest, highest) frequency, Hz; `None` when no such run spans an octave.
pub fn supported_band(frf: &Frf, fmin_hz: f64) -> Option<(f64, f64)> {
    let f = &frf.freq_hz;
    let e = frf.rel_std();
    let smooth: Vec<f64> = (0..f.len())
        .map(|i| {
            let (lo, hi) = (f[i] * 10f64.powf(-1.0 / 6.0), f[i] * 10f64.powf(1.0 / 6.0));
            let near: Vec<f64> = (0..f.len())
                .filter(|&k| f[k] >= lo && f[k] <= hi)
                .map(|k| e[k] * e[k])
                .collect();
            (near.iter().sum::<f64>() / near.len().max(1) as f64).sqrt()
        })
        .collect();
    let mask: Vec<bool> = (0..f.len())
        .map(|i| {
            f[i] >= fmin_hz
                && f[i] > 0.0
                && smooth[i] <= MAX_REL_ERR
                && frf.dof.get(i).copied().unwrap_or(0.0) >= MIN_DOF
        })
        .collect();
    let r = segments_where(&mask, 2).into_iter().max_by(|a, b| {
        let w = |r: &Range<usize>| f[r.end - 1] / f[r.start];
        w(a).total_cmp(&w(b))
    })?;
    let (lo, hi) = (f[r.start], f[r.end - 1]);
    (hi >= 2.0 * lo).then_some((lo, hi))
}
