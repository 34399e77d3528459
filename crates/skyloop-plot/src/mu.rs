//! Structured-singular-value plots: upper and lower μ bounds against frequency, e.g. one curve pair
//! per DK-iteration.

use std::path::Path;

use crate::error::Result;
use crate::figure::{Figure, Marker, Panel, Series, SeriesStyle};

/// μ bounds of one analysis over frequency.
#[derive(Debug, Clone, PartialEq)]
pub struct MuCurve {
    /// Legend text (e.g. "RP, iteration 2").
    pub label: String,
    /// Frequencies, Hz.
    pub freq_hz: Vec<f64>,
    /// Upper bound (dimensionless).
    pub upper: Vec<f64>,
    /// Lower bound (dimensionless); may be empty.
    pub lower: Vec<f64>,
}

/// Builds the μ figure: upper bounds solid, lower bounds dashed, the line μ = 1 marked.
pub fn mu_figure(title: &str, curves: &[MuCurve]) -> Figure {
    let mut p = Panel::frequency("μ");
    for (k, c) in curves.iter().enumerate() {
        p.series
            .push(Series::line(format!("{} upper", c.label), c.freq_hz.clone(), c.upper.clone()).colored(k));
        if !c.lower.is_empty() {
            p.series.push(
                Series::line(format!("{} lower", c.label), c.freq_hz.clone(), c.lower.clone())
                    .styled(SeriesStyle::Dashed)
                    .colored(k),
            );
        }
    }
    p.markers.push(Marker::Horizontal {
        y: 1.0,
        label: "μ = 1".into(),
    });
    Figure::new(title, vec![p])
}

/// Writes a μ plot to `path` (`.svg` or `.png`).
pub fn plot_mu(path: &Path, title: &str, curves: &[MuCurve]) -> Result<()> {
    mu_figure(title, curves).save(path)
}
