//! Plots for skyloop: Bode (SISO and MIMO grids), Nyquist, Nichols, pole–zero maps, root loci,
//! step responses with their characteristics and time traces, singular values, Hankel singular
//! values, μ bounds and measured frequency responses with confidence bands, as SVG or PNG, and HTML
//! reports with optional interactive (zoom, pan, hover) figures.
//!
//! Every plot is built from plain data (frequencies in Hz, magnitudes in dB, phases in degrees, times
//! in seconds), so any crate can draw without this one knowing how the numbers were computed.
//!
//! # Builders (data in, [`Figure`] out; each has a `plot_*` twin writing `.svg`/`.png`)
//!
//! | plot | builder |
//! |---|---|
//! | Bode, SISO, margins marked | [`bode::bode_figure`], [`bode::bode_figure_with`] (phase-axis options) |
//! | Bode, MIMO input–output grid | [`bode::bode_mimo_figure`] (responses `[output][input]`, [`bode::IoNames`]) |
//! | Nyquist | [`nyquist::nyquist_figure`] |
//! | Nichols, optional M-circles | [`nichols::nichols_figure`] ([`nichols::DEFAULT_M_DB`]) |
//! | singular values | [`sigma::sigma_figure`], [`sigma::sigma_figure_with_targets`] |
//! | pole–zero map | [`pzmap::pzmap_figure`] |
//! | root locus from computed poles per gain | [`pzmap::rlocus_figure`] |
//! | step response with `stepinfo` marks | [`traces::step_figure`] ([`traces::StepInfo`]) |
//! | time traces | [`traces::traces_figure`] |
//! | HTML report, interactive figures | [`report::Section::interactive_figure`], [`Figure::to_json`] |
//!
//! # Conventions the renderer keeps
//!
//! Tick labels in engineering notation without trailing zeros ([`ticks::format_tick`]: "10G",
//! "0.5", "20"); log axes labelled at decades (and 2, 5 over at most two decades); the label area as
//! wide as the widest label; curves cut where they leave the view ([`geometry::clip_polyline`]),
//! never clamped onto the frame; value labels (margins, crossovers, step characteristics) placed
//! where they hide no earlier label; the legend in the corner that hides no data and no label, else
//! outside on the right (every placed box is in [`Figure::layout`]); the Okabe–Ito palette ([`PALETTE`]), a series keeping its colour across the panels of a
//! figure (by label, or fixed with [`Series::colored`]); dashed for references and targets.

pub mod bode;
pub mod error;
pub mod figure;
pub mod frf;
pub mod geometry;
pub mod heatmap;
pub mod hsv;
pub mod interactive;
pub mod layout;
pub mod mu;
pub mod nichols;
pub mod nyquist;
pub mod pzmap;
#[cfg(not(target_arch = "wasm32"))] // PNG files only (see render::register_font)
mod raster_text;
mod render;
pub mod report;
pub mod sigma;
pub mod ticks;
pub mod traces;

pub use error::PlotError;
pub use figure::{Band, Figure, Marker, Panel, Series, SeriesStyle, NEUTRAL, PALETTE};
pub use report::Report;
