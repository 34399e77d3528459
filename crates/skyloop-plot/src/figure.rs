//! The data model every plot is built from: a figure is a vertical stack of panels, each holding
//! line/point series, shaded bands and marker lines.

use crate::error::{PlotError, Result};

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeriesStyle {
    /// A solid line through the points.
    Line,
    /// A dashed line through the points.
    Dashed,
    /// Filled circles at the points.
    Points,
    /// Vertical stems from the bottom of the axis to each point (bar-like).
    Stems,
    /// A cross (×) at each point: poles in a pole–zero map or root locus.
    Crosses,
    /// A hollow circle (○) at each point: zeros in a pole–zero map or root locus.
    Circles,
    /// A thin grey line for reference geometry (unit circle, M-circles, stability boundary); no
    /// palette colour is used up.
    Reference,
}

/// The colour-blind-safe palette of Okabe & Ito (2008), as RGB, in their published order with black
/// moved last (black is the colour of frames and text, so it is the last resort for a curve).
/// `Series::colored(i)` picks entry `i % 8`.
pub const PALETTE: [(u8, u8, u8); 8] = [
    (0, 114, 178),   // blue
    (213, 94, 0),    // vermillion
    (0, 158, 115),   // bluish green
    (230, 159, 0),   // orange
    (204, 121, 167), // reddish purple
    (86, 180, 233),  // sky blue
    (240, 228, 66),  // yellow
    (0, 0, 0),       // black
];

/// Colour of reference geometry and marker lines (grey), as RGB.
pub const NEUTRAL: (u8, u8, u8) = (110, 110, 110);

/// One curve: x and y values of equal length and a legend label (empty: no legend entry).
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text; empty for none.
    pub label: String,
    /// Abscissae, in the panel's x unit.
    pub x: Vec<f64>,
    /// Ordinates, in the panel's y unit.
    pub y: Vec<f64>,
    /// How to draw it.
    pub style: SeriesStyle,
    /// Palette index into [`PALETTE`]; `None` picks one: series with the same label share a colour
    /// across the panels of a figure, unlabelled ones take their index in the panel.
    pub color: Option<usize>,
}

impl Series {
    /// The unit circle, unlabelled, in the thin grey reference style (Nyquist's |L| = 1, the
    /// z-plane stability boundary); 361 points.
    pub fn unit_circle() -> Series {
        let n = 361;
        let (cx, cy): (Vec<f64>, Vec<f64>) = (0..n)
            .map(|i| {
                let t = 2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64;
                (t.cos(), t.sin())
            })
            .unzip();
        Series::line("", cx, cy).styled(SeriesStyle::Reference)
    }

    /// A solid line with a label.
    pub fn line(label: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Series {
            label: label.into(),
            x,
            y,
            style: SeriesStyle::Line,
            color: None,
        }
    }

    /// The same series with another style.
    pub fn styled(mut self, style: SeriesStyle) -> Self {
        self.style = style;
        self
    }

    /// The same series with a fixed palette colour (index into [`PALETTE`], wrapping), so one system
    /// keeps its colour in every panel (magnitude and phase, several channels).
    pub fn colored(mut self, index: usize) -> Self {
        self.color = Some(index);
        self
    }

    /// A dashed line: the convention for a reference, target or bound.
    pub fn dashed(label: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Series::line(label, x, y).styled(SeriesStyle::Dashed)
    }

    /// Markers at points, e.g. poles (`SeriesStyle::Crosses`) or zeros (`SeriesStyle::Circles`).
    pub fn points(label: impl Into<String>, x: Vec<f64>, y: Vec<f64>, style: SeriesStyle) -> Self {
        Series::line(label, x, y).styled(style)
    }
}

/// A shaded region between a lower and an upper curve over the same x values (confidence bands).
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    /// Legend text; empty for none.
    pub label: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Lower edge.
    pub lower: Vec<f64>,
    /// Upper edge.
    pub upper: Vec<f64>,
    /// Palette index of the fill.
    pub color: usize,
}

/// A labelled vertical (`at_x`) or horizontal (`at_y`) reference line, e.g. a crossover frequency.
#[derive(Debug, Clone, PartialEq)]
pub enum Marker {
    /// A vertical line at this x.
    Vertical {
        /// Position on the x axis.
        x: f64,
        /// Text drawn next to the line.
        label: String,
    },
    /// A horizontal line at this y.
    Horizontal {
        /// Position on the y axis.
        y: f64,
        /// Text drawn next to the line.
        label: String,
    },
    /// A single labelled point, e.g. the critical point −1 of a Nyquist plot.
    Point {
        /// Position on the x axis.
        x: f64,
        /// Position on the y axis.
        y: f64,
        /// Text drawn next to the point.
        label: String,
    },
    /// An arrowhead at a point of a curve showing its direction of travel (Nyquist: increasing ω).
    Arrow {
        /// Position on the x axis.
        x: f64,
        /// Position on the y axis.
        y: f64,
        /// Direction of travel along x, in data units (only the direction matters).
        dx: f64,
        /// Direction of travel along y, in data units.
        dy: f64,
        /// Palette index of the curve it belongs to.
        color: usize,
    },
    /// A text note at a data position (e.g. "overshoot 12.3 %" beside a peak).
    Note {
        /// Position on the x axis.
        x: f64,
        /// Position on the y axis.
        y: f64,
        /// The text.
        label: String,
    },
}

