//! Periodic multisines with Schroeder phases (Schroeder 1970): flat amplitude spectrum, low crest factor.

use std::f64::consts::PI;

use super::{check_positive, check_rate, Signal};
use crate::error::{invalid, Result};

/// A multisine's parameters: harmonics of 1/period between `f_min_hz` and `f_max_hz`.
#[derive(Debug, Clone, PartialEq)]
pub struct MultisineSpec {
    /// Lowest excited frequency, Hz (rounded up to a harmonic of 1/period).
    pub f_min_hz: f64,
    /// Highest excited frequency, Hz (rounded down to a harmonic).
    pub f_max_hz: f64,
    /// Period, s: the frequency resolution is 1/period.
    pub period_s: f64,
    /// Number of periods.
    pub periods: usize,
    /// Peak amplitude of the generated signal.
    pub amplitude: f64,
}

/// Samples the multisine at `rate_hz`; the result is scaled so that its peak equals `amplitude`.
pub fn multisine(spec: &MultisineSpec, rate_hz: f64) -> Result<Signal> {
    check_rate(rate_hz)?;
    check_positive(spec.f_min_hz, "multisine minimum frequency")?;
    check_positive(spec.f_max_hz, "multisine maximum frequency")?;
    check_positive(spec.period_s, "multisine period")?;
    if spec.periods == 0 || !spec.amplitude.is_finite() {
        return Err(invalid("multisine needs at least one period and a finite amplitude"));
    }
    if spec.f_max_hz >= rate_hz / 2.0 {
        return Err(invalid(format!(
            "multisine maximum {} Hz is at or above Nyquist {} Hz",
            spec.f_max_hz,
            rate_hz / 2.0
        )));
    }
    super::check_samples(spec.period_s * spec.periods as f64, rate_hz, "multisine")?;
    let n_per = (spec.period_s * rate_hz).round() as usize;
    let period = n_per as f64 / rate_hz;
    let k0 = (spec.f_min_hz * period).ceil().max(1.0) as usize;
    let k1 = (spec.f_max_hz * period).floor() as usize;
    if k1 < k0 {
        return Err(invalid(format!(
            "no harmonic of 1/{period} s lies within [{}, {}] Hz; lengthen the period",
            spec.f_min_hz, spec.f_max_hz
        )));
    }
    let count = (k1 - k0 + 1) as f64;
    // Schroeder's phases φ_k = −π k(k−1)/K for K equal-power harmonics.
    let phases: Vec<f64> = (0..=(k1 - k0)).map(|j| -PI * (j * (j + 1)) as f64 / count).collect();
    let mut one = vec![0.0; n_per];
    for (i, v) in one.iter_mut().enumerate() {
        let t = i as f64 / rate_hz;
        *v = (k0..=k1)
            .zip(&phases)
            .map(|(k, ph)| (2.0 * PI * k as f64 * t / period + ph).cos())
            .sum();
    }
    let peak = one.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if peak > 0.0 {
        one.iter_mut().for_each(|v| *v *= spec.amplitude / peak);
    }
    let mut values = Vec::with_capacity(n_per * spec.periods);
    for _ in 0..spec.periods {
        values.extend_from_slice(&one);
    }
    Ok(Signal { rate_hz, values })
}

#[cfg(test)]
mod tests {
    use super::*;
    use realfft::RealFftPlanner;

    fn spec() -> MultisineSpec {
        MultisineSpec {
            f_min_hz: 0.5,
            f_max_hz: 40.0,
            period_s: 10.0,
            periods: 2,
            amplitude: 2.0,
        }
    }

    /// Schroeder phases keep the crest factor near 1.7 where zero phases give √(2K) (here K = 396).
    #[test]
    fn low_crest_factor_and_peak() {
        let s = multisine(&spec(), 250.0).unwrap();
        assert_eq!(s.values.len(), 5000);
        let peak = s.values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!((peak - 2.0).abs() < 1e-12);
        assert!(s.crest_factor() < 2.0, "crest {}", s.crest_factor());
    }

    /// The spectrum of one period is flat on the excited harmonics and empty elsewhere.
    #[test]
    fn flat_spectrum_on_harmonics() {
        let s = multisine(&spec(), 250.0).unwrap();
        let mut x = s.values[..2500].to_vec();
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(2500);
        let mut out = fft.make_output_vec();
        fft.process(&mut x, &mut out).unwrap();
        let mags: Vec<f64> = out.iter().map(|c| c.norm()).collect();
        let excited = &mags[5..=400];
        let (lo, hi) = excited
            .iter()
            .fold((f64::MAX, 0.0f64), |(a, b), &m| (a.min(m), b.max(m)));
        assert!((hi - lo) / hi < 1e-9, "flat within rounding: {lo} {hi}");
        assert!(mags[..5].iter().chain(&mags[401..]).all(|&m| m < 1e-9 * hi));
    }

    #[test]
    fn rejects_bad_input() {
        let mut s = spec();
        s.f_max_hz = 200.0;
        assert!(multisine(&s, 250.0).is_err());
        let mut s = spec();
        s.f_min_hz = 0.41;
        s.f_max_hz = 0.45;
        assert!(multisine(&s, 250.0).is_err());
    }
}
