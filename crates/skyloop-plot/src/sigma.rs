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

/// Builds a singular-value figure: the largest of each system solid, the others dashed.
pub fn sigma_figure(title: &str, data: &[SigmaData]) -> Figure {
    let mut p = Panel::frequency("singular values [dB]");
    for (k, d) in data.iter().enumerate() {
        let count = d.sv_db.iter().map(Vec::len).max().unwrap_or(0);
        for i in 0..count {
            let y: Vec<f64> = d.sv_db.iter().map(|v| v.get(i).copied().unwrap_or(f64::NAN)).collect();
            let (label, style) = if i == 0 {
                (d.label.clone(), SeriesStyle::Line)
            } else {
                (String::new(), SeriesStyle::Dashed)
            };
            p.series
                .push(Series::line(label, d.freq_hz.clone(), y).styled(style).colored(k));
        }
    }
    Figure::new(title, vec![p])
}

/// Writes a singular-value plot to `path` (`.svg` or `.png`).
pub fn plot_sigma(path: &Path, title: &str, data: &[SigmaData]) -> Result<()> {
    sigma_figure(title, data).save(path)
}
