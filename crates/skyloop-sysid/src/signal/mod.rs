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
