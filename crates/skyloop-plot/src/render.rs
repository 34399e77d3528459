//! Drawing a [`Figure`] onto an SVG or PNG backend of plotters.
//!
//! The axes are laid out and drawn here rather than by plotters' mesh, so that tick labels follow
//! [`crate::ticks`] (engineering notation, decades on log axes), the label area is as wide as the
//! widest measured label (nothing clipped), curves are cut where they leave the view box
//! ([`crate::geometry`]) instead of being clamped onto the frame, and legends go where they hide no
//! data.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::error::{PlotError, Result};
use crate::figure::{usable, Figure, Marker, Panel, SeriesStyle, NEUTRAL, PALETTE};
use crate::geometry::{clip_polygon, clip_polyline, ViewBox};
use crate::layout::{BoxKind, Layout, PlacedBox, PxRect};
use crate::ticks::{degree_ticks, linear_ticks, log_ticks, Tick};

/// Palette colour `i` (wrapping).
fn color(i: usize) -> RGBColor {
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    RGBColor(r, g, b)
}

fn neutral() -> RGBColor {
    RGBColor(NEUTRAL.0, NEUTRAL.1, NEUTRAL.2)
}

/// The embedded DejaVu Sans (Bitstream Vera licence, `fonts/DejaVu-LICENSE.txt`): text is drawn with
/// it on every machine, so no system font library (fontconfig, freetype) or C compiler is needed.
#[cfg(not(target_arch = "wasm32"))]
pub(crate) static FONT: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");

/// Registers the embedded font as plotters' "sans-serif" once per process.
#[cfg(not(target_arch = "wasm32"))]
pub(crate) fn register_font() -> std::result::Result<(), String> {
    static REGISTERED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_ok());
    if ok {
        Ok(())
    } else {
        Err("the embedded font could not be loaded".into())
    }
}

/// plotters has no font registration on wasm32 (its ab_glyph backend is native only): a browser page
/// draws its plots itself and takes only the figures' data from here.
#[cfg(target_arch = "wasm32")]
pub(crate) fn register_font() -> std::result::Result<(), String> {
    Err("figures are not rendered in WebAssembly builds (the page draws them from their data)".into())
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

    /// Where rendering puts every legend and text of the figure: pixel boxes in the image
    /// [`Figure::save`] writes (the same layout for SVG and PNG; the text is measured with the
    /// embedded font).
    pub fn layout(&self) -> Result<Layout> {
        self.check()?;
        let mut boxes = Vec::new();
        svg_string_recorded(self, &mut boxes)?;
        Ok(Layout { boxes })
    }
}

/// Writes `fig` to `path`, choosing the backend from the extension.
pub(crate) fn save(fig: &Figure, path: &Path) -> Result<()> {
    let name = path.display().to_string();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let size = fig.size();
    let draw_err = |e: String| PlotError::Draw {
        path: name.clone(),
        message: e,
    };
    if matches!(ext.as_deref(), Some("svg" | "png")) {
        // The backends report a missing folder or a read-only file as a Debug dump of their nested
        // error at present() time; checking first gives the operating system's own words.
        std::fs::File::create(path).map_err(|e| draw_err(format!("cannot create the file: {e}")))?;
    }
    match ext.as_deref() {
        Some("svg") => {
            let root = SVGBackend::new(path, size).into_drawing_area();
            draw_figure(fig, &root, &mut Vec::new()).map_err(draw_err)?;
            root.present().map_err(|e| draw_err(e.to_string()))
        }
        // No bitmap file backend on wasm32 (see `register_font`).
        #[cfg(not(target_arch = "wasm32"))]
        Some("png") => {
            let backend =
                crate::raster_text::PngBackend::new(BitMapBackend::new(path, size), FONT).map_err(draw_err)?;
            let root = backend.into_drawing_area();
            draw_figure(fig, &root, &mut Vec::new()).map_err(draw_err)?;
            root.present().map_err(|e| draw_err(e.to_string()))
        }
        _ => Err(PlotError::Format(name)),
    }
}

/// Renders `fig` to an SVG string.
pub(crate) fn svg_string(fig: &Figure) -> Result<String> {
    svg_string_recorded(fig, &mut Vec::new())
}

