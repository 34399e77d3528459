//! Data windows for Welch segments (periodic forms, as scipy.signal.get_window's default).

use std::f64::consts::PI;

use crate::error::{invalid, Result, SysidError};

/// A data window.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Window {
    /// All ones.
    Rectangular,
    /// 0.5 − 0.5·cos(2πn/N).
    Hann,
    /// 0.54 − 0.46·cos(2πn/N).
    Hamming,
    /// 0.42 − 0.5·cos(2πn/N) + 0.08·cos(4πn/N).
    Blackman,
}

impl Window {
    /// The `n` window samples.
    pub fn samples(&self, n: usize) -> Vec<f64> {
        let x = |i: usize| 2.0 * PI * i as f64 / n as f64;
        (0..n)
            .map(|i| match self {
                Window::Rectangular => 1.0,
                Window::Hann => 0.5 - 0.5 * x(i).cos(),
                Window::Hamming => 0.54 - 0.46 * x(i).cos(),
                Window::Blackman => 0.42 - 0.5 * x(i).cos() + 0.08 * (2.0 * x(i)).cos(),
            })
            .collect()
    }
}

impl std::str::FromStr for Window {
    type Err = SysidError;
    fn from_str(s: &str) -> Result<Window> {
        match s.to_ascii_lowercase().as_str() {
            "rect" | "rectangular" | "boxcar" => Ok(Window::Rectangular),
            "hann" | "hanning" => Ok(Window::Hann),
            "hamming" => Ok(Window::Hamming),
            "blackman" => Ok(Window::Blackman),
            _ => Err(invalid(format!(
                "unknown window '{s}' (rectangular, hann, hamming, blackman)"
            ))),
        }
    }
}
