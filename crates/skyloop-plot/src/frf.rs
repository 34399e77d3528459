//! Measured frequency responses (from flight data) with confidence bands and coherence, and fitted
//! models overlaid, as in the bicopter paper's identification figures.

use std::path::Path;

use crate::bode::BodeData;
use crate::error::Result;
use crate::figure::{Band, Figure, Panel, Series, SeriesStyle};

/// A non-parametric estimate over frequency.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrfEstimate {
    /// Frequencies, Hz.
    pub freq_hz: Vec<f64>,
    /// Magnitude, dB.
    pub mag_db: Vec<f64>,
    /// Phase, degrees.
    pub phase_deg: Vec<f64>,
    /// Magnitude confidence band (lower, upper), dB; empty vectors for none.
    pub mag_band_db: (Vec<f64>, Vec<f64>),
    /// Phase confidence band (lower, upper), degrees; empty vectors for none.
    pub phase_band_deg: (Vec<f64>, Vec<f64>),
    /// Squared coherence in [0, 1]; empty for none.
    pub coherence: Vec<f64>,
    /// The band the parametric fit used, Hz (low, high): shaded so a reader sees which part of the
    /// estimate the model answers to; `None` for none.
    pub fit_band_hz: Option<(f64, f64)>,
}

/// Builds the figure: magnitude and phase with bands and fitted models, and coherence when present.
pub fn frf_figure(title: &str, est: &FrfEstimate, fits: &[BodeData]) -> Figure {
    let f = &est.freq_hz;
    let mut mag = Panel::frequency("magnitude [dB]");
    let mut phase = Panel::frequency("phase [deg]");
    phase.y_degrees = true;
    if !est.mag_band_db.0.is_empty() {
        mag.bands.push(Band {
            label: "confidence".into(),
            x: f.clone(),
            lower: est.mag_band_db.0.clone(),
            upper: est.mag_band_db.1.clone(),
            color: 0,
        });
    }
    if !est.phase_band_deg.0.is_empty() {
        phase.bands.push(Band {
            label: String::new(),
            x: f.clone(),
            lower: est.phase_band_deg.0.clone(),
            upper: est.phase_band_deg.1.clone(),
            color: 0,
        });
    }
    mag.series
        .push(Series::line("measured", f.clone(), est.mag_db.clone()).colored(0));
    phase
        .series
        .push(Series::line("", f.clone(), est.phase_deg.clone()).colored(0));
    for (k, fit) in fits.iter().enumerate() {
        mag.series.push(
            Series::line(fit.label.clone(), fit.freq_hz.clone(), fit.mag_db.clone())
                .styled(SeriesStyle::Dashed)
                .colored(k + 1),
        );
        phase.series.push(
            Series::line("", fit.freq_hz.clone(), fit.phase_deg.clone())
                .styled(SeriesStyle::Dashed)
                .colored(k + 1),
        );
    }
    let mut panels = vec![mag, phase];
    if !est.coherence.is_empty() {
        panels.push(Panel {
            y_range: Some((0.0, 1.05)),
            series: vec![Series::line("", f.clone(), est.coherence.clone()).colored(2)],
            ..Panel::frequency("coherence")
        });
    }
    if let Some((lo, hi)) = est
        .fit_band_hz
        .filter(|(lo, hi)| lo.is_finite() && hi.is_finite() && lo < hi)
    {
        // On the coherence panel when there is one (fixed 0..1 range), else under the magnitude.
        let (panel, y0, y1) = if est.coherence.is_empty() {
            let (a, b) = est
                .mag_db
                .iter()
                .filter(|v| v.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
            (0, a, b)
        } else {
            (2, 0.0, 1.05)
        };
        if y0 < y1 {
            panels[panel].bands.push(Band {
                label: format!("fit band {lo:.3} to {hi:.3} Hz"),
                x: vec![lo, hi],
                lower: vec![y0; 2],
                upper: vec![y1; 2],
                color: 3,
            });
        }
    }
    Figure::new(title, panels)
}

/// Writes a measured-FRF plot to `path` (`.svg` or `.png`).
pub fn plot_frf(path: &Path, title: &str, est: &FrfEstimate, fits: &[BodeData]) -> Result<()> {
    frf_figure(title, est, fits).save(path)
}
