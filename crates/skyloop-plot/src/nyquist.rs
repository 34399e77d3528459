//! Nyquist plots: the loop's frequency response in the complex plane with its mirror image for
//! negative frequencies (dashed), arrows along increasing ω, the unit circle and the critical point
//! −1. Curves leaving the view are cut at its edge, never drawn along the frame.

use std::path::Path;

use crate::error::Result;
use crate::figure::{Figure, Marker, Panel, Series, SeriesStyle};
use crate::geometry::{clip_polyline, points_along, ViewBox};

/// One loop's response for ω ≥ 0, in order of increasing ω (the mirror for ω < 0 is drawn dashed).
#[derive(Debug, Clone, PartialEq)]
pub struct NyquistData {
    /// Legend text.
    pub label: String,
    /// Real parts.
    pub re: Vec<f64>,
    /// Imaginary parts.
    pub im: Vec<f64>,
}

/// The view half-width used when none is given and the curve runs far out (a loop with integrators
/// goes to infinity): what happens near −1 is what the plot is for.
pub const AUTO_RADIUS: f64 = 4.0;

/// Where along the visible curve the direction arrows sit (fractions of its length).
const ARROW_AT: [f64; 3] = [0.2, 0.5, 0.8];

/// The square view `[-r, r]²` the figure shows for `radius`, or the data's extent (with the unit
/// circle and −1) when it is small enough; `None` radius and a far-running curve give
/// ±4 (the view that shows what happens near −1).
pub fn nyquist_view(data: &[NyquistData], radius: Option<f64>) -> ViewBox {
    if let Some(r) = radius.filter(|r| r.is_finite() && *r > 0.0) {
        return ViewBox {
            x0: -r,
            x1: r,
            y0: -r,
            y1: r,
        };
    }
    let mut b = ViewBox {
        x0: -1.2,
        x1: 1.2,
        y0: -1.2,
        y1: 1.2,
    };
    for d in data {
        for (x, y) in d.re.iter().zip(&d.im) {
            if x.is_finite() && y.is_finite() {
                b.x0 = b.x0.min(*x);
                b.x1 = b.x1.max(*x);
                b.y0 = b.y0.min(-y.abs());
                b.y1 = b.y1.max(y.abs());
            }
        }
    }
    let r = AUTO_RADIUS;
    if b.x0 < -r || b.x1 > r || b.y1 > r {
        return ViewBox {
            x0: -r,
            x1: r,
            y0: -r,
            y1: r,
        };
    }
    let pad = 0.05 * (b.x1 - b.x0).max(b.y1 - b.y0);
    ViewBox {
        x0: b.x0 - pad,
        x1: b.x1 + pad,
        y0: b.y0 - pad,
        y1: b.y1 + pad,
    }
}

