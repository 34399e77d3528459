//! Time-domain plots: step responses and simulation traces stacked in panels sharing the time axis.

use std::path::Path;

use crate::error::Result;
use crate::figure::{Figure, Marker, Panel, Series};

/// One signal against time.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// Legend text.
    pub label: String,
    /// Times, s.
    pub t: Vec<f64>,
    /// Values, in the panel's unit.
    pub y: Vec<f64>,
}

/// A panel of traces sharing one y unit, with an optional horizontal reference (setpoint, bound).
#[derive(Debug, Clone, PartialEq)]
pub struct TracePanel {
    /// y-axis description with its unit.
    pub y_label: String,
    /// Signals drawn in this panel.
    pub traces: Vec<Trace>,
    /// Horizontal reference lines: value and label.
    pub references: Vec<(f64, String)>,
}

/// Builds a figure of stacked trace panels over time in seconds.
pub fn traces_figure(title: &str, panels: &[TracePanel]) -> Figure {
    let panels = panels
        .iter()
        .map(|tp| Panel {
            x_label: "time [s]".into(),
            y_label: tp.y_label.clone(),
            series: tp
                .traces
                .iter()
                .map(|t| Series::line(t.label.clone(), t.t.clone(), t.y.clone()))
                .collect(),
            markers: tp
                .references
                .iter()
                .map(|(y, label)| Marker::Horizontal {
                    y: *y,
                    label: label.clone(),
                })
                .collect(),
            ..Panel::default()
        })
        .collect();
    Figure::new(title, panels)
}

/// Writes stacked time traces to `path` (`.svg` or `.png`).
pub fn plot_traces(path: &Path, title: &str, panels: &[TracePanel]) -> Result<()> {
    traces_figure(title, panels).save(path)
}

/// Writes step responses (one panel, several systems overlaid, the final value 1 marked) to `path`.
pub fn plot_step(path: &Path, title: &str, traces: &[Trace]) -> Result<()> {
    let panel = TracePanel {
        y_label: "output".into(),
        traces: traces.to_vec(),
        references: vec![],
    };
    traces_figure(title, &[panel]).save(path)
}
