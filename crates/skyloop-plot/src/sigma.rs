//! Singular-value plots of MIMO frequency responses (dB against Hz).

use std::path::Path;

use crate::error::Result;
use crate::figure::{Figure, Panel, Series, SeriesStyle};

/// Singular values of one system over frequency: `sv_db[k][i]` is the i-th largest at `freq_hz[k]`.
#[derive(Debug, Clone, PartialEq)]
pub struct SigmaData {
    /// Legend text.
    pub label: String,
    /// Frequencies, Hz.
    pub freq_hz: Vec<f64>,
    /// Singular values in dB, one vector (descending) per frequency.
    pub sv_db: Vec<Vec<f64>>,
}

/// Builds a singular-value figure as MATLAB's `sigma`: every singular value of system `k` a solid
/// line in palette colour `k` (dashed stays free for references and targets), the system's label
/// on the largest. A missing value (fewer singular values at some frequency) breaks the line.
pub fn sigma_figure(title: &str, data: &[SigmaData]) -> Figure {
    sigma_figure_with_targets(title, data, &[])
}

/// A singular-value figure with reference or target curves (e.g. a loop-shaping target or a
/// weight's inverse 1/|W|), drawn dashed in their own colours after the systems'.
pub fn sigma_figure_with_targets(title: &str, data: &[SigmaData], targets: &[SigmaTarget]) -> Figure {
    let mut p = Panel::frequency("singular values [dB]");
    for (k, d) in data.iter().enumerate() {
        let count = d.sv_db.iter().map(Vec::len).max().unwrap_or(0);
        for i in 0..count {
            let y: Vec<f64> = d.sv_db.iter().map(|v| v.get(i).copied().unwrap_or(f64::NAN)).collect();
            let label = if i == 0 { d.label.clone() } else { String::new() };
            p.series.push(
                Series::line(label, d.freq_hz.clone(), y)
                    .styled(SeriesStyle::Line)
                    .colored(k),
            );
        }
    }
    for (k, t) in targets.iter().enumerate() {
        p.series.push(
            Series::line(t.label.clone(), t.freq_hz.clone(), t.mag_db.clone())
                .styled(SeriesStyle::Dashed)
                .colored(data.len() + k),
        );
    }
    Figure::new(title, vec![p])
}

/// A reference curve on a singular-value plot (a target loop shape, a bound), drawn dashed.
#[derive(Debug, Clone, PartialEq)]
pub struct SigmaTarget {
    /// Legend text.
    pub label: String,
    /// Frequencies, Hz.
    pub freq_hz: Vec<f64>,
    /// Magnitude, dB.
    pub mag_db: Vec<f64>,
}

/// Writes a singular-value plot to `path` (`.svg` or `.png`).
pub fn plot_sigma(path: &Path, title: &str, data: &[SigmaData]) -> Result<()> {
    sigma_figure(title, data).save(path)
}
