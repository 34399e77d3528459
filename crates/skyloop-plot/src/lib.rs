//! Plots for skyloop: Bode, Nyquist, step and time traces, singular values, Hankel singular values,
//! μ bounds and measured frequency responses with confidence bands, as SVG or PNG.
//!
//! Every plot is built from plain data (frequencies in Hz, magnitudes in dB, phases in degrees, times
//! in seconds), so any crate can draw without this one knowing how the numbers were computed.

pub mod bode;
pub mod error;
pub mod figure;
pub mod frf;
pub mod hsv;
pub mod mu;
pub mod nyquist;
mod render;
pub mod report;
pub mod sigma;
pub mod traces;

pub use error::PlotError;
pub use figure::{Band, Figure, Marker, Panel, Series, SeriesStyle};
pub use report::Report;
