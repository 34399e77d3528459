//! Drawing a [`Figure`] with plotters onto an SVG or PNG backend.

use std::path::Path;

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::error::{PlotError, Result};
use crate::figure::{usable, Figure, Marker, Panel, SeriesStyle};

/// Line colours, chosen to stay distinguishable when printed in grey.
const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// Palette colour `i`, wrapping around.
fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// The embedded DejaVu Sans (Bitstream Vera licence, `fonts/DejaVu-LICENSE.txt`): text is drawn with
/// it on every machine, so no system font library (fontconfig, freetype) or C compiler is needed.
static FONT: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");

/// Registers the embedded font as plotters' "sans-serif" once per process.
fn register_font() -> std::result::Result<(), String> {
    static REGISTERED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_ok());
    if ok {
        Ok(())
    } else {
        Err("the embedded font could not be loaded".into())
    }
}

// Rendering lives here, beside the backends; `figure` holds only data, so the two modules do not
// depend on each other in a circle.
impl Figure {
    /// Writes the figure to `path`; the format follows the extension (`.svg` or `.png`).
    pub fn save(&self, path: &std::path::Path) -> Result<()> {
        self.check()?;
        save(self, path)
    }

    /// Renders the figure as an SVG document in memory (for embedding in HTML reports).
    pub fn to_svg_string(&self) -> Result<String> {
        self.check()?;
        svg_string(self)
    }
}

/// Writes `fig` to `path`, choosing the backend from the extension.
pub(crate) fn save(fig: &Figure, path: &Path) -> Result<()> {
    let name = path.display().to_string();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let size = (fig.width, fig.panel_height * fig.panels.len() as u32 + 40);
    let draw_err = |e: String| PlotError::Draw {
        path: name.clone(),
        message: e,
    };
    match ext.as_deref() {
        Some("svg") => {
            let root = SVGBackend::new(path, size).into_drawing_area();
            draw_figure(fig, &root).map_err(draw_err)?;
            root.present().map_err(|e| draw_err(e.to_string()))
        }
        Some("png") => {
            let root = BitMapBackend::new(path, size).into_drawing_area();
            draw_figure(fig, &root).map_err(draw_err)?;
            root.present().map_err(|e| draw_err(e.to_string()))
        }
        _ => Err(PlotError::Format(name)),
    }
}

/// Renders `fig` to an SVG string.
pub(crate) fn svg_string(fig: &Figure) -> Result<String> {
    let size = (fig.width, fig.panel_height * fig.panels.len() as u32 + 40);
    let mut buf = String::new();
    {
        let root = SVGBackend::with_string(&mut buf, size).into_drawing_area();
        draw_figure(fig, &root).map_err(|e| PlotError::Draw {
            path: "<svg>".into(),
            message: e,
        })?;
        root.present().map_err(|e| PlotError::Draw {
            path: "<svg>".into(),
            message: e.to_string(),
        })?;
    }
    Ok(buf)
}

fn draw_figure<DB: DrawingBackend>(fig: &Figure, root: &DrawingArea<DB, Shift>) -> std::result::Result<(), String> {
    register_font()?;
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let root = root.titled(&fig.title, ("sans-serif", 22)).map_err(|e| e.to_string())?;
    let areas = root.split_evenly((fig.panels.len(), 1));
    for (panel, area) in fig.panels.iter().zip(areas.iter()) {
        draw_panel(panel, area)?;
    }
    Ok(())
}

/// The data range of a panel along one axis, padded; log axes snap outward to decades.
fn axis_range(values: impl Iterator<Item = f64>, log: bool, fixed: Option<(f64, f64)>) -> (f64, f64) {
    if let Some(r) = fixed {
        return r;
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| usable(*v, log)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return if log { (0.1, 10.0) } else { (-1.0, 1.0) };
    }
    if log {
        let (a, b) = (lo.log10().floor(), hi.log10().ceil());
        let b = if b <= a { a + 1.0 } else { b };
        (10f64.powf(a), 10f64.powf(b))
    } else {
        let span = hi - lo;
        let pad = if span > 0.0 {
            0.05 * span
        } else {
            0.5 * lo.abs().max(1.0)
        };
        (lo - pad, hi + pad)
    }
}

fn draw_panel<DB: DrawingBackend>(p: &Panel, area: &DrawingArea<DB, Shift>) -> std::result::Result<(), String> {
    let xs = p
        .series
        .iter()
        .flat_map(|s| s.x.iter().copied())
        .chain(p.bands.iter().flat_map(|b| b.x.clone()));
    let ys = p
        .series
        .iter()
        .flat_map(|s| s.y.iter().copied())
        .chain(
            p.bands
                .iter()
                .flat_map(|b| b.lower.iter().chain(&b.upper).copied().collect::<Vec<_>>()),
        )
        .chain(p.markers.iter().filter_map(|m| match m {
            Marker::Horizontal { y, .. } | Marker::Point { y, .. } => Some(*y),
            Marker::Vertical { .. } => None,
        }));
    let (x0, x1) = axis_range(xs, p.x_log, p.x_range);
    let (y0, y1) = axis_range(ys, p.y_log, p.y_range);
    match (p.x_log, p.y_log) {
        (false, false) => draw_in(p, area, x0..x1, y0..y1),
        (true, false) => draw_in(p, area, (x0..x1).log_scale(), y0..y1),
        (false, true) => draw_in(p, area, x0..x1, (y0..y1).log_scale()),
        (true, true) => draw_in(p, area, (x0..x1).log_scale(), (y0..y1).log_scale()),
    }
}

