//! Excitation signals sampled at a fixed rate: chirps, PRBS, Schroeder multisines, and a CSV writer.

pub mod chirp;
pub mod csv;
pub mod multisine;
pub mod prbs;

pub use chirp::{chirp, ChirpSpec, Sweep};
pub use csv::write_csv;
pub use multisine::{multisine, MultisineSpec};
pub use prbs::{prbs, PrbsSpec};

use crate::error::{invalid, Result};

/// A uniformly sampled signal: `values[i]` is the value at `i / rate_hz` seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct Signal {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Samples.
    pub values: Vec<f64>,
}

impl Signal {
    /// Sample times, s (starting at 0).
    pub fn time_s(&self) -> Vec<f64> {
        (0..self.values.len()).map(|i| i as f64 / self.rate_hz).collect()
    }

    /// Peak absolute value divided by the RMS value (∞ for an all-zero signal).
    pub fn crest_factor(&self) -> f64 {
        crest_factor(&self.values)
    }
}

/// Peak absolute value over RMS of `x`.
pub fn crest_factor(x: &[f64]) -> f64 {
    if x.is_empty() {
        return f64::INFINITY;
    }
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let rms = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
    if rms == 0.0 {
        f64::INFINITY
    } else {
        peak / rms
    }
}

/// Most samples a generated signal may have (400 MB of f64, about 1.7 h at 8 kHz): a duration or a
/// rate beyond it is a typo, and would otherwise allocate without bound.
pub const MAX_SIGNAL_SAMPLES: f64 = 5e7;

/// Checks that `duration_s` at `rate_hz` stays within [`MAX_SIGNAL_SAMPLES`], naming both.
pub(crate) fn check_samples(duration_s: f64, rate_hz: f64, what: &str) -> Result<()> {
    let n = duration_s * rate_hz;
    if !(n <= MAX_SIGNAL_SAMPLES) {
        return Err(invalid(format!(
            "{what} of {duration_s} s at {rate_hz} Hz is {n:.3e} samples, above the limit of {MAX_SIGNAL_SAMPLES:e}; \
             shorten it or lower --rate"
        )));
    }
    Ok(())
}

pub(crate) fn check_rate(rate_hz: f64) -> Result<()> {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(invalid(format!(
            "sample rate must be a positive number of Hz, got {rate_hz}"
        )));
    }
    Ok(())
}

pub(crate) fn check_positive(v: f64, what: &str) -> Result<()> {
    if !(v.is_finite() && v > 0.0) {
        return Err(invalid(format!("{what} must be positive and finite, got {v}")));
    }
    Ok(())
}

#[cfg(test)]
mod limit_tests {
    use super::chirp::{chirp, ChirpSpec, Sweep};

    /// A duration or rate typo is refused with both numbers and the limit, before any allocation.
    #[test]
    fn huge_signals_are_refused() {
        let spec = |duration_s| ChirpSpec {
            f0_hz: 0.1,
            f1_hz: 10.0,
            duration_s,
            amplitude: 1.0,
            amplitude_end: None,
            fade_s: 0.0,
            sweep: Sweep::Exponential,
        };
        let e = chirp(&spec(1e12), 100.0).unwrap_err().to_string();
        assert!(e.contains("1000000000000 s") && e.contains("limit"), "{e}");
        let e = chirp(&spec(1.0), 1e9).unwrap_err().to_string();
        assert!(e.contains("--rate"), "{e}");
        assert_eq!(chirp(&spec(10.0), 100.0).unwrap().values.len(), 1000);
    }
}
