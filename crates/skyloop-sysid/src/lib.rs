//! skyloop-sysid: system identification from flight data.
//!
//! Excitation signals (chirps, PRBS, Schroeder multisines), log readers (CSV, PX4 ULog, Betaflight
//! blackbox) with resampling and segment selection, non-parametric frequency-response estimates
//! (ETFE, Welch H1, Blackman–Tukey SPA, SPAFDR; open or closed loop) with coherence and confidence,
//! and parametric fits (expression models with named parameters and exact delay; rational TFs).
//!
//! Frequencies are Hz where a name says `_hz`, rad/s otherwise; times are seconds.

pub mod error;
pub mod signal;

pub use error::{Result, SysidError};
pub mod fit;
pub mod logs;
pub mod spectral;
