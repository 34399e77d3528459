//! Power spectral density by Welch's method (as `scipy.signal.welch` with its defaults: periodic
//! Hann window, 50 % overlap, each segment's mean removed, one-sided density scaling), over one or
//! several records of the same sample period (e.g. a flight's airborne segments), averaged by
//! segment count.

use super::window::Window;
use super::Rfft;
use crate::error::{invalid, Result};

/// A one-sided power spectral density.
#[derive(Debug, Clone, PartialEq)]
pub struct Psd {
    /// Frequencies, Hz (0 to the Nyquist frequency, spaced 1/(nfft·dt)).
    pub freq_hz: Vec<f64>,
    /// Density, (signal unit)²/Hz.
    pub density: Vec<f64>,
    /// Segments averaged.
    pub segments: usize,
}

impl Psd {
    /// ∫ density df over [f_lo, f_hi] Hz (trapezoids on the estimate's grid): the signal's variance
    /// in that band, (signal unit)².
    pub fn band_power(&self, f_lo: f64, f_hi: f64) -> f64 {
        self.weighted_band_power(f_lo, f_hi, |_| 1.0)
    }

    /// ∫ w(f)·density(f) df over [f_lo, f_hi] Hz (trapezoids on the estimate's grid).
    pub fn weighted_band_power(&self, f_lo: f64, f_hi: f64, mut w: impl FnMut(f64) -> f64) -> f64 {
        let mut acc = 0.0;
        let mut prev: Option<(f64, f64)> = None;
        for (&f, &p) in self.freq_hz.iter().zip(&self.density) {
            if f < f_lo || f > f_hi {
                prev = None;
                continue;
            }
            let v = w(f) * p;
            if let Some((f0, v0)) = prev {
                acc += 0.5 * (v + v0) * (f - f0);
            }
            prev = Some((f, v));
        }
        acc
    }
}

/// Welch's PSD of `records` (each sampled at `dt_s`) with segments of `nfft` samples; records
/// shorter than one segment are skipped.
///
/// # Errors
/// `nfft` outside 8..=2^20, a sample period that is not positive, or no record as long as a segment.
pub fn psd(records: &[&[f64]], dt_s: f64, nfft: usize) -> Result<Psd> {
    if !(8..=1 << 20).contains(&nfft) {
        return Err(invalid(format!(
            "PSD segment length must be in 8..=1048576, got {nfft}"
        )));
    }
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(invalid(format!("PSD sample period must be positive, got {dt_s}")));
    }
    let seg_psd = SegmentPsd::new(nfft, dt_s);
    let mut acc = vec![0.0; seg_psd.bins()];
    let mut count = 0usize;
    let step = nfft / 2;
    for r in records {
        let mut start = 0;
        while start + nfft <= r.len() {
            for (a, d) in acc.iter_mut().zip(seg_psd.density(&r[start..start + nfft])?) {
                *a += d;
            }
            count += 1;
            start += step;
        }
    }
    if count == 0 {
        return Err(invalid(format!(
            "PSD: no record holds a segment of {nfft} samples ({:.3} s)",
            nfft as f64 * dt_s
        )));
    }
    Ok(Psd {
        freq_hz: seg_psd.freq_hz(),
        density: acc.iter().map(|a| a / count as f64).collect(),
        segments: count,
    })
}

/// The one-sided PSD of single segments of `nfft` samples (periodic Hann window, mean removed,
/// density scaling): the building block of Welch's average and of spectrograms.
pub struct SegmentPsd {
    nfft: usize,
    dt_s: f64,
    window: Vec<f64>,
    scale: f64,
    fft: Rfft,
}

impl SegmentPsd {
    /// Segments of `nfft` samples taken every `dt_s` seconds (the caller checks both).
    pub fn new(nfft: usize, dt_s: f64) -> SegmentPsd {
        let window = Window::Hann.samples(nfft);
        let wss: f64 = window.iter().map(|v| v * v).sum();
        SegmentPsd {
            nfft,
            dt_s,
            window,
            scale: dt_s / wss,
            fft: Rfft::new(nfft),
        }
    }

    /// Number of frequency bins, nfft/2 + 1.
    pub fn bins(&self) -> usize {
        self.nfft / 2 + 1
    }

    /// The bins' frequencies, Hz.
    pub fn freq_hz(&self) -> Vec<f64> {
        (0..self.bins())
            .map(|k| k as f64 / (self.nfft as f64 * self.dt_s))
            .collect()
    }

    /// The density of one segment (exactly `nfft` samples), (signal unit)²/Hz.
    ///
    /// # Errors
    /// A segment of another length.
    pub fn density(&self, seg: &[f64]) -> Result<Vec<f64>> {
        if seg.len() != self.nfft {
            return Err(invalid(format!(
                "PSD segment has {} samples, not {}",
                seg.len(),
                self.nfft
            )));
        }
        let mean = seg.iter().sum::<f64>() / self.nfft as f64;
        let x: Vec<f64> = seg.iter().map(|v| v - mean).collect();
        let half = self.bins();
        Ok(self
            .fft
            .run(&x, Some(&self.window))?
            .iter()
            .enumerate()
            .map(|(k, z)| {
                // One-sided: every bin but DC and (even nfft) Nyquist carries both signs' power.
                let two = if k == 0 || (self.nfft % 2 == 0 && k == half - 1) {
                    1.0
                } else {
                    2.0
                };
                z.norm_sqr() * self.scale * two
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// Parseval: a sine of amplitude A has variance A²/2, and the PSD's band power around its
    /// frequency holds it; white noise of variance σ² has density 2σ²·dt one-sided.
    #[test]
    fn band_power_holds_the_variance() {
        let dt = 1e-3;
        let n = 200_000;
        let a = 3.0;
        let x: Vec<f64> = (0..n)
            .map(|k| a * (2.0 * std::f64::consts::PI * 50.0 * k as f64 * dt).sin())
            .collect();
        let p = psd(&[&x], dt, 1024).unwrap();
        let v = p.band_power(40.0, 60.0);
        assert!((v - a * a / 2.0).abs() < 0.01 * a * a / 2.0, "{v}");
        // A deterministic white sequence (an LCG's uniform numbers, variance 1/12).
        let mut s = 12345u64;
        let u: Vec<f64> = (0..n)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
        let p = psd(&[&u], dt, 256).unwrap();
        let mid: Vec<f64> = p.density[10..100].to_vec();
        let mean = mid.iter().sum::<f64>() / mid.len() as f64;
        assert!((mean - 2.0 * dt / 12.0).abs() < 0.03 * 2.0 * dt / 12.0, "{mean}");
        assert!(psd(&[&u[..100]], dt, 256).is_err());
        assert!(psd(&[&u], 0.0, 256).is_err());
    }
}