/// Renders `fig` to an SVG string, recording the boxes of its legends and texts in `rec`.
fn svg_string_recorded(fig: &Figure, rec: &mut Vec<PlacedBox>) -> Result<String> {
    let size = fig.size();
    let mut buf = String::new();
    {
        let root = SVGBackend::with_string(&mut buf, size).into_drawing_area();
        draw_figure(fig, &root, rec).map_err(|e| PlotError::Draw {
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

/// Font sizes, px.
const TICK_FONT: f64 = 13.0;
const DESC_FONT: f64 = 14.0;
const TITLE_FONT: f64 = 15.0;
const NOTE_FONT: f64 = 12.0;
const LEGEND_FONT: f64 = 13.0;

pub(crate) fn text_style(size: f64) -> TextStyle<'static> {
    TextStyle::from(("sans-serif", size).into_font()).color(&BLACK)
}

/// Width and height of `s` in pixels as drawn on `area` (a rough estimate if the font fails).
fn measure<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, s: &str, size: f64) -> (i32, i32) {
    match area.estimate_text_size(s, &text_style(size)) {
        Ok((w, h)) => (w as i32, h as i32),
        Err(_) => ((0.6 * size * s.chars().count() as f64) as i32, size as i32),
    }
}

/// One axis: its range and scale, and the map from data to pixels.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Axis {
    pub(crate) lo: f64,
    pub(crate) hi: f64,
    pub(crate) log: bool,
}

impl Axis {
    /// The axis coordinate in which the map to pixels is linear (log10 on a log axis).
    pub(crate) fn t(&self, v: f64) -> f64 {
        if self.log {
            v.log10()
        } else {
            v
        }
    }
}

/// The data range of a panel along one axis, padded; log axes snap outward to decades.
///
/// A log y axis gets a little room before snapping, so a value on a decade (a Hankel singular value
/// of 10⁻⁶) is not drawn on the frame; a log x axis does not, so a frequency grid from 0.01 to 100 Hz
/// fills the axis exactly.
pub(crate) fn axis_range(
    values: impl Iterator<Item = f64>,
    log: bool,
    fixed: Option<(f64, f64)>,
    is_y: bool,
) -> (f64, f64) {
    if let Some((a, b)) = fixed {
        if usable(a, log) && usable(b, log) && a != b {
            return (a.min(b), a.max(b));
        }
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
        // A little room first, so a value on a decade is not drawn on the frame.
        let pad = if is_y {
            0.02 * (hi.log10() - lo.log10()).max(0.5)
        } else {
            0.0
        };
        let (a, b) = ((lo.log10() - pad).floor(), (hi.log10() + pad).ceil());
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

/// The x and y axes a panel is drawn in (before equal-aspect widening).
pub(crate) fn panel_axes(p: &Panel) -> (Axis, Axis) {
    let xs = p
        .series
        .iter()
        .flat_map(|s| s.x.iter().copied())
        .chain(p.bands.iter().flat_map(|b| b.x.iter().copied()))
        .chain(p.markers.iter().filter_map(|m| match m {
            Marker::Point { x, .. } => Some(*x),
            _ => None,
        }));
    let ys = p
        .series
        .iter()
        .flat_map(|s| s.y.iter().copied())
        .chain(p.bands.iter().flat_map(|b| b.lower.iter().chain(&b.upper).copied()))
        .chain(p.markers.iter().filter_map(|m| match m {
            Marker::Horizontal { y, .. } | Marker::Point { y, .. } => Some(*y),
            _ => None,
        }));
    let (x0, x1) = axis_range(xs, p.x_log, p.x_range, false);
    let (y0, y1) = axis_range(ys, p.y_log, p.y_range, true);
    (
        Axis {
            lo: x0,
            hi: x1,
            log: p.x_log,
        },
        Axis {
            lo: y0,
            hi: y1,
            log: p.y_log,
        },
    )
}

/// Widens one range so a data unit spans as many pixels in x as in y (linear axes only).
fn equalize(x: &mut Axis, y: &mut Axis, w: f64, h: f64) {
    if x.log || y.log || w <= 0.0 || h <= 0.0 {
        return;
    }
    let ux = (x.hi - x.lo) / w;
    let uy = (y.hi - y.lo) / h;
    if ux > uy {
        let c = 0.5 * (y.lo + y.hi);
        let half = 0.5 * ux * h;
        y.lo = c - half;
        y.hi = c + half;
    } else {
        let c = 0.5 * (x.lo + x.hi);
        let half = 0.5 * uy * w;
        x.lo = c - half;
        x.hi = c + half;
    }
}

/// Ticks of one axis given the pixel length available.
/// On a log y axis (dimensionless: singular values, μ) labels far from 1 are written with a power of
/// ten; a log x axis is a frequency in Hz and keeps SI prefixes ("10k").
fn axis_ticks(a: &Axis, degrees: bool, pixels: f64, spacing: f64, max: usize) -> Vec<Tick> {
    let n = ((pixels / spacing).floor() as usize).clamp(2, max);
    if a.log {
        // Decade labels are short ("10", "1k"): they can sit closer than linear ones.
        let mut t = log_ticks(a.lo, a.hi, ((pixels / (0.6 * spacing)).floor() as usize).clamp(2, 16));
        // Minor lines (2…9 × 10ᵏ) only where a decade is wide enough for them not to be a smear.
        let decades = (a.hi / a.lo).log10();
        if pixels / decades.max(1e-9) < 45.0 {
            t.retain(|t| t.label.is_some() || (t.value.log10().fract()).abs() < 1e-9);
        }
        t
    } else if degrees {
        degree_ticks(a.lo, a.hi, n)
    } else {
        linear_ticks(a.lo, a.hi, n)
    }
}

/// Where a panel's plot area sits inside its drawing area, px (area-relative).
#[derive(Debug, Clone, Copy)]
struct Frame {
    left: i32,
    top: i32,
    right: i32,
    bottom: i32,
    x: Axis,
    y: Axis,
}

impl Frame {
    /// Pixel position of a point given in axis coordinates (`Axis::t`).
    fn px_t(&self, tx: f64, ty: f64) -> (f64, f64) {
        let (a, b) = (self.x.t(self.x.lo), self.x.t(self.x.hi));
        let (c, d) = (self.y.t(self.y.lo), self.y.t(self.y.hi));
        let u = self.left as f64 + (tx - a) / (b - a) * (self.right - self.left) as f64;
        let v = self.bottom as f64 - (ty - c) / (d - c) * (self.bottom - self.top) as f64;
        (u, v)
    }

    /// Pixel position of a data point.
    fn px(&self, x: f64, y: f64) -> (f64, f64) {
        self.px_t(self.x.t(x), self.y.t(y))
    }

    /// The view box in axis coordinates.
    fn tbox(&self) -> ViewBox {
        ViewBox {
            x0: self.x.t(self.x.lo),
            x1: self.x.t(self.x.hi),
            y0: self.y.t(self.y.lo),
            y1: self.y.t(self.y.hi),
        }
    }

    fn inside_px(&self, p: (f64, f64)) -> bool {
        p.0 >= self.left as f64 && p.0 <= self.right as f64 && p.1 >= self.top as f64 && p.1 <= self.bottom as f64
    }
}

/// A panel after layout: its frame, ticks, and its curves already clipped and in pixels.
struct Laid {
    frame: Frame,
    xticks: Vec<Tick>,
    yticks: Vec<Tick>,
    /// Visible runs of each series, px.
    runs: Vec<Vec<Vec<(f64, f64)>>>,
    legend: Vec<LegendEntry>,
    legend_size: (i32, i32),
    /// Pixels of point-like markers and notes (the legend must not hide them either).
    marks: Vec<(f64, f64)>,
    /// The markers' labels, placed ([`place_labels`]; empty until then).
    labels: Vec<PlacedLabel>,
}

#[derive(Clone)]
enum LegendKind {
    Line { dashed: bool },
    Band,
    Mark(SeriesStyle),
}

#[derive(Clone)]
struct LegendEntry {
    label: String,
    color: RGBColor,
    kind: LegendKind,
}

/// Colours of every series of the figure (palette indices; `usize::MAX` for reference grey): a fixed
/// colour wins; otherwise series sharing a label share a colour across panels.
pub(crate) fn resolve_colors(fig: &Figure) -> Vec<Vec<usize>> {
    let mut by_label: Vec<(String, usize)> = Vec::new();
    let mut next = 0usize;
    fig.panels
        .iter()
        .map(|p| {
            p.series
                .iter()
                .enumerate()
                .map(|(k, s)| {
                    if s.style == SeriesStyle::Reference {
                        return usize::MAX;
                    }
                    if let Some(c) = s.color {
                        return c;
                    }
                    if s.label.is_empty() {
                        return k;
                    }
                    if let Some((_, c)) = by_label.iter().find(|(l, _)| *l == s.label) {
                        return *c;
                    }
                    let c = next;
                    next += 1;
                    by_label.push((s.label.clone(), c));
                    c
                })
                .collect()
        })
        .collect()
}

fn rgb(c: usize) -> RGBColor {
    if c == usize::MAX {
        neutral()
    } else {
        color(c)
    }
}

fn legend_entries(p: &Panel, colors: &[usize]) -> Vec<LegendEntry> {
    let mut out = Vec::new();
    for b in &p.bands {
        if !b.label.is_empty() {
            out.push(LegendEntry {
                label: b.label.clone(),
                color: color(b.color),
                kind: LegendKind::Band,
            });
        }
    }
    for (s, c) in p.series.iter().zip(colors) {
        if s.label.is_empty() || out.iter().any(|e: &LegendEntry| e.label == s.label) {
            continue;
        }
        let kind = match s.style {
            SeriesStyle::Line => LegendKind::Line { dashed: false },
            SeriesStyle::Dashed | SeriesStyle::Reference => LegendKind::Line { dashed: true },
            other => LegendKind::Mark(other),
        };
        out.push(LegendEntry {
            label: s.label.clone(),
            color: rgb(*c),
            kind,
        });
    }
    out
}

const LEGEND_ROW: i32 = 19;
const LEGEND_SWATCH: i32 = 26;

fn legend_size<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, entries: &[LegendEntry]) -> (i32, i32) {
    if entries.is_empty() {
        return (0, 0);
    }
    let w = entries
        .iter()
        .map(|e| measure(area, &e.label, LEGEND_FONT).0)
        .max()
        .unwrap_or(0);
    (w + LEGEND_SWATCH + 18, entries.len() as i32 * LEGEND_ROW + 8)
}

/// Left and bottom space a panel needs for its tick labels and axis descriptions, px.
fn margins<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &Panel, yticks: &[Tick]) -> (i32, i32) {
    let widest = yticks
        .iter()
        .filter_map(|t| t.label.as_ref())
        .map(|l| measure(area, l, TICK_FONT).0)
        .max()
        .unwrap_or(0);
    let desc = if p.y_label.is_empty() {
        0
    } else {
        measure(area, &p.y_label, DESC_FONT).1 + 8
    };
    let left = 8 + desc + widest + 8;
    let bottom = 6 + TICK_FONT as i32 + 6 + if p.x_label.is_empty() { 0 } else { DESC_FONT as i32 + 8 } + 4;
    (left, bottom)
}

fn top_margin(p: &Panel) -> i32 {
    if p.title.is_empty() {
        12
    } else {
        TITLE_FONT as i32 + 14
    }
}

/// Lays out a panel given the margins; widens for equal aspect and clips the curves.
fn lay_out(p: &Panel, colors_unused: &[usize], (w, h): (i32, i32), left: i32, bottom: i32, right: i32) -> Laid {
    let _ = colors_unused;
    let (mut xa, mut ya) = panel_axes(p);
    let top = top_margin(p);
    let (pw, ph) = ((w - left - right).max(20), (h - top - bottom).max(20));
    if p.equal_aspect {
        equalize(&mut xa, &mut ya, pw as f64, ph as f64);
    }
    let frame = Frame {
        left,
        top,
        right: left + pw,
        bottom: top + ph,
        x: xa,
        y: ya,
    };
    let xticks = axis_ticks(&xa, p.x_degrees, pw as f64, 85.0, 14);
    // At most 10 labels up the side: a tall dB axis then reads in 10s or 20s.
    let mut yticks = axis_ticks(&ya, p.y_degrees, ph as f64, 26.0, 10);
    if ya.log {
        for t in &mut yticks {
            if t.label.is_some() {
                let decade = 10f64.powf(t.value.log10().floor());
                t.label = Some(crate::ticks::format_tick_exp(t.value, decade));
            }
        }
    }
    let tb = frame.tbox();
    let runs = p
        .series
        .iter()
        .map(|s| {
            let pts: Vec<(f64, f64)> =
                s.x.iter()
                    .zip(&s.y)
                    .map(|(x, y)| {
                        if usable(*x, p.x_log) && usable(*y, p.y_log) {
                            (xa.t(*x), ya.t(*y))
                        } else {
                            (f64::NAN, f64::NAN)
                        }
                    })
                    .collect();
            let runs = match s.style {
                SeriesStyle::Line | SeriesStyle::Dashed | SeriesStyle::Reference => clip_polyline(&pts, &tb),
                // Markers are kept or dropped whole, never moved onto the frame.
                _ => pts
                    .iter()
                    .filter(|q| q.0.is_finite() && tb.contains(q.0, q.1))
                    .map(|q| vec![*q])
                    .collect(),
            };
            runs.into_iter()
                .map(|r| r.into_iter().map(|(tx, ty)| frame.px_t(tx, ty)).collect())
                .collect()
        })
        .collect();
    let marks = p
        .markers
        .iter()
        .filter_map(|m| match m {
            Marker::Point { x, y, .. } | Marker::Note { x, y, .. } | Marker::Arrow { x, y, .. }
                if usable(*x, p.x_log) && usable(*y, p.y_log) =>
            {
                Some(frame.px(*x, *y))
            }
            _ => None,
        })
        .collect();
    Laid {
        frame,
        xticks,
        yticks,
        runs,
        legend: Vec::new(),
        legend_size: (0, 0),
        marks,
        labels: Vec::new(),
    }
}

/// How many drawn pixels of the curves fall inside a rectangle (lines sampled every 3 px).
fn coverage(runs: &[Vec<Vec<(f64, f64)>>], r: (f64, f64, f64, f64)) -> usize {
    let inside = |p: (f64, f64)| p.0 >= r.0 && p.0 <= r.2 && p.1 >= r.1 && p.1 <= r.3;
    let mut n = 0;
    for series in runs {
        for run in series {
            if run.len() == 1 {
                n += usize::from(inside(run[0]));
            }
            for w in run.windows(2) {
                let (a, b) = (w[0], w[1]);
                let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
                let k = (len / 3.0).ceil().max(1.0) as usize;
                for i in 0..=k {
                    let t = i as f64 / k as f64;
                    n += usize::from(inside((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))));
                }
            }
        }
    }
    n
}

