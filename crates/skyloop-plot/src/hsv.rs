//! Hankel-singular-value plots: which states a reduction keeps and which it discards.

use std::path::Path;

use crate::error::{PlotError, Result};
use crate::figure::{Figure, Marker, Panel, Series, SeriesStyle};

/// Builds the figure: σᵢ on a log axis against the state index, kept states in one colour and
/// discarded ones in another, with a line at the reduced order.
pub fn hsv_figure(title: &str, hsv: &[f64], kept: Option<usize>) -> Result<Figure> {
    if hsv.is_empty() {
        return Err(PlotError::Data("no Hankel singular values to plot".into()));
    }
    let k = kept.unwrap_or(hsv.len()).min(hsv.len());
    let idx: Vec<f64> = (1..=hsv.len()).map(|i| i as f64).collect();
    let mut p = Panel {
        x_label: "state".into(),
        y_label: "Hankel singular value".into(),
        y_log: true,
        x_range: Some((0.0, hsv.len() as f64 + 1.0)),
        ..Panel::default()
    };
    p.series.push(
        Series::line("kept", idx[..k].to_vec(), hsv[..k].to_vec())
            .styled(SeriesStyle::Stems)
            .colored(0),
    );
    p.series.push(
        Series::line("", idx[..k].to_vec(), hsv[..k].to_vec())
            .styled(SeriesStyle::Points)
            .colored(0),
    );
    if k < hsv.len() {
        p.series.push(
            Series::line("discarded", idx[k..].to_vec(), hsv[k..].to_vec())
                .styled(SeriesStyle::Stems)
                .colored(1),
        );
        p.series.push(
            Series::line("", idx[k..].to_vec(), hsv[k..].to_vec())
                .styled(SeriesStyle::Points)
                .colored(1),
        );
        p.markers.push(Marker::Vertical {
            x: k as f64 + 0.5,
            label: format!("order {k}"),
        });
    }
    Ok(Figure::new(title, vec![p]))
}

/// Writes a Hankel-singular-value plot to `path` (`.svg` or `.png`).
pub fn plot_hsv(path: &Path, title: &str, hsv: &[f64], kept: Option<usize>) -> Result<()> {
    hsv_figure(title, hsv, kept)?.save(path)
}
