//! Peaks of a gyro spectrum, named by how they behave against throttle: a motor harmonic moves with
//! the throttle (or sits on a harmonic of the logged motor speed), a frame resonance stays put, and
//! the prop-wash band is the broad hump below 100 Hz.

use super::Heat;
use serde::Serialize;

/// A named spectral peak.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Peak {
    /// Centre, Hz.
    pub freq_hz: f64,
    /// PSD at the centre, dB re 1 unit²/Hz.
    pub db: f64,
    /// Height above the local floor, dB.
    pub prominence_db: f64,
    /// "motor harmonic", "frame resonance" or "prop wash band".
    pub kind: &'static str,
    /// Why it was named so.
    pub reason: String,
}

/// Smallest height above the floor that counts as a peak, dB.
const MIN_PROMINENCE_DB: f64 = 6.0;
/// Most peaks reported.
const MAX_PEAKS: usize = 6;

/// The peaks of `psd_db` (on `freq`) above 15 Hz, strongest first, named with `by_throttle` (its
/// motor speeds) and `tracks`: each frame's throttle in [0, 1] and strongest peaks, Hz.
pub fn find(freq: &[f64], psd_db: &[f64], by_throttle: &Heat, tracks: &[(f64, Vec<f64>)]) -> Vec<Peak> {
    if freq.len() < 8 || psd_db.len() != freq.len() {
        return Vec::new();
    }
    let df = freq[1] - freq[0];
    // The floor: a running median over ±40 Hz.
    let half = ((40.0 / df).round() as usize).max(3);
    let floor: Vec<f64> = (0..freq.len())
        .map(|k| {
            let mut w: Vec<f64> = psd_db[k.saturating_sub(half)..(k + half + 1).min(freq.len())].to_vec();
            w.sort_by(f64::total_cmp);
            w[w.len() / 2]
        })
        .collect();
    let mut peaks: Vec<Peak> = (1..freq.len() - 1)
        .filter(|&k| freq[k] >= 15.0 && psd_db[k] > psd_db[k - 1] && psd_db[k] >= psd_db[k + 1])
        .filter(|&k| psd_db[k] - floor[k] >= MIN_PROMINENCE_DB)
        .map(|k| {
            let (kind, reason) = name(freq[k], width_hz(freq, psd_db, k, floor[k]), by_throttle, tracks);
            Peak {
                freq_hz: freq[k],
                db: psd_db[k],
                prominence_db: psd_db[k] - floor[k],
                kind,
                reason,
            }
        })
        .collect();
    peaks.sort_by(|a, b| b.prominence_db.total_cmp(&a.prominence_db));
    peaks.truncate(MAX_PEAKS);
    peaks
}

/// Width of the peak at `k` where it stands 3 dB above its floor, Hz.
fn width_hz(freq: &[f64], d: &[f64], k: usize, floor: f64) -> f64 {
    let level = (d[k] - 3.0).max(floor);
    let lo = (0..k).rev().find(|&i| d[i] < level).unwrap_or(0);
    let hi = (k..d.len()).find(|&i| d[i] < level).unwrap_or(d.len() - 1);
    freq[hi] - freq[lo]
}