fn draw_in<DB, X, Y>(p: &Panel, area: &DrawingArea<DB, Shift>, xr: X, yr: Y) -> std::result::Result<(), String>
where
    DB: DrawingBackend,
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let mut chart = ChartBuilder::on(area)
        .caption(&p.title, ("sans-serif", 16))
        .margin(8)
        .margin_right(28)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d(xr, yr)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(p.x_label.as_str())
        .y_desc(p.y_label.as_str())
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(e)?;
    let (xlo, xhi) = {
        let r = chart.x_range();
        (r.start, r.end)
    };
    let (ylo, yhi) = {
        let r = chart.y_range();
        (r.start, r.end)
    };
    let clip_y = |y: f64| y.clamp(ylo, yhi);
    let mut any_legend = false;

    for b in &p.bands {
        let mut poly: Vec<(f64, f64)> = Vec::with_capacity(2 * b.x.len());
        for i in 0..b.x.len() {
            if usable(b.x[i], p.x_log) && usable(b.upper[i], p.y_log) {
                poly.push((b.x[i], clip_y(b.upper[i])));
            }
        }
        for i in (0..b.x.len()).rev() {
            if usable(b.x[i], p.x_log) && usable(b.lower[i], p.y_log) {
                poly.push((b.x[i], clip_y(b.lower[i])));
            }
        }
        let fill = color(b.color).mix(0.2);
        let ann = chart
            .draw_series(std::iter::once(Polygon::new(poly, fill.filled())))
            .map_err(e)?;
        if !b.label.is_empty() {
            any_legend = true;
            ann.label(b.label.as_str())
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 16, y + 5)], fill.filled()));
        }
    }

    for (k, s) in p.series.iter().enumerate() {
        let c = color(s.color.unwrap_or(k));
        // Points that cannot be placed split the line rather than being joined across the gap.
        let mut segments: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
        for (x, y) in s.x.iter().zip(&s.y) {
            if usable(*x, p.x_log) && usable(*y, p.y_log) {
                if let Some(last) = segments.last_mut() {
                    last.push((*x, *y));
                }
            } else if segments.last().is_some_and(|l| !l.is_empty()) {
                segments.push(Vec::new());
            }
        }
        let style = ShapeStyle::from(&c).stroke_width(2);
        let mut first = true;
        for seg in segments.iter().filter(|seg| !seg.is_empty()) {
            let ann = match s.style {
                SeriesStyle::Line => chart
                    .draw_series(LineSeries::new(seg.iter().copied(), style))
                    .map_err(e)?,
                SeriesStyle::Dashed => chart
                    .draw_series(DashedLineSeries::new(seg.iter().copied(), 8, 5, style))
                    .map_err(e)?,
                SeriesStyle::Points => chart
                    .draw_series(seg.iter().map(|&(x, y)| Circle::new((x, y), 3, c.filled())))
                    .map_err(e)?,
                SeriesStyle::Stems => chart
                    .draw_series(
                        seg.iter()
                            .map(|&(x, y)| PathElement::new(vec![(x, ylo), (x, y)], style)),
                    )
                    .map_err(e)?,
            };
            if first && !s.label.is_empty() {
                any_legend = true;
                ann.label(s.label.as_str())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], c.stroke_width(2)));
            }
            first = false;
        }
    }

    let grey = RGBColor(90, 90, 90);
    for m in &p.markers {
        match m {
            Marker::Vertical { x, label } if usable(*x, p.x_log) => {
                chart
                    .draw_series(DashedLineSeries::new(
                        vec![(*x, ylo), (*x, yhi)],
                        4,
                        4,
                        grey.stroke_width(1),
                    ))
                    .map_err(e)?;
                chart
                    .draw_series(std::iter::once(Text::new(label.clone(), (*x, yhi), ("sans-serif", 12))))
                    .map_err(e)?;
            }
            Marker::Horizontal { y, label } if usable(*y, p.y_log) => {
                chart
                    .draw_series(DashedLineSeries::new(
                        vec![(xlo, *y), (xhi, *y)],
                        4,
                        4,
                        grey.stroke_width(1),
                    ))
                    .map_err(e)?;
                chart
                    .draw_series(std::iter::once(Text::new(label.clone(), (xlo, *y), ("sans-serif", 12))))
                    .map_err(e)?;
            }
            Marker::Point { x, y, label } if usable(*x, p.x_log) && usable(*y, p.y_log) => {
                chart
                    .draw_series(std::iter::once(Cross::new((*x, *y), 6, RED.stroke_width(2))))
                    .map_err(e)?;
                chart
                    .draw_series(std::iter::once(Text::new(label.clone(), (*x, *y), ("sans-serif", 12))))
                    .map_err(e)?;
            }
            _ => {}
        }
    }

    if any_legend {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(160, 160, 160))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(e)?;
    }
    Ok(())
}