/// The inside corner where a legend of size `(w, h)` covers the fewest curve pixels, with that count.
fn best_corner(l: &Laid, (w, h): (i32, i32)) -> ((i32, i32), usize) {
    let f = &l.frame;
    let pad = 8;
    let corners = [
        (f.right - pad - w, f.top + pad),
        (f.left + pad, f.top + pad),
        (f.right - pad - w, f.bottom - pad - h),
        (f.left + pad, f.bottom - pad - h),
    ];
    let mut best = (corners[0], usize::MAX);
    for c in corners {
        // A margin of a few pixels around the box: a curve grazing the border is hidden too.
        let r = (
            (c.0 - 3) as f64,
            (c.1 - 3) as f64,
            (c.0 + w + 3) as f64,
            (c.1 + h + 3) as f64,
        );
        // A marker or note counts as much as a stretch of curve: it carries a value.
        let inside = |q: &&(f64, f64)| q.0 >= r.0 - 40.0 && q.0 <= r.2 + 10.0 && q.1 >= r.1 - 10.0 && q.1 <= r.3 + 10.0;
        // A label under the legend would be lost: as bad as many marks.
        let legend = PxRect {
            left: c.0,
            top: c.1,
            right: c.0 + w,
            bottom: c.1 + h,
        };
        let labels = l.labels.iter().filter(|n| n.rect.grown(2).overlaps(&legend)).count();
        let n = coverage(&l.runs, r) + 50 * l.marks.iter().filter(inside).count() + 1000 * labels;
        if n < best.1 {
            best = (c, n);
        }
    }
    best
}