/// Least-squares slope of frequency on throttle (Hz per unit throttle), the correlation r, and the
/// 5th and 95th percentile throttle; None with fewer than 8 frames or under 5 % of throttle spread.
fn regression(pairs: &[(f64, f64)]) -> Option<(f64, f64, f64, f64)> {
    if pairs.len() < 8 {
        return None;
    }
    let n = pairs.len() as f64;
    let (mt, mf) = (
        pairs.iter().map(|p| p.0).sum::<f64>() / n,
        pairs.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let (mut stt, mut sff, mut stf) = (0.0, 0.0, 0.0);
    for (t, f) in pairs {
        stt += (t - mt) * (t - mt);
        sff += (f - mf) * (f - mf);
        stf += (t - mt) * (f - mf);
    }
    let mut ts: Vec<f64> = pairs.iter().map(|p| p.0).collect();
    ts.sort_by(f64::total_cmp);
    let (lo, hi) = (ts[ts.len() / 20], ts[ts.len() - 1 - ts.len() / 20]);
    if hi - lo < 0.05 || stt <= 0.0 || sff <= 0.0 {
        return None;
    }
    Some((stf / stt, stf / (stt * sff).sqrt(), lo, hi))
}

/// Names a peak at `f` Hz of `width` Hz: by the logged motor speed in `heat`'s rows where there is
/// one, else by how it moves with the throttle over the frames' `tracks`.
fn name(f: f64, width: f64, heat: &Heat, tracks: &[(f64, Vec<f64>)]) -> (&'static str, String) {
    // A harmonic of the logged motor speed, in the rows that have it.
    let harmonic = heat
        .motor_hz
        .iter()
        .zip(&heat.frames)
        .filter(|(m, c)| m.is_some() && **c >= 3)
        .find_map(|(m, _)| {
            let m = (*m)?;
            (1..=3).find(|h| ((f - m * *h as f64) / f).abs() < 0.08).map(|h| (h, m))
        });
    if let Some((h, m)) = harmonic {
        return (
            "motor harmonic",
            format!("at harmonic {h} of the logged motor speed ({m:.0} Hz)"),
        );
    }
    // Where the peak sits frame by frame against that frame's throttle: the nearest of the frame's
    // strongest peaks within ±30 %, regressed on throttle.
    let pairs: Vec<(f64, f64)> = tracks
        .iter()
        .filter_map(|(t, peaks)| {
            let near = peaks
                .iter()
                .filter(|p| (**p - f).abs() <= 0.3 * f)
                .min_by(|a, b| (*a - f).abs().total_cmp(&(*b - f).abs()))?;
            Some((*t, *near))
        })
        .collect();
    let fit = regression(&pairs);
    if let Some((slope, r, t_lo, t_hi)) = fit {
        // A motor's rotation rises roughly with the square root of thrust: its frequency's
        // elasticity to throttle, (df/f)/(dt/t), is near 0.5–1; a structure's is near 0.
        let t_mid = 0.5 * (t_lo + t_hi);
        let elasticity = slope * t_mid / f;
        if r > 0.5 && elasticity >= 0.3 {
            return (
                "motor harmonic",
                format!(
                    "moves with throttle: {:.0} → {:.0} Hz from {:.0} to {:.0} % (elasticity {elasticity:.2}, r = {r:.2}, {} frames)",
                    f - slope * 0.5 * (t_hi - t_lo),
                    f + slope * 0.5 * (t_hi - t_lo),
                    100.0 * t_lo,
                    100.0 * t_hi,
                    pairs.len()
                ),
            );
        }
    }
    if f < 100.0 && width > 15.0 {
        return ("prop wash band", format!("broad ({width:.0} Hz wide) below 100 Hz"));
    }
    let why = match fit {
        Some((_, r, t_lo, t_hi)) => format!(
            "does not follow the throttle over {:.0}–{:.0} % (r = {r:.2}, {} frames)",
            100.0 * t_lo,
            100.0 * t_hi,
            pairs.len()
        ),
        None => "too little throttle variation to see it move; taken as fixed".to_string(),
    };
    ("frame resonance", why)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn spectrum(freq: &[f64], peaks: &[(f64, f64)]) -> Vec<f64> {
        freq.iter()
            .map(|f| {
                let p: f64 = peaks.iter().map(|(c, a)| a * (-((f - c) / 3.0).powi(2)).exp()).sum();
                10.0 * (1e-3 + p).log10()
            })
            .collect()
    }

    /// A peak that moves from 150 to 300 Hz as the throttle rises is a motor harmonic; one that
    /// stays at 420 Hz is a frame resonance.
    #[test]
    fn moving_and_fixed_peaks_are_told_apart() {
        let freq: Vec<f64> = (0..=250).map(|k| k as f64 * 2.0).collect();
        let heat = Heat {
            x: vec![50.0],
            freq_hz: freq.clone(),
            psd_db: vec![vec![0.0; freq.len()]],
            frames: vec![1],
            motor_hz: vec![None],
        };
        let tracks: Vec<(f64, Vec<f64>)> = (0..40)
            .map(|i| {
                let t = 0.2 + 0.5 * i as f64 / 39.0;
                (t, vec![100.0 + 300.0 * t, 420.0 + (i % 3) as f64])
            })
            .collect();
        let mean = spectrum(&freq, &[(220.0, 0.3), (420.0, 0.5)]);
        let p = find(&freq, &mean, &heat, &tracks);
        let at = |f: f64| p.iter().find(|q| (q.freq_hz - f).abs() < 5.0).unwrap();
        assert_eq!(at(420.0).kind, "frame resonance", "{:?}", at(420.0));
        assert_eq!(at(220.0).kind, "motor harmonic", "{:?}", at(220.0));
        // With the motor speed logged, the harmonic is named by it.
        let with_rpm = Heat {
            motor_hz: vec![Some(110.0)],
            frames: vec![5],
            ..heat
        };
        let q = find(&freq, &mean, &with_rpm, &[]);
        assert!(
            q.iter()
                .any(|x| x.kind == "motor harmonic" && x.reason.contains("harmonic 2")),
            "{q:?}"
        );
    }
}
