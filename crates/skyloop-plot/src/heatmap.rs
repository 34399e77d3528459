//! Heatmaps with a colour bar: a value over a grid of x (throttle, time) and y (frequency), as a
//! spectrogram is drawn, with labelled overlay lines (motor harmonics) on top.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::error::{PlotError, Result};
use crate::layout::{BoxKind, Layout, PlacedBox, PxRect};
use crate::render::{register_font, text_style};
use crate::ticks::{format_tick, nice_step};

/// A line drawn over the heatmap, e.g. a motor harmonic against throttle.
#[derive(Debug, Clone, PartialEq)]
pub struct Overlay {
    /// Label drawn at the line's right end.
    pub label: String,
    /// Points (x, y) in data units.
    pub points: Vec<(f64, f64)>,
}

/// A heatmap: `z[i][j]` is the value at `x[i]`, `y[j]` (NaN: no data, drawn light grey).
#[derive(Debug, Clone, PartialEq)]
pub struct Heatmap {
    /// Caption.
    pub title: String,
    /// x-axis description with its unit.
    pub x_label: String,
    /// y-axis description with its unit.
    pub y_label: String,
    /// Colour-bar description with its unit.
    pub colorbar_label: String,
    /// Cell centres along x, increasing.
    pub x: Vec<f64>,
    /// Cell centres along y, increasing and evenly spaced.
    pub y: Vec<f64>,
    /// Values, one row per x.
    pub z: Vec<Vec<f64>>,
    /// Lines over the map.
    pub overlays: Vec<Overlay>,
    /// Largest y shown (None: the last y).
    pub y_max: Option<f64>,
    /// Colour range (None: the 2nd percentile to the largest value).
    pub z_range: Option<(f64, f64)>,
}

/// The viridis colour map's anchors (perceptually uniform, readable in grey and by colour-blind
/// readers), from dark (low) to yellow (high).
const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (71, 44, 122),
    (59, 81, 139),
    (44, 113, 142),
    (33, 144, 141),
    (39, 173, 129),
    (92, 200, 99),
    (170, 220, 50),
    (253, 231, 37),
];