/// Draws `fig` on `root`, recording the box of every legend and text it places in `rec`.
fn draw_figure<DB: DrawingBackend>(
    fig: &Figure,
    root: &DrawingArea<DB, Shift>,
    rec: &mut Vec<PlacedBox>,
) -> std::result::Result<(), String> {
    register_font()?;
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let body = if fig.title.is_empty() {
        root.margin(8, 0, 0, 0)
    } else {
        root.titled(&fig.title, ("sans-serif", 20)).map_err(e)?
    };
    let (rows, cols) = fig.grid();
    let areas = body.split_evenly((rows, cols));
    let colors = resolve_colors(fig);
    let n = fig.panels.len();
    let dims: Vec<(i32, i32)> = areas
        .iter()
        .take(n)
        .map(|a| {
            let (w, h) = a.dim_in_pixel();
            (w as i32, h as i32)
        })
        .collect();

    // Pass 1: margins from the measured tick labels, aligned down each column so stacked panels
    // (magnitude over phase) share their frequency axis pixel for pixel.
    let mut lefts = vec![0; n];
    let mut bottoms = vec![0; n];
    let mut rights = vec![16; n];
    for (i, p) in fig.panels.iter().enumerate() {
        let first = lay_out(p, &colors[i], dims[i], 80, 60, 16);
        let (l, b) = margins(&body, p, &first.yticks);
        lefts[i] = l;
        bottoms[i] = b;
        // The last x label is centred on the right edge: half of it must fit in the margin.
        let last = first.xticks.iter().rev().find_map(|t| t.label.as_ref());
        rights[i] = last.map_or(16, |s| (measure(&body, s, TICK_FONT).0 / 2 + 6).max(16));
    }
    let col_min_right: Vec<i32> = (0..cols)
        .map(|c| (0..n).filter(|i| i % cols == c).map(|i| rights[i]).max().unwrap_or(16))
        .collect();
    let col_max = |v: &[i32], c: usize| (0..n).filter(|i| i % cols == c).map(|i| v[i]).max().unwrap_or(0);
    let col_left: Vec<i32> = (0..cols).map(|c| col_max(&lefts, c)).collect();

    // Pass 2: legends inside, in the emptiest corner, unless every corner hides data; then the whole
    // column reserves room on the right and its legends go outside.
    let legends: Vec<Vec<LegendEntry>> = fig
        .panels
        .iter()
        .zip(&colors)
        .map(|(p, c)| legend_entries(p, c))
        .collect();
    let sizes: Vec<(i32, i32)> = legends.iter().map(|l| legend_size(&body, l)).collect();
    let mut outside_col = vec![false; cols];
    for (i, p) in fig.panels.iter().enumerate() {
        if legends[i].is_empty() {
            continue;
        }
        let mut l = lay_out(
            p,
            &colors[i],
            dims[i],
            col_left[i % cols],
            bottoms[i],
            col_min_right[i % cols],
        );
        l.labels = place_labels(p, &l, &body);
        let (_, hidden) = best_corner(&l, sizes[i]);
        let fits = sizes[i].0 < (l.frame.right - l.frame.left) / 2 && sizes[i].1 < (l.frame.bottom - l.frame.top) / 2;
        if hidden > 0 || !fits {
            outside_col[i % cols] = true;
        }
    }
    let col_right: Vec<i32> = (0..cols)
        .map(|c| {
            if outside_col[c] {
                ((0..n).filter(|i| i % cols == c).map(|i| sizes[i].0).max().unwrap_or(0) + 22).max(col_min_right[c])
            } else {
                col_min_right[c]
            }
        })
        .collect();

    for (i, (p, area)) in fig.panels.iter().zip(areas.iter()).enumerate() {
        let c = i % cols;
        let mut l = lay_out(p, &colors[i], dims[i], col_left[c], bottoms[i], col_right[c]);
        l.labels = place_labels(p, &l, area);
        l.legend = legends[i].clone();
        l.legend_size = sizes[i];
        draw_panel(p, &colors[i], &l, area, outside_col[c], (i, &mut *rec))?;
    }
    Ok(())
}

/// Splits a pixel polyline into dashes of `on` px separated by `off` px, continuing across vertices.
fn dashes(run: &[(f64, f64)], on: f64, off: f64) -> Vec<Vec<(i32, i32)>> {
    let mut out: Vec<Vec<(i32, i32)>> = Vec::new();
    let mut cur: Vec<(i32, i32)> = Vec::new();
    let mut drawing = true;
    let mut left = on;
    let ip = |p: (f64, f64)| (p.0.round() as i32, p.1.round() as i32);
    if let Some(&p0) = run.first() {
        cur.push(ip(p0));
    }
    for w in run.windows(2) {
        let (mut a, b) = (w[0], w[1]);
        let mut len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        while len > 0.0 {
            let step = left.min(len);
            let t = step / len;
            let q = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
            if drawing {
                cur.push(ip(q));
            }
            left -= step;
            len -= step;
            a = q;
            if left <= 1e-9 {
                if drawing {
                    if cur.len() > 1 {
                        out.push(std::mem::take(&mut cur));
                    }
                    cur.clear();
                } else {
                    cur = vec![ip(a)];
                }
                drawing = !drawing;
                left = if drawing { on } else { off };
            }
        }
    }
    if drawing && cur.len() > 1 {
        out.push(cur);
    }
    out
}

fn ipt(p: (f64, f64)) -> (i32, i32) {
    (p.0.round() as i32, p.1.round() as i32)
}

