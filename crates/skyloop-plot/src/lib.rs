//! Plots for skyloop: Bode (SISO and MIMO grids), Nyquist, Nichols, pole–zero maps, root loci,
//! step responses with their characteristics and time traces, singular values, Hankel singular
//! values, μ bounds and measured frequency responses with confidence bands, as SVG or PNG, and HTML
//! reports with optional interactive (zoom, pan, hover) figures.
//!
//! Every plot is built from plain data (frequencies in Hz, magnitudes in dB, phases in degrees, times
//! in seconds), so any crate can draw without this one knowing how the numbers were computed.

pub mod bode;
pub mod error;
pub mod figure;
pub mod frf;
pub mod geometry;
pub mod hsv;
pub mod interactive;
pub mod mu;
pub mod nichols;
pub mod nyquist;
pub mod pzmap;
mod render;
pub mod report;
pub mod sigma;
pub mod ticks;
pub mod traces;

pub use error::PlotError;
pub use figure::{Band, Figure, Marker, Panel, Series, SeriesStyle, NEUTRAL, PALETTE};
pub use report::Report;
