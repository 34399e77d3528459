//! Nyquist plots: the loop's frequency response in the complex plane, with its mirror image for
//! negative frequencies, the unit circle and the critical point −1.

use std::path::Path;

use crate::error::Result;
use crate::figure::{Figure, Marker, Panel, Series, SeriesStyle};

/// One loop's response for ω ≥ 0 (the mirror for ω < 0 is drawn dashed).
#[derive(Debug, Clone, PartialEq)]
pub struct NyquistData {
    /// Legend text.
    pub label: String,
    /// Real parts.
    pub re: Vec<f64>,
    /// Imaginary parts.
    pub im: Vec<f64>,
}

/// Builds the Nyquist figure; `radius` clips the view to |z| ≤ radius when given (the curve of a
/// loop with integrators runs off to infinity).
pub fn nyquist_figure(title: &str, data: &[NyquistData], radius: Option<f64>) -> Figure {
    let mut p = Panel {
        x_label: "real".into(),
        y_label: "imaginary".into(),
        ..Panel::default()
    };
    for (k, d) in data.iter().enumerate() {
        p.series
            .push(Series::line(d.label.clone(), d.re.clone(), d.im.clone()).colored(k));
        let mirror: Vec<f64> = d.im.iter().map(|v| -v).collect();
        p.series.push(
            Series::line("", d.re.clone(), mirror)
                .styled(SeriesStyle::Dashed)
                .colored(k),
        );
    }
    let n = 181;
    let (cx, cy): (Vec<f64>, Vec<f64>) = (0..n)
        .map(|i| {
            let t = 2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64;
            (t.cos(), t.sin())
        })
        .unzip();
    p.series
        .push(Series::line("", cx, cy).styled(SeriesStyle::Dashed).colored(7));
    p.markers.push(Marker::Point {
        x: -1.0,
        y: 0.0,
        label: "-1".into(),
    });
    if let Some(r) = radius {
        p.x_range = Some((-r, r));
        p.y_range = Some((-r, r));
    }
    let mut f = Figure::new(title, vec![p]);
    f.panel_height = 720;
    f.width = 800;
    f
}

/// Writes a Nyquist plot to `path` (`.svg` or `.png`).
pub fn plot_nyquist(path: &Path, title: &str, data: &[NyquistData], radius: Option<f64>) -> Result<()> {
    nyquist_figure(title, data, radius).save(path)
}