fn draw_panel<DB: DrawingBackend>(
    p: &Panel,
    colors: &[usize],
    l: &Laid,
    area: &DrawingArea<DB, Shift>,
    legend_outside: bool,
    (panel, rec): (usize, &mut Vec<PlacedBox>),
) -> std::result::Result<(), String> {
    let f = l.frame;
    let (w, _) = area.dim_in_pixel();
    // Boxes are recorded in pixels of the whole image, where panels do not share coordinates.
    let base = area.get_base_pixel();
    let mut put = |kind: BoxKind, text: &str, rect: PxRect| {
        rec.push(PlacedBox {
            panel,
            kind,
            text: text.to_string(),
            rect: rect.shifted(base),
        });
    };

    draw_data(p, colors, l, area)?;
    draw_markers(p, &f, area, &l.labels)?;
    for n in &l.labels {
        put(BoxKind::Label, &n.text, n.rect);
    }

    draw_axes_text(p, l, area, &mut put)?;

    if !l.legend.is_empty() {
        let (lw, lh) = l.legend_size;
        let origin = if legend_outside {
            ((f.right + 12).min(w as i32 - lw - 2), f.top)
        } else {
            best_corner(l, l.legend_size).0
        };
        draw_legend(area, &l.legend, origin, (lw, lh))?;
        let text: Vec<&str> = l.legend.iter().map(|en| en.label.as_str()).collect();
        let rect = PxRect {
            left: origin.0,
            top: origin.1,
            right: origin.0 + lw,
            bottom: origin.1 + lh,
        };
        put(BoxKind::Legend, &text.join(" | "), rect);
    }
    Ok(())
}

/// Draws a panel's grid, bands and curves (the data, under everything else).
fn draw_data<DB: DrawingBackend>(
    p: &Panel,
    colors: &[usize],
    l: &Laid,
    area: &DrawingArea<DB, Shift>,
) -> std::result::Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let f = l.frame;
    // Grid: minor lines fainter than labelled ones.
    for t in &l.xticks {
        let (u, _) = f.px(t.value, if f.y.log { f.y.lo } else { 0.0 });
        let u = u.round() as i32;
        if u < f.left || u > f.right {
            continue;
        }
        let c = if t.label.is_some() {
            RGBColor(215, 215, 215)
        } else {
            RGBColor(238, 238, 238)
        };
        area.draw(&PathElement::new(vec![(u, f.top), (u, f.bottom)], c.stroke_width(1)))
            .map_err(e)?;
    }
    for t in &l.yticks {
        let (_, v) = f.px(if f.x.log { f.x.lo } else { 0.0 }, t.value);
        let v = v.round() as i32;
        if v < f.top || v > f.bottom {
            continue;
        }
        let c = if t.label.is_some() {
            RGBColor(215, 215, 215)
        } else {
            RGBColor(238, 238, 238)
        };
        area.draw(&PathElement::new(vec![(f.left, v), (f.right, v)], c.stroke_width(1)))
            .map_err(e)?;
    }

    // Bands, clipped as polygons.
    let tb = f.tbox();
    for b in &p.bands {
        let mut poly: Vec<(f64, f64)> = Vec::with_capacity(2 * b.x.len());
        for i in 0..b.x.len() {
            if usable(b.x[i], p.x_log) && usable(b.upper[i], p.y_log) {
                poly.push((f.x.t(b.x[i]), f.y.t(b.upper[i])));
            }
        }
        for i in (0..b.x.len()).rev() {
            if usable(b.x[i], p.x_log) && usable(b.lower[i], p.y_log) {
                poly.push((f.x.t(b.x[i]), f.y.t(b.lower[i])));
            }
        }
        let poly: Vec<(i32, i32)> = clip_polygon(&poly, &tb)
            .into_iter()
            .map(|(x, y)| ipt(f.px_t(x, y)))
            .collect();
        if poly.len() >= 3 {
            area.draw(&Polygon::new(poly, color(b.color).mix(0.2).filled()))
                .map_err(e)?;
        }
    }

    // Curves: reference geometry first, so data is drawn over it.
    let mut order: Vec<usize> = (0..p.series.len()).collect();
    order.sort_by_key(|&k| p.series[k].style != SeriesStyle::Reference);
    for k in order {
        let s = &p.series[k];
        let c = rgb(colors[k]);
        let style = ShapeStyle::from(&c).stroke_width(2);
        for run in &l.runs[k] {
            match s.style {
                SeriesStyle::Line => {
                    area.draw(&PathElement::new(
                        run.iter().copied().map(ipt).collect::<Vec<_>>(),
                        style,
                    ))
                    .map_err(e)?;
                }
                SeriesStyle::Dashed => {
                    for d in dashes(run, 9.0, 5.0) {
                        area.draw(&PathElement::new(d, style)).map_err(e)?;
                    }
                }
                SeriesStyle::Reference => {
                    for d in dashes(run, 5.0, 4.0) {
                        area.draw(&PathElement::new(d, neutral().stroke_width(1))).map_err(e)?;
                    }
                }
                SeriesStyle::Points => {
                    for q in run {
                        area.draw(&Circle::new(ipt(*q), 3, c.filled())).map_err(e)?;
                    }
                }
                SeriesStyle::Stems => {
                    for q in run {
                        let (u, v) = ipt(*q);
                        area.draw(&PathElement::new(vec![(u, f.bottom), (u, v)], style))
                            .map_err(e)?;
                    }
                }
                SeriesStyle::Crosses => {
                    for q in run {
                        draw_cross(area, ipt(*q), 5, c)?;
                    }
                }
                SeriesStyle::Circles => {
                    for q in run {
                        area.draw(&Circle::new(ipt(*q), 5, c.stroke_width(2))).map_err(e)?;
                    }
                }
            }
        }
    }
    Ok(())
}

