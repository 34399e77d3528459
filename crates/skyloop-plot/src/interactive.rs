//! The data of a figure as JSON, and the inline script that draws it interactively (zoom, pan,
//! hover) in an HTML report: no CDN, no network, the static SVG stays beside it.

use std::fmt::Write as _;

use crate::error::Result;
use crate::figure::{Figure, Marker, SeriesStyle, NEUTRAL, PALETTE};
use crate::render::{panel_axes, resolve_colors};

/// The script that turns every `<div class="skl-int" data-src="ID">` of a page into an interactive
/// figure drawn from the JSON in `<script type="application/json" id="ID">` (see
/// [`Figure::to_json`]): wheel zooms about the cursor (shift: x only, alt: y only), drag pans,
/// double-click resets, hovering shows the nearest data point's values.
pub const INTERACTIVE_JS: &str = include_str!("interactive.js");

fn hex((r, g, b): (u8, u8, u8)) -> String {
    format!("#{r:02x}{g:02x}{b:02x}")
}

/// A JSON string literal, safe inside an HTML `<script>` element too (`</` is written `<\/`).
fn js_str(s: &str) -> String {
    let mut o = String::with_capacity(s.len() + 2);
    o.push('"');
    for c in s.chars() {
        match c {
            '"' => o.push_str("\\\""),
            '\\' => o.push_str("\\\\"),
            '\n' => o.push_str("\\n"),
            '\r' => o.push_str("\\r"),
            '\t' => o.push_str("\\t"),
            '<' => o.push_str("\\u003c"),
            '>' => o.push_str("\\u003e"),
            '&' => o.push_str("\\u0026"),
            c if (c as u32) < 0x20 => {
                let _ = write!(o, "\\u{:04x}", c as u32);
            }
            c => o.push(c),
        }
    }
    o.push('"');
    o
}

/// A JSON number; NaN and infinities (which JSON has not) are `null`.
fn num(v: f64) -> String {
    if v.is_finite() {
        // Shortest round-trip form; Rust never writes an exponent JSON would reject.
        format!("{v}")
    } else {
        "null".into()
    }
}

fn nums(v: &[f64]) -> String {
    let mut o = String::with_capacity(v.len() * 8 + 2);
    o.push('[');
    for (i, x) in v.iter().enumerate() {
        if i > 0 {
            o.push(',');
        }
        o.push_str(&num(*x));
    }
    o.push(']');
    o
}

fn style_name(s: SeriesStyle) -> &'static str {
    match s {
        SeriesStyle::Line => "line",
        SeriesStyle::Dashed => "dashed",
        SeriesStyle::Points => "points",
        SeriesStyle::Stems => "stems",
        SeriesStyle::Crosses => "crosses",
        SeriesStyle::Circles => "circles",
        SeriesStyle::Reference => "reference",
    }
}

fn color_hex(c: usize) -> String {
    if c == usize::MAX {
        hex(NEUTRAL)
    } else {
        hex(PALETTE[c % PALETTE.len()])
    }
}

impl Figure {
    /// The figure as JSON: size, grid, and per panel its labels, scales, the axis ranges the static
    /// rendering uses, every series (x, y, colour as `#rrggbb`, style) and marker. Missing values are
    /// `null`. This is what the interactive report figures are drawn from.
    pub fn to_json(&self) -> Result<String> {
        self.check()?;
        let colors = resolve_colors(self);
        let mut o = String::new();
        let _ = write!(
            o,
            "{{\"title\":{},\"width\":{},\"panelHeight\":{},\"columns\":{},\"panels\":[",
            js_str(&self.title),
            self.width,
            self.panel_height,
            self.grid().1
        );
        for (pi, p) in self.panels.iter().enumerate() {
            if pi > 0 {
                o.push(',');
            }
            let (xa, ya) = panel_axes(p);
            let _ = write!(
                o,
                "{{\"title\":{},\"xLabel\":{},\"yLabel\":{},\"xLog\":{},\"yLog\":{},\"xDeg\":{},\"yDeg\":{},\"equal\":{},\"xRange\":[{},{}],\"yRange\":[{},{}],\"series\":[",
                js_str(&p.title),
                js_str(&p.x_label),
                js_str(&p.y_label),
                p.x_log,
                p.y_log,
                p.x_degrees,
                p.y_degrees,
                p.equal_aspect,
                num(xa.lo),
                num(xa.hi),
                num(ya.lo),
                num(ya.hi)
            );
            for (si, s) in p.series.iter().enumerate() {
                if si > 0 {
                    o.push(',');
                }
                let _ = write!(
                    o,
                    "{{\"label\":{},\"color\":\"{}\",\"style\":\"{}\",\"x\":{},\"y\":{}}}",
                    js_str(&s.label),
                    color_hex(colors[pi][si]),
                    style_name(s.style),
                    nums(&s.x),
                    nums(&s.y)
                );
            }
            o.push_str("],\"markers\":[");
            let mut first = true;
            for m in &p.markers {
                let item = match m {
                    Marker::Vertical { x, label } => {
                        format!(
                            "{{\"kind\":\"vertical\",\"x\":{},\"label\":{}}}",
                            num(*x),
                            js_str(label)
                        )
                    }
                    Marker::Horizontal { y, label } => {
                        format!(
                            "{{\"kind\":\"horizontal\",\"y\":{},\"label\":{}}}",
                            num(*y),
                            js_str(label)
                        )
                    }
                    Marker::Point { x, y, label } => format!(
                        "{{\"kind\":\"point\",\"x\":{},\"y\":{},\"label\":{}}}",
                        num(*x),
                        num(*y),
                        js_str(label)
                    ),
                    Marker::Note { x, y, label } => format!(
                        "{{\"kind\":\"note\",\"x\":{},\"y\":{},\"label\":{}}}",
                        num(*x),
                        num(*y),
                        js_str(label)
                    ),
                    Marker::Arrow { x, y, dx, dy, color } => format!(
                        "{{\"kind\":\"arrow\",\"x\":{},\"y\":{},\"dx\":{},\"dy\":{},\"color\":\"{}\"}}",
                        num(*x),
                        num(*y),
                        num(*dx),
                        num(*dy),
                        color_hex(*color)
                    ),
                };
                if !first {
                    o.push(',');
                }
                first = false;
                o.push_str(&item);
            }
            o.push_str("]}");
        }
        o.push_str("]}");
        Ok(o)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figure::{Panel, Series};

    #[test]
    fn json_is_safe_in_a_script_and_has_no_nan() {
        let mut p = Panel::frequency("gain [dB]");
        p.series
            .push(Series::line("</script><b>", vec![1.0, 10.0], vec![f64::NAN, 2.5]));
        let j = Figure::new("t \"q\"", vec![p]).to_json().expect("json");
        assert!(!j.contains("</"));
        assert!(!j.contains("NaN"));
        assert!(j.contains("\"y\":[null,2.5]"));
        assert!(j.contains("\\\"q\\\""));
        assert!(j.contains("\"color\":\"#0072b2\""));
        assert!(j.contains("\"xRange\":[1,10]"));
    }
}