/// One set of axes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Panel {
    /// Caption above the axes (may be empty).
    pub title: String,
    /// x-axis description with its unit.
    pub x_label: String,
    /// y-axis description with its unit.
    pub y_label: String,
    /// Logarithmic x axis (frequencies).
    pub x_log: bool,
    /// Logarithmic y axis (singular values).
    pub y_log: bool,
    /// Curves.
    pub series: Vec<Series>,
    /// Shaded bands, drawn below the curves.
    pub bands: Vec<Band>,
    /// Reference lines and points.
    pub markers: Vec<Marker>,
    /// Fixed y range; `None` fits the data.
    pub y_range: Option<(f64, f64)>,
    /// Fixed x range; `None` fits the data.
    pub x_range: Option<(f64, f64)>,
    /// One data unit spans as many pixels along x as along y (complex-plane plots: a circle is
    /// round); the range of the longer side is widened to match.
    pub equal_aspect: bool,
    /// The x axis is in degrees: ticks at multiples of 15°, 45°, 90°, ... (Nichols).
    pub x_degrees: bool,
    /// The y axis is in degrees: ticks at multiples of 15°, 45°, 90°, ... (phase).
    pub y_degrees: bool,
}

impl Panel {
    /// An empty panel over a logarithmic frequency axis in Hz with the given y-axis description.
    pub fn frequency(y_label: &str) -> Self {
        Panel {
            x_label: "frequency [Hz]".into(),
            y_label: y_label.into(),
            x_log: true,
            ..Panel::default()
        }
    }
}

/// A titled stack of panels sharing the figure width.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Figure {
    /// Caption of the whole figure.
    pub title: String,
    /// Panels from top to bottom.
    pub panels: Vec<Panel>,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels of each panel.
    pub panel_height: u32,
    /// Number of panel columns: panels fill a grid row by row (MIMO Bode: one column per input);
    /// 0 or 1 stacks them vertically.
    pub columns: usize,
}

impl Figure {
    /// A figure with the default size (960 px wide, 360 px per panel).
    pub fn new(title: impl Into<String>, panels: Vec<Panel>) -> Self {
        Figure {
            title: title.into(),
            panels,
            width: 960,
            panel_height: 360,
            columns: 1,
        }
    }

    /// Renumbers the palette colours of every series, band and arrow that has one: colour `k` becomes
    /// `map[k]` (indices beyond `map` stay). Builders colour system `k` of their input with `k`; this
    /// keeps a system's colour the same across figures (e.g. the final controller always orange,
    /// `map = [3]`), or gives a single curve a chosen colour.
    pub fn remap_colors(mut self, map: &[usize]) -> Self {
        let re = |c: usize| map.get(c).copied().unwrap_or(c);
        for p in &mut self.panels {
            for s in &mut p.series {
                s.color = s.color.map(re);
            }
            for b in &mut p.bands {
                b.color = re(b.color);
            }
            for m in &mut p.markers {
                if let Marker::Arrow { color, .. } = m {
                    *color = re(*color);
                }
            }
        }
        self
    }

    /// Number of panel rows and columns of the grid.
    pub fn grid(&self) -> (usize, usize) {
        let cols = self.columns.max(1).min(self.panels.len().max(1));
        (self.panels.len().div_ceil(cols), cols)
    }

    /// Size of the rendered image in pixels (width, height).
    pub fn size(&self) -> (u32, u32) {
        let (rows, _) = self.grid();
        let title = if self.title.is_empty() { 8 } else { 40 };
        (self.width, self.panel_height * rows as u32 + title)
    }

    /// Rejects figures that cannot be drawn: no panels, series of unequal length, no finite data.
    pub(crate) fn check(&self) -> Result<()> {
        if self.panels.is_empty() {
            return Err(PlotError::Data("a figure needs at least one panel".into()));
        }
        for p in &self.panels {
            for s in &p.series {
                if s.x.len() != s.y.len() {
                    return Err(PlotError::Data(format!(
                        "series '{}' has {} x values but {} y values",
                        s.label,
                        s.x.len(),
                        s.y.len()
                    )));
                }
            }
            for b in &p.bands {
                if b.x.len() != b.lower.len() || b.x.len() != b.upper.len() {
                    return Err(PlotError::Data(format!(
                        "band '{}' has edges of unequal length",
                        b.label
                    )));
                }
            }
            let finite = p.series.iter().any(|s| {
                s.x.iter()
                    .zip(&s.y)
                    .any(|(x, y)| usable(*x, p.x_log) && usable(*y, p.y_log))
            });
            // A panel whose axes the caller fixed may be empty on purpose (a zero channel of a MIMO
            // grid); any other empty panel is a caller's mistake.
            if !finite && (p.x_range.is_none() || p.y_range.is_none()) {
                return Err(PlotError::Data(format!(
                    "panel '{}' has no finite data to draw",
                    p.title
                )));
            }
        }
        Ok(())
    }
}

/// Whether a value can be placed on an axis (finite, and positive on a log axis).
pub(crate) fn usable(v: f64, log: bool) -> bool {
    v.is_finite() && (!log || v > 0.0)
}
