//! Empirical transfer-function estimate: the ratio of the full-record DFTs, Y_k/U_k, optionally
//! smoothed over neighbouring bins (as MATLAB's etfe with a smoothing width).

use super::spafdr::Dft;
use super::{limits, prepare, Frf, IoData, Options};
use crate::error::Result;

/// Bins used for the coherence of a raw (unsmoothed) ETFE: a single periodogram has coherence 1 by
/// construction, so it comes from the neighbouring bins of a 5-bin Hann smoothing (the point's own bin
/// left out); the confidence then uses ν = 1, as the estimate is a single periodogram ratio.
const COHERENCE_BINS: usize = 5;

/// ETFE at every DFT bin in [fmin, fmax].
pub fn etfe(d: &IoData, o: &Options) -> Result<Frf> {
    let p = prepare(d, o.detrend, 8)?;
    let dft = Dft::new(&p.u, &p.y, p.r.as_deref(), None, p.dt)?;
    let (lo, hi) = limits(o, dft.df, p.dt)?;
    let bins = o.smoothing_bins.max(1);
    // A Hann window of full width (b + 1) bins has b nonzero taps.
    let width = (bins.max(COHERENCE_BINS) + 1) as f64 * dft.df;
    let last = dft.u.len() - 1;
    let ks: Vec<usize> = (1..=last)
        .filter(|&k| {
            let f = k as f64 * dft.df;
            f >= lo - 1e-9 * dft.df && f <= hi + 1e-9 * dft.df
        })
        .collect();
    let points = ks
        .iter()
        .filter_map(|&k| {
            let f = k as f64 * dft.df;
            dft.smooth(f, width).map(|(mut c, mut nu)| {
                if bins == 1 {
                    // Leave the point's own bin out of the coherence behind its raw estimate (the Hann
                    // window's centre tap is 1): otherwise a bin hit by more noise also gets a lower
                    // coherence, so a lower fit weight, and the fit's residual variance underestimates
                    // the noise.
                    c.add(-1.0, dft.u[k], dft.y[k], dft.r.as_ref().map(|r| r[k]), None);
                    // The estimate itself is one periodogram ratio: one average.
                    nu = 1.0;
                }
                (f, c, nu)
            })
        })
        .collect();
    let mut frf = Frf::from_cross(points, p.r.is_some())?;
    if bins > 1 {
        let w = (bins + 1) as f64 * dft.df;
        let mut pts = Vec::new();
        for &f in &frf.freq_hz {
            if let Some((c, nu)) = dft.smooth(f, w) {
                pts.push((f, c, nu));
            }
        }
        let sm = Frf::from_cross(pts, p.r.is_some())?;
        if sm.freq_hz.len() == frf.freq_hz.len() {
            frf.response = sm.response;
            frf.bandwidth_hz = vec![w; frf.freq_hz.len()];
        }
    } else {
        for (g, f) in frf.response.iter_mut().zip(&frf.freq_hz) {
            let k = (f / dft.df).round() as usize;
            *g = dft.y[k] / dft.u[k];
        }
    }
    Ok(frf)
}