/// The colour of `t` in [0, 1] on the map.
pub fn colormap(t: f64) -> RGBColor {
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let s = t * (VIRIDIS.len() - 1) as f64;
    let i = (s.floor() as usize).min(VIRIDIS.len() - 2);
    let f = s - i as f64;
    let mix = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

const WIDTH: u32 = 960;
const HEIGHT: u32 = 420;

impl Heatmap {
    fn check(&self) -> Result<()> {
        if self.x.is_empty()
            || self.y.len() < 2
            || self.z.len() != self.x.len()
            || self.z.iter().any(|r| r.len() != self.y.len())
        {
            return Err(PlotError::Data(format!(
                "heatmap '{}' needs one row of {} values per x ({} rows for {} x)",
                self.title,
                self.y.len(),
                self.z.len(),
                self.x.len()
            )));
        }
        if !self.z.iter().flatten().any(|v| v.is_finite()) {
            return Err(PlotError::Data(format!("heatmap '{}' has no finite value", self.title)));
        }
        Ok(())
    }

    /// The colour range: given, or the 2nd percentile to the largest finite value.
    pub fn range(&self) -> (f64, f64) {
        if let Some(r) = self.z_range {
            return r;
        }
        let mut v: Vec<f64> = self.z.iter().flatten().copied().filter(|v| v.is_finite()).collect();
        v.sort_by(f64::total_cmp);
        let lo = v.get(v.len() / 50).copied().unwrap_or(0.0);
        let hi = v.last().copied().unwrap_or(1.0);
        (lo, if hi > lo { hi } else { lo + 1.0 })
    }

    /// Writes the heatmap as `.png` or `.svg` (by the extension).
    ///
    /// # Errors
    /// Rows that do not match the axes, no finite value, an unknown extension or an unwritable file.
    pub fn save(&self, path: &std::path::Path) -> Result<()> {
        self.check()?;
        let name = path.display().to_string();
        let err = |m: String| PlotError::Draw {
            path: name.clone(),
            message: m,
        };
        std::fs::File::create(path).map_err(|e| err(format!("cannot create the file: {e}")))?;
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            // No bitmap file backend on wasm32 (see `render::register_font`).
            #[cfg(not(target_arch = "wasm32"))]
            Some("png") => {
                let backend =
                    crate::raster_text::PngBackend::new(BitMapBackend::new(path, (WIDTH, HEIGHT)), crate::render::FONT)
                        .map_err(err)?;
                let root = backend.into_drawing_area();
                self.draw(&root, &mut Vec::new()).map_err(err)?;
                root.present().map_err(|e| err(e.to_string()))
            }
            Some("svg") => {
                let root = SVGBackend::new(path, (WIDTH, HEIGHT)).into_drawing_area();
                self.draw(&root, &mut Vec::new()).map_err(err)?;
                root.present().map_err(|e| err(e.to_string()))
            }
            _ => Err(PlotError::Format(name)),
        }
    }

    /// The heatmap as an SVG document (for HTML reports).
    ///
    /// # Errors
    /// As [`save`](Self::save), without the file.
    pub fn to_svg_string(&self) -> Result<String> {
        self.svg_recorded(&mut Vec::new())
    }

    /// Where rendering puts the overlay labels: their pixel boxes (panel 0, [`BoxKind::Label`]).
    ///
    /// # Errors
    /// As [`to_svg_string`](Self::to_svg_string).
    pub fn layout(&self) -> Result<Layout> {
        let mut boxes = Vec::new();
        self.svg_recorded(&mut boxes)?;
        Ok(Layout { boxes })
    }

    fn svg_recorded(&self, rec: &mut Vec<PlacedBox>) -> Result<String> {
        self.check()?;
        let mut buf = String::new();
        {
            let root = SVGBackend::with_string(&mut buf, (WIDTH, HEIGHT)).into_drawing_area();
            let err = |m: String| PlotError::Draw {
                path: "<svg>".into(),
                message: m,
            };
            self.draw(&root, rec).map_err(err)?;
            root.present().map_err(|e| err(e.to_string()))?;
        }
        Ok(buf)
    }

    /// Draws the heatmap, recording the boxes of the overlay labels in `rec`.
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        rec: &mut Vec<PlacedBox>,
    ) -> std::result::Result<(), String> {
        register_font()?;
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        root.fill(&WHITE).map_err(e)?;
        let body = root.titled(&self.title, ("sans-serif", 18)).map_err(e)?;
        let (map, bar) = body.split_horizontally(WIDTH - 130);
        let (lo, hi) = self.range();
        let dx = |i: usize| -> (f64, f64) {
            let c = self.x[i];
            let left = if i > 0 {
                0.5 * (self.x[i - 1] + c)
            } else if self.x.len() > 1 {
                c - 0.5 * (self.x[1] - c)
            } else {
                c - 0.5
            };
            let right = if i + 1 < self.x.len() {
                0.5 * (self.x[i + 1] + c)
            } else if i > 0 {
                c + 0.5 * (c - self.x[i - 1])
            } else {
                c + 0.5
            };
            (left, right)
        };
        let half_dy = 0.5 * (self.y[1] - self.y[0]);
        let y_max = self.y_max.unwrap_or(self.y[self.y.len() - 1] + half_dy);
        let (x0, x1) = (dx(0).0, dx(self.x.len() - 1).1);
        let mut chart = ChartBuilder::on(&map)
            .margin(10)
            .x_label_area_size(46)
            .y_label_area_size(64)
            .build_cartesian_2d(x0..x1, 0f64..y_max)
            .map_err(|e| e.to_string())?;
        // Tick labels as the other figures write them (no trailing ".0").
        let (xs, ys) = (nice_step(x0, x1, 10), nice_step(0.0, y_max, 8));
        let fx = |v: &f64| format_tick(*v, xs);
        let fy = |v: &f64| format_tick(*v, ys);
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .x_labels(10)
            .y_labels(8)
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .label_style(text_style(13.0))
            .axis_desc_style(text_style(14.0))
            .draw()
            .map_err(|e| e.to_string())?;
        for (i, row) in self.z.iter().enumerate() {
            let (l, r) = dx(i);
            let cells = self
                .y
                .iter()
                .zip(row)
                .filter(|(y, _)| **y - half_dy < y_max)
                .map(|(y, v)| {
                    let color = if v.is_finite() {
                        colormap((v - lo) / (hi - lo))
                    } else {
                        RGBColor(235, 235, 235)
                    };
                    Rectangle::new(
                        [(l, (y - half_dy).max(0.0)), (r, (y + half_dy).min(y_max))],
                        color.filled(),
                    )
                });
            chart.draw_series(cells).map_err(|e| e.to_string())?;
        }
        for o in &self.overlays {
            let pts: Vec<(f64, f64)> = o
                .points
                .iter()
                .copied()
                .filter(|(x, y)| x.is_finite() && y.is_finite() && *y <= y_max)
                .collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), WHITE.stroke_width(2)))
                .map_err(|e| e.to_string())?;
            if let Some(&(x, y)) = pts.last() {
                let style = text_style(12.0).color(&WHITE).pos(Pos::new(HPos::Right, VPos::Bottom));
                let (w, h) = root.estimate_text_size(&o.label, &style).map_err(e)?;
                let (u, v) = chart.backend_coord(&(x, y));
                rec.push(PlacedBox {
                    panel: 0,
                    kind: BoxKind::Label,
                    text: o.label.clone(),
                    rect: PxRect {
                        left: u - w as i32,
                        top: v - h as i32,
                        right: u,
                        bottom: v,
                    },
                });
                chart
                    .draw_series(std::iter::once(Text::new(o.label.clone(), (x, y), style)))
                    .map_err(|e| e.to_string())?;
            }
        }
        self.draw_bar(&bar, lo, hi)
    }

    fn draw_bar<DB: DrawingBackend>(
        &self,
        bar: &DrawingArea<DB, Shift>,
        lo: f64,
        hi: f64,
    ) -> std::result::Result<(), String> {
        let mut c = ChartBuilder::on(bar)
            .margin_top(10)
            .margin_bottom(56)
            .margin_right(4)
            .y_label_area_size(0)
            .right_y_label_area_size(70)
            .build_cartesian_2d(0f64..1f64, lo..hi)
            .map_err(|e| e.to_string())?;
        let zs = nice_step(lo, hi, 8);
        let fz = |v: &f64| format_tick(*v, zs);
        c.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_label_formatter(&fz)
            .y_desc(self.colorbar_label.as_str())
            .y_labels(8)
            .label_style(text_style(12.0))
            .axis_desc_style(text_style(13.0))
            .draw()
            .map_err(|e| e.to_string())?;
        let n = 120;
        let step = (hi - lo) / n as f64;
        c.draw_series((0..n).map(|k| {
            let v = lo + k as f64 * step;
            Rectangle::new(
                [(0.0, v), (1.0, v + step)],
                colormap((v + 0.5 * step - lo) / (hi - lo)).filled(),
            )
        }))
        .map_err(|e| e.to_string())?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn renders_with_a_colour_bar_and_rejects_ragged_rows() {
        let x: Vec<f64> = (0..20).map(|i| 2.5 + 5.0 * i as f64).collect();
        let y: Vec<f64> = (0..100).map(|j| 4.0 * j as f64).collect();
        let z: Vec<Vec<f64>> = x
            .iter()
            .map(|t| {
                y.iter()
                    .map(|f| -60.0 + 30.0 * (-((f - 3.0 * t) / 20.0).powi(2)).exp())
                    .collect()
            })
            .collect();
        let h = Heatmap {
            title: "gyro roll".into(),
            x_label: "throttle [%]".into(),
            y_label: "frequency [Hz]".into(),
            colorbar_label: "PSD [dB]".into(),
            x,
            y,
            z,
            overlays: vec![Overlay {
                label: "motor ×1".into(),
                points: vec![(10.0, 30.0), (90.0, 270.0)],
            }],
            y_max: None,
            z_range: None,
        };
        let svg = h.to_svg_string().unwrap();
        assert!(svg.contains("PSD [dB]") && svg.contains("motor ×1") && svg.contains("throttle [%]"));
        let dir = std::env::temp_dir().join(format!("skyloop-heat-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        h.save(&dir.join("h.png")).unwrap();
        assert!(std::fs::metadata(dir.join("h.png")).unwrap().len() > 5000);
        let mut bad = h.clone();
        bad.z[3].pop();
        assert!(bad.to_svg_string().is_err());
        assert_eq!(colormap(0.0), RGBColor(68, 1, 84));
        assert_eq!(colormap(1.0), RGBColor(253, 231, 37));
    }
}