/// Draws a panel's frame, ticks, tick labels, axis descriptions and title, recording each text's
/// box with `put`.
fn draw_axes_text<DB: DrawingBackend>(
    p: &Panel,
    l: &Laid,
    area: &DrawingArea<DB, Shift>,
    put: &mut dyn FnMut(BoxKind, &str, PxRect),
) -> std::result::Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let f = l.frame;
    // Frame, ticks and their labels.
    area.draw(&Rectangle::new(
        [(f.left, f.top), (f.right, f.bottom)],
        BLACK.stroke_width(1),
    ))
    .map_err(e)?;
    let tick_style = text_style(TICK_FONT);
    for t in &l.xticks {
        let (u, _) = f.px(t.value, if f.y.log { f.y.lo } else { 0.0 });
        let u = u.round() as i32;
        if u < f.left - 1 || u > f.right + 1 {
            continue;
        }
        if let Some(lab) = &t.label {
            area.draw(&PathElement::new(
                vec![(u, f.bottom), (u, f.bottom - 5)],
                BLACK.stroke_width(1),
            ))
            .map_err(e)?;
            area.draw(&Text::new(
                lab.clone(),
                (u, f.bottom + 5),
                tick_style.pos(Pos::new(HPos::Center, VPos::Top)),
            ))
            .map_err(e)?;
            let size = measure(area, lab, TICK_FONT);
            put(
                BoxKind::Tick,
                lab,
                text_rect(size, (u, f.bottom + 5), HPos::Center, VPos::Top),
            );
        }
    }
    for t in &l.yticks {
        let (_, v) = f.px(if f.x.log { f.x.lo } else { 0.0 }, t.value);
        let v = v.round() as i32;
        if v < f.top - 1 || v > f.bottom + 1 {
            continue;
        }
        if let Some(lab) = &t.label {
            area.draw(&PathElement::new(
                vec![(f.left, v), (f.left + 5, v)],
                BLACK.stroke_width(1),
            ))
            .map_err(e)?;
            area.draw(&Text::new(
                lab.clone(),
                (f.left - 6, v),
                tick_style.pos(Pos::new(HPos::Right, VPos::Center)),
            ))
            .map_err(e)?;
            let size = measure(area, lab, TICK_FONT);
            put(
                BoxKind::Tick,
                lab,
                text_rect(size, (f.left - 6, v), HPos::Right, VPos::Center),
            );
        }
    }
    if !p.x_label.is_empty() {
        let at = ((f.left + f.right) / 2, f.bottom + 8 + TICK_FONT as i32 + 6);
        area.draw(&Text::new(
            p.x_label.clone(),
            at,
            text_style(DESC_FONT).pos(Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(e)?;
        let size = measure(area, &p.x_label, DESC_FONT);
        put(
            BoxKind::Caption,
            &p.x_label,
            text_rect(size, at, HPos::Center, VPos::Top),
        );
    }
    if !p.y_label.is_empty() {
        let at = (6, (f.top + f.bottom) / 2);
        area.draw(&Text::new(
            p.y_label.clone(),
            at,
            text_style(DESC_FONT)
                .transform(FontTransform::Rotate270)
                .pos(Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(e)?;
        // Turned a quarter: the text's width runs up the side.
        let (tw, th) = measure(area, &p.y_label, DESC_FONT);
        put(
            BoxKind::Caption,
            &p.y_label,
            text_rect((th, tw), at, HPos::Left, VPos::Center),
        );
    }
    if !p.title.is_empty() {
        let at = ((f.left + f.right) / 2, 4);
        area.draw(&Text::new(
            p.title.clone(),
            at,
            text_style(TITLE_FONT).pos(Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(e)?;
        let size = measure(area, &p.title, TITLE_FONT);
        put(BoxKind::Caption, &p.title, text_rect(size, at, HPos::Center, VPos::Top));
    }
    Ok(())
}

fn draw_cross<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    (u, v): (i32, i32),
    r: i32,
    c: RGBColor,
) -> std::result::Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let s = c.stroke_width(2);
    area.draw(&PathElement::new(vec![(u - r, v - r), (u + r, v + r)], s))
        .map_err(e)?;
    area.draw(&PathElement::new(vec![(u - r, v + r), (u + r, v - r)], s))
        .map_err(e)?;
    Ok(())
}

fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
    (x, y): (i32, i32),
    (w, h): (i32, i32),
) -> std::result::Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    area.draw(&Rectangle::new([(x, y), (x + w, y + h)], WHITE.mix(0.9).filled()))
        .map_err(e)?;
    area.draw(&Rectangle::new(
        [(x, y), (x + w, y + h)],
        RGBColor(160, 160, 160).stroke_width(1),
    ))
    .map_err(e)?;
    for (i, en) in entries.iter().enumerate() {
        let cy = y + 4 + LEGEND_ROW * i as i32 + LEGEND_ROW / 2;
        let (x0, x1) = (x + 6, x + 6 + LEGEND_SWATCH - 4);
        match &en.kind {
            LegendKind::Line { dashed: false } => {
                area.draw(&PathElement::new(vec![(x0, cy), (x1, cy)], en.color.stroke_width(2)))
                    .map_err(e)?;
            }
            LegendKind::Line { dashed: true } => {
                for d in dashes(&[(x0 as f64, cy as f64), (x1 as f64, cy as f64)], 7.0, 4.0) {
                    area.draw(&PathElement::new(d, en.color.stroke_width(2))).map_err(e)?;
                }
            }
            LegendKind::Band => {
                area.draw(&Rectangle::new(
                    [(x0, cy - 5), (x1, cy + 5)],
                    en.color.mix(0.3).filled(),
                ))
                .map_err(e)?;
            }
            LegendKind::Mark(style) => {
                let m = ((x0 + x1) / 2, cy);
                match style {
                    SeriesStyle::Crosses => draw_cross(area, m, 5, en.color)?,
                    SeriesStyle::Circles => area.draw(&Circle::new(m, 5, en.color.stroke_width(2))).map_err(e)?,
                    _ => area.draw(&Circle::new(m, 3, en.color.filled())).map_err(e)?,
                }
            }
        }
        area.draw(&Text::new(
            en.label.clone(),
            (x + 6 + LEGEND_SWATCH + 2, cy),
            text_style(LEGEND_FONT).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(e)?;
    }
    Ok(())
}

/// A value label placed inside a panel: its text, anchor (px, area-relative) and alignment, the box
/// of its white backdrop, and a leader line from the point it names when it sits away from it.
#[derive(Clone)]
struct PlacedLabel {
    text: String,
    anchor: (i32, i32),
    h: HPos,
    v: VPos,
    rect: PxRect,
    leader: Option<((i32, i32), (i32, i32))>,
}

/// The box of text of size `(tw, th)` px anchored at `(x, y)` with alignment `h`, `v`.
fn text_rect((tw, th): (i32, i32), (x, y): (i32, i32), h: HPos, v: VPos) -> PxRect {
    let x0 = match h {
        HPos::Left => x,
        HPos::Center => x - tw / 2,
        HPos::Right => x - tw,
    };
    let y0 = match v {
        VPos::Top => y,
        VPos::Center => y - th / 2,
        VPos::Bottom => y - th,
    };
    PxRect {
        left: x0,
        top: y0,
        right: x0 + tw,
        bottom: y0 + th,
    }
}

impl PlacedLabel {
    /// A note of measured size `size` at `anchor`; its box includes the backdrop's padding.
    fn new(text: &str, size: (i32, i32), anchor: (i32, i32), h: HPos, v: VPos) -> Self {
        let r = text_rect(size, anchor, h, v);
        PlacedLabel {
            text: text.to_string(),
            anchor,
            h,
            v,
            rect: PxRect {
                left: r.left - 2,
                top: r.top - 1,
                right: r.right + 2,
                bottom: r.bottom + 1,
            },
            leader: None,
        }
    }

    fn clashes(&self, placed: &[PlacedLabel]) -> usize {
        placed.iter().filter(|o| o.rect.grown(1).overlaps(&self.rect)).count()
    }
}

/// Text with a white backdrop so it stays legible over grid lines and curves.
fn note<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, n: &PlacedLabel) -> std::result::Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let r = n.rect;
    area.draw(&Rectangle::new(
        [(r.left, r.top), (r.right, r.bottom)],
        WHITE.mix(0.85).filled(),
    ))
    .map_err(e)?;
    area.draw(&Text::new(
        n.text.clone(),
        n.anchor,
        text_style(NOTE_FONT)
            .color(&RGBColor(40, 40, 40))
            .pos(Pos::new(n.h, n.v)),
    ))
    .map_err(e)?;
    Ok(())
}

/// Places the labels of a panel's markers, each where it hides no earlier label if it can:
/// vertical-line labels stacked in rows along the top, horizontal-line labels above their line at
/// the left or right end, point notes in the freest place around their point.
fn place_labels<DB: DrawingBackend>(p: &Panel, l: &Laid, area: &DrawingArea<DB, Shift>) -> Vec<PlacedLabel> {
    let f = &l.frame;
    let mut out: Vec<PlacedLabel> = Vec::new();
    for m in &p.markers {
        let placed = match m {
            Marker::Vertical { x, label } if usable(*x, p.x_log) && !label.is_empty() => {
                let (u, _) = f.px(*x, if f.y.log { f.y.lo } else { 0.0 });
                if !f.inside_px((u, f.top as f64)) {
                    continue;
                }
                let u = u.round() as i32;
                let (tw, th) = measure(area, label, NOTE_FONT);
                // Right of the line, unless that would run past the frame.
                let (x0, hpos) = if u + 4 + tw <= f.right {
                    (u + 4, HPos::Left)
                } else {
                    (u - 4, HPos::Right)
                };
                let at_row =
                    |r: i32| PlacedLabel::new(label, (tw, th), (x0, f.top + 3 + r * (th + 3)), hpos, VPos::Top);
                // The first row where it hides no earlier label.
                let row = (0..20).find(|r| at_row(*r).clashes(&out) == 0).unwrap_or(0);
                Some(at_row(row))
            }
            Marker::Horizontal { y, label } if usable(*y, p.y_log) && !label.is_empty() => {
                let (_, v) = f.px(if f.x.log { f.x.lo } else { 0.0 }, *y);
                if !f.inside_px((f.left as f64, v)) {
                    continue;
                }
                let v = v.round() as i32;
                let size = measure(area, label, NOTE_FONT);
                let places = [
                    PlacedLabel::new(label, size, (f.left + 4, v - 2), HPos::Left, VPos::Bottom),
                    PlacedLabel::new(label, size, (f.right - 4, v - 2), HPos::Right, VPos::Bottom),
                    PlacedLabel::new(label, size, (f.left + 4, v + 2), HPos::Left, VPos::Top),
                    PlacedLabel::new(label, size, (f.right - 4, v + 2), HPos::Right, VPos::Top),
                ];
                let free = places.iter().find(|c| c.clashes(&out) == 0);
                Some(free.unwrap_or(&places[0]).clone())
            }
            Marker::Point { x, y, label } if usable(*x, p.x_log) && usable(*y, p.y_log) && !label.is_empty() => {
                let q = f.px(*x, *y);
                if !f.inside_px(q) {
                    continue;
                }
                let q = ipt(q);
                let size = measure(area, label, NOTE_FONT);
                Some(PlacedLabel::new(
                    label,
                    size,
                    (q.0 - 6, q.1 - 6),
                    HPos::Right,
                    VPos::Bottom,
                ))
            }
            Marker::Note { x, y, label } if usable(*x, p.x_log) && usable(*y, p.y_log) && !label.is_empty() => {
                let q = f.px(*x, *y);
                if !f.inside_px(q) {
                    continue;
                }
                Some(place_note(label, ipt(q), measure(area, label, NOTE_FONT), l, &out))
            }
            _ => None,
        };
        out.extend(placed);
    }
    out
}

/// Of the places around the point `q` (four quadrants, near then farther out), the one inside the
/// frame that hides the least of the curves and no earlier label: a note must not cover the
/// response it describes, nor another trace's note.
fn place_note(label: &str, q: (i32, i32), (tw, th): (i32, i32), l: &Laid, placed: &[PlacedLabel]) -> PlacedLabel {
    let f = &l.frame;
    let mut best: Option<(PlacedLabel, usize)> = None;
    for gap in [6, 22, 40] {
        for (dx, dy) in [(1, -1), (1, 1), (-1, -1), (-1, 1)] {
            let h = if dx > 0 { HPos::Left } else { HPos::Right };
            let v = if dy < 0 { VPos::Bottom } else { VPos::Top };
            let anchor = (q.0 + dx * gap, q.1 + dy * gap);
            let mut c = PlacedLabel::new(label, (tw, th), anchor, h, v);
            let r = c.rect;
            if r.left + 2 < f.left || r.right - 2 > f.right || r.top + 1 < f.top || r.bottom - 1 > f.bottom {
                continue;
            }
            let hidden = coverage(&l.runs, (r.left as f64, r.top as f64, r.right as f64, r.bottom as f64));
            // Farther places cost a little, so a free near place wins.
            let score = hidden + 10_000 * c.clashes(placed) + gap as usize;
            if best.as_ref().is_none_or(|b| score < b.1) {
                // A leader from the point to the note's near corner says which point it names.
                c.leader = (gap > 6).then_some((q, anchor));
                best = Some((c, score));
            }
        }
    }
    best.map_or_else(
        || PlacedLabel::new(label, (tw, th), (q.0 + 6, q.1 - 6), HPos::Left, VPos::Bottom),
        |b| b.0,
    )
}

/// Draws the marker geometry (dashed lines, the critical point, arrows), then the placed labels
/// with their leaders over it.
fn draw_markers<DB: DrawingBackend>(
    p: &Panel,
    f: &Frame,
    area: &DrawingArea<DB, Shift>,
    labels: &[PlacedLabel],
) -> std::result::Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let grey = neutral();
    for m in &p.markers {
        match m {
            Marker::Vertical { x, .. } if usable(*x, p.x_log) => {
                let (u, _) = f.px(*x, if f.y.log { f.y.lo } else { 0.0 });
                if !f.inside_px((u, f.top as f64)) {
                    continue;
                }
                let u = u.round();
                for d in dashes(&[(u, f.top as f64), (u, f.bottom as f64)], 4.0, 4.0) {
                    area.draw(&PathElement::new(d, grey.stroke_width(1))).map_err(e)?;
                }
            }
            Marker::Horizontal { y, .. } if usable(*y, p.y_log) => {
                let (_, v) = f.px(if f.x.log { f.x.lo } else { 0.0 }, *y);
                if !f.inside_px((f.left as f64, v)) {
                    continue;
                }
                let v = v.round();
                for d in dashes(&[(f.left as f64, v), (f.right as f64, v)], 4.0, 4.0) {
                    area.draw(&PathElement::new(d, grey.stroke_width(1))).map_err(e)?;
                }
            }
            Marker::Point { x, y, .. } if usable(*x, p.x_log) && usable(*y, p.y_log) => {
                let q = f.px(*x, *y);
                if !f.inside_px(q) {
                    continue;
                }
                let q = ipt(q);
                // The critical point in red as MATLAB draws it: a plus sign.
                let red = RGBColor(200, 0, 0);
                for seg in [[(q.0 - 7, q.1), (q.0 + 7, q.1)], [(q.0, q.1 - 7), (q.0, q.1 + 7)]] {
                    area.draw(&PathElement::new(seg.to_vec(), red.stroke_width(2)))
                        .map_err(e)?;
                }
            }
            Marker::Arrow { x, y, dx, dy, color: c } if usable(*x, p.x_log) && usable(*y, p.y_log) => {
                draw_arrow(p, f, area, (*x, *y), (*dx, *dy), *c)?;
            }
            _ => {}
        }
    }
    for n in labels {
        if let Some((a, b)) = n.leader {
            area.draw(&PathElement::new(vec![a, b], grey.stroke_width(1)))
                .map_err(e)?;
        }
        note(area, n)?;
    }
    Ok(())
}

/// A filled arrowhead at `(x, y)` pointing along `(dx, dy)` (axis coordinates; linear axes only).
fn draw_arrow<DB: DrawingBackend>(
    p: &Panel,
    f: &Frame,
    area: &DrawingArea<DB, Shift>,
    (x, y): (f64, f64),
    (dx, dy): (f64, f64),
    c: usize,
) -> std::result::Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let q = f.px(x, y);
    if !f.inside_px(q) {
        return Ok(());
    }
    // Direction in pixels: a short step along (dx, dy) in axis coordinates.
    let h = 1e-6 * ((f.x.hi - f.x.lo).abs() + (f.y.hi - f.y.lo).abs()).max(1e-300);
    let norm = (dx * dx + dy * dy).sqrt();
    if norm.is_nan() || norm <= 0.0 || p.x_log || p.y_log {
        return Ok(());
    }
    let r = f.px(x + h * dx / norm, y + h * dy / norm);
    let (ux, uy) = (r.0 - q.0, r.1 - q.1);
    let n = (ux * ux + uy * uy).sqrt();
    if n.is_nan() || n <= 0.0 {
        return Ok(());
    }
    let (ux, uy) = (ux / n, uy / n);
    let (len, half) = (13.0, 5.5);
    let tip = (q.0 + 0.5 * len * ux, q.1 + 0.5 * len * uy);
    let base = (q.0 - 0.5 * len * ux, q.1 - 0.5 * len * uy);
    let tri = vec![
        ipt(tip),
        ipt((base.0 - half * uy, base.1 + half * ux)),
        ipt((base.0 + half * uy, base.1 - half * ux)),
    ];
    area.draw(&Polygon::new(tri, rgb(c).filled())).map_err(e)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dashes_alternate_along_the_path() {
        let d = dashes(&[(0.0, 0.0), (30.0, 0.0)], 8.0, 5.0);
        // 0–8, 13–21, 26–30.
        assert_eq!(d.len(), 3);
        assert_eq!(d[0], vec![(0, 0), (8, 0)]);
        assert_eq!(d[1], vec![(13, 0), (21, 0)]);
    }

    fn panel_with(series: Vec<crate::figure::Series>) -> Panel {
        Panel {
            series,
            x_range: Some((0.0, 1.0)),
            y_range: Some((0.0, 1.0)),
            ..Panel::default()
        }
    }

    #[test]
    fn the_legend_takes_the_empty_corner_or_none() {
        use crate::figure::Series;
        let x: Vec<f64> = (0..=100).map(|i| i as f64 / 100.0).collect();
        // A curve in the lower left only: the upper-right corner is free.
        let low = panel_with(vec![Series::line("a", vec![0.0, 0.3], vec![0.0, 0.3])]);
        let l = lay_out(&low, &[0], (600, 400), 60, 50, 16);
        let ((cx, cy), hidden) = best_corner(&l, (120, 40));
        assert_eq!(hidden, 0);
        assert!(cx > 300 && cy < 100, "{cx} {cy}");
        // Lines along the top and the bottom: every corner would hide data.
        let full = panel_with(vec![
            Series::line("top", x.clone(), vec![0.97; x.len()]),
            Series::line("bottom", x.clone(), vec![0.03; x.len()]),
        ]);
        let l = lay_out(&full, &[0, 1], (600, 400), 60, 50, 16);
        assert!(best_corner(&l, (120, 40)).1 > 0);
    }

    #[test]
    fn curves_leaving_the_view_are_cut_at_its_edge_in_pixels() {
        use crate::figure::Series;
        // From the centre to far right: the visible run ends exactly on the right edge.
        let p = panel_with(vec![Series::line("", vec![0.5, 10.0], vec![0.5, 0.5])]);
        let l = lay_out(&p, &[0], (600, 400), 60, 50, 16);
        let run = &l.runs[0][0];
        assert_eq!(run.len(), 2);
        assert!((run[1].0 - l.frame.right as f64).abs() < 1e-9);
        assert!((run[1].1 - run[0].1).abs() < 1e-9);
    }

    #[test]
    fn same_label_same_colour_across_panels() {
        use crate::figure::Series;
        let a = panel_with(vec![
            Series::line("K1", vec![0.0, 1.0], vec![0.0, 1.0]),
            Series::line("K2", vec![0.0, 1.0], vec![1.0, 0.0]),
        ]);
        let b = panel_with(vec![Series::line("K2", vec![0.0, 1.0], vec![0.0, 1.0])]);
        let c = resolve_colors(&Figure::new("", vec![a, b]));
        assert_eq!(c[0], vec![0, 1]);
        assert_eq!(c[1], vec![1]);
    }

    #[test]
    fn equal_aspect_widens_the_short_side() {
        let mut x = Axis {
            lo: -1.0,
            hi: 1.0,
            log: false,
        };
        let mut y = x;
        equalize(&mut x, &mut y, 400.0, 200.0);
        assert_eq!((x.lo, x.hi), (-2.0, 2.0));
        assert_eq!((y.lo, y.hi), (-1.0, 1.0));
    }
}