/// Builds the Nyquist figure; `radius` limits the view to `[-radius, radius]²` when given (the curve
/// of a loop with integrators runs off to infinity; it is cut where it leaves the view).
pub fn nyquist_figure(title: &str, data: &[NyquistData], radius: Option<f64>) -> Figure {
    let view = nyquist_view(data, radius);
    let mut p = Panel {
        title: "solid ω > 0, dashed ω < 0; arrows: increasing ω".into(),
        x_label: "real".into(),
        y_label: "imaginary".into(),
        equal_aspect: true,
        x_range: Some((view.x0, view.x1)),
        y_range: Some((view.y0, view.y1)),
        ..Panel::default()
    };
    p.series.push(Series::unit_circle());
    for (k, d) in data.iter().enumerate() {
        let pos: Vec<(f64, f64)> = d.re.iter().copied().zip(d.im.iter().copied()).collect();
        let neg: Vec<(f64, f64)> = pos.iter().rev().map(|&(x, y)| (x, -y)).collect();
        p.series
            .push(Series::line(d.label.clone(), d.re.clone(), d.im.clone()).colored(k));
        p.series.push(
            Series::line("", neg.iter().map(|q| q.0).collect(), neg.iter().map(|q| q.1).collect())
                .styled(SeriesStyle::Dashed)
                .colored(k),
        );
        // ω rises along the data for ω > 0, and along the reversed mirror for ω < 0 (from −∞ to 0).
        // Arrows go where the curve is legible: not where it coils up near the origin (a delay
        // spirals in there), so points within a tenth of the view of 0 are left out.
        let near = 0.1 * (view.x1 - view.x0).max(view.y1 - view.y0);
        for branch in [&pos, &neg] {
            let away: Vec<(f64, f64)> = branch
                .iter()
                .map(|&(x, y)| {
                    if x.hypot(y) < near {
                        (f64::NAN, f64::NAN)
                    } else {
                        (x, y)
                    }
                })
                .collect();
            let runs = clip_polyline(&away, &view);
            for ((x, y), (dx, dy)) in points_along(&runs, &ARROW_AT) {
                p.markers.push(Marker::Arrow { x, y, dx, dy, color: k });
            }
        }
    }
    p.markers.push(Marker::Note {
        x: 0.5f64.sqrt(),
        y: 0.5f64.sqrt(),
        label: "|L| = 1".into(),
    });
    p.markers.push(Marker::Point {
        x: -1.0,
        y: 0.0,
        label: "−1".into(),
    });
    let mut f = Figure::new(title, vec![p]);
    // Close to square once the tick labels are placed: the unit circle fills the view evenly.
    f.panel_height = 720;
    f.width = 760;
    f
}

/// Writes a Nyquist plot to `path` (`.svg` or `.png`).
pub fn plot_nyquist(path: &Path, title: &str, data: &[NyquistData], radius: Option<f64>) -> Result<()> {
    nyquist_figure(title, data, radius).save(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 10/(s(s+1)) at s = jω: runs off to −j∞ as ω → 0.
    fn integrator_loop() -> NyquistData {
        let (re, im) = (0..400)
            .map(|i| {
                let w = 10f64.powf(-3.0 + 5.0 * i as f64 / 399.0);
                // 10 / (jω (1 + jω)) = 10 (−ω − j) / (ω (1 + ω²))  … written out.
                let d = w * (1.0 + w * w);
                (-10.0 * w / d, -10.0 / d)
            })
            .unzip();
        NyquistData {
            label: "L".into(),
            re,
            im,
        }
    }

    #[test]
    fn the_view_is_limited_and_marks_are_there() {
        let f = nyquist_figure("N", &[integrator_loop()], None);
        let p = &f.panels[0];
        assert_eq!(p.x_range, Some((-AUTO_RADIUS, AUTO_RADIUS)));
        assert!(p.equal_aspect);
        let arrows: Vec<&Marker> = p.markers.iter().filter(|m| matches!(m, Marker::Arrow { .. })).collect();
        assert_eq!(arrows.len(), 6);
        // Every arrow is inside the view.
        for a in arrows {
            if let Marker::Arrow { x, y, .. } = a {
                assert!(x.abs() <= AUTO_RADIUS && y.abs() <= AUTO_RADIUS);
            }
        }
        assert!(p
            .markers
            .iter()
            .any(|m| matches!(m, Marker::Point { x, y, .. } if *x == -1.0 && *y == 0.0)));
        // Mirror dashed, same colour as the curve.
        assert_eq!(p.series[2].style, SeriesStyle::Dashed);
        assert_eq!(p.series[2].color, p.series[1].color);
    }

    #[test]
    fn arrows_point_along_increasing_frequency() {
        let f = nyquist_figure("N", &[integrator_loop()], Some(2.0));
        // On the ω > 0 branch of 10/(s(s+1)) the imaginary part rises towards 0 as ω grows.
        let first = f.panels[0].markers.iter().find_map(|m| match m {
            Marker::Arrow { dy, .. } => Some(*dy),
            _ => None,
        });
        assert!(first.is_some_and(|dy| dy > 0.0));
    }
}
