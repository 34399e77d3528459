//! Time-domain plots: step responses and simulation traces stacked in panels sharing the time axis.

use std::path::Path;

use crate::error::Result;
use crate::figure::{Figure, Marker, Panel, Series, SeriesStyle};

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

/// Builds a figure of stacked trace panels over time in seconds; traces whose label starts with
/// "reference" are dashed.
pub fn traces_figure(title: &str, panels: &[TracePanel]) -> Figure {
    let panels = panels
        .iter()
        .map(|tp| Panel {
            x_label: "time [s]".into(),
            y_label: tp.y_label.clone(),
            series: tp
                .traces
                .iter()
                .map(|t| {
                    // A trace named "reference …" is a command, drawn dashed by the convention of
                    // every figure here (the response solid).
                    if t.label.starts_with("reference") {
                        Series::dashed(t.label.clone(), t.t.clone(), t.y.clone())
                    } else {
                        Series::line(t.label.clone(), t.t.clone(), t.y.clone())
                    }
                })
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

/// Step-response characteristics to mark on a step trace: the analysis crate's `stepinfo` result.
pub use skyloop_lti::timeresp::StepInfo;

/// The first time (interpolated) at which `y` reaches `level` going the way of `sign`.
fn first_crossing(t: &[f64], y: &[f64], level: f64) -> Option<f64> {
    let up = level >= y.first().copied().unwrap_or(0.0);
    for i in 1..t.len().min(y.len()) {
        let (a, b) = (y[i - 1], y[i]);
        let crossed = if up {
            a < level && b >= level
        } else {
            a > level && b <= level
        };
        if crossed && b != a {
            return Some(t[i - 1] + (level - a) / (b - a) * (t[i] - t[i - 1]));
        }
    }
    None
}

/// `y(t)` by linear interpolation.
fn value_at(t: &[f64], y: &[f64], at: f64) -> Option<f64> {
    for i in 1..t.len().min(y.len()) {
        if t[i - 1] <= at && at <= t[i] && t[i] > t[i - 1] {
            return Some(y[i - 1] + (at - t[i - 1]) / (t[i] - t[i - 1]) * (y[i] - y[i - 1]));
        }
    }
    None
}

/// Builds a step-response figure with the characteristics of `infos[k]` marked on `traces[k]`
/// (fewer infos than traces leave the rest plain): the final value dashed, the rise points with the
/// rise time, the peak with the overshoot, the lowest point with the undershoot, and the settling
/// band with a line at the settling time, each with its value. Trace `k` has palette colour `k`;
/// marks are drawn in their trace's colour.
pub fn step_figure(title: &str, traces: &[Trace], infos: &[StepInfo]) -> Figure {
    let mut p = Panel {
        x_label: "time [s]".into(),
        y_label: "output".into(),
        ..Panel::default()
    };
    let t_end = traces
        .iter()
        .flat_map(|t| t.t.iter().copied())
        .filter(|v| v.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    let t_start = traces
        .iter()
        .flat_map(|t| t.t.iter().copied())
        .filter(|v| v.is_finite())
        .fold(f64::INFINITY, f64::min);
    for (k, tr) in traces.iter().enumerate() {
        p.series
            .push(Series::line(tr.label.clone(), tr.t.clone(), tr.y.clone()).colored(k));
    }
    let fmt = |v: f64| crate::bode::sig3(v);
    if !infos.is_empty() {
        // Head room over the peak, so its note can sit above the curve instead of on it.
        let (lo, hi) = traces
            .iter()
            .flat_map(|t| t.y.iter().copied())
            .chain(infos.iter().map(|i| i.final_value))
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
        if lo.is_finite() && hi > lo {
            let span = hi - lo;
            p.y_range = Some((lo - 0.05 * span, hi + 0.15 * span));
        }
    }
    for (k, (tr, info)) in traces.iter().zip(infos).enumerate() {
        let yf = info.final_value;
        let mut dots: (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
        // With several traces on one axis, each note names its trace.
        let whose = if traces.len() > 1 && !tr.label.is_empty() {
            format!("{}: ", tr.label)
        } else {
            String::new()
        };
        let dot = |x: f64, y: f64, p: &mut Panel, dots: &mut (Vec<f64>, Vec<f64>), label: String| {
            dots.0.push(x);
            dots.1.push(y);
            p.markers.push(Marker::Note {
                x,
                y,
                label: format!("{whose}{label}"),
            });
        };
        p.series.push(
            Series::line("", vec![t_start, t_end], vec![yf, yf])
                .styled(SeriesStyle::Dashed)
                .colored(k),
        );
        if let Some(rt) = info.rise_time_s {
            let (lo, hi) = info.rise_limits;
            if let Some(t0) = first_crossing(&tr.t, &tr.y, lo * yf) {
                let t1 = t0 + rt;
                let y1 = value_at(&tr.t, &tr.y, t1).unwrap_or(hi * yf);
                dots.0.push(t0);
                dots.1.push(lo * yf);
                dot(t1, y1, &mut p, &mut dots, format!("rise time {} s", fmt(rt)));
            }
        }
        if let Some((peak, tp)) = info.peak {
            let os = info
                .overshoot_pct
                .map(|o| format!(", overshoot {} %", fmt(o)))
                .unwrap_or_default();
            dot(
                tp,
                peak,
                &mut p,
                &mut dots,
                format!("peak {} at {} s{os}", fmt(peak), fmt(tp)),
            );
        } else if let Some(os) = info.overshoot_pct {
            p.markers.push(Marker::Horizontal {
                y: yf * (1.0 + os / 100.0),
                label: format!("overshoot {} %", fmt(os)),
            });
        }
        if let Some(us) = info.undershoot_pct.filter(|u| *u > 0.0) {
            // The lowest point of the trace (the opposite way of the final value).
            let low =
                tr.t.iter()
                    .zip(&tr.y)
                    .filter(|(t, y)| t.is_finite() && y.is_finite())
                    .min_by(|a, b| (a.1 * yf.signum()).total_cmp(&(b.1 * yf.signum())));
            if let Some((t, y)) = low {
                dot(*t, *y, &mut p, &mut dots, format!("undershoot {} %", fmt(us)));
            }
        }
        if let Some(ts) = info.settling_time_s {
            let b = info.settling_band * yf.abs();
            for y in [yf - b, yf + b] {
                p.series
                    .push(Series::line("", vec![t_start, t_end], vec![y, y]).styled(SeriesStyle::Reference));
            }
            let ys = value_at(&tr.t, &tr.y, ts).unwrap_or(yf);
            dot(
                ts,
                ys,
                &mut p,
                &mut dots,
                format!("settling time {} s ({} %)", fmt(ts), fmt(100.0 * info.settling_band)),
            );
        }
        p.series
            .push(Series::points("", dots.0, dots.1, SeriesStyle::Points).colored(k));
    }
    Figure::new(title, vec![p])
}

/// Writes an annotated step response (see [`step_figure`]) to `path` (`.svg` or `.png`).
pub fn plot_step_info(path: &Path, title: &str, traces: &[Trace], infos: &[StepInfo]) -> Result<()> {
    step_figure(title, traces, infos).save(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_marks_carry_their_values() {
        // Second-order step with ζ = 0.4, ωn = 5 rad/s.
        let (z, wn) = (0.4f64, 5.0f64);
        let wd = wn * (1.0 - z * z).sqrt();
        let t: Vec<f64> = (0..=400).map(|i| i as f64 * 0.01).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|t| 1.0 - (-z * wn * t).exp() * ((wd * t).cos() + z / (1.0 - z * z).sqrt() * (wd * t).sin()))
            .collect();
        let tp = std::f64::consts::PI / wd;
        let os = 100.0 * (-z * std::f64::consts::PI / (1.0 - z * z).sqrt()).exp();
        let info = StepInfo {
            rise_time_s: Some(0.27),
            settling_time_s: Some(1.8),
            overshoot_pct: Some(os),
            peak: Some((1.0 + os / 100.0, tp)),
            ..StepInfo::new(1.0)
        };
        let f = step_figure(
            "S",
            &[Trace {
                label: "y".into(),
                t,
                y,
            }],
            &[info],
        );
        let notes: Vec<String> = f.panels[0]
            .markers
            .iter()
            .filter_map(|m| match m {
                Marker::Note { label, .. } => Some(label.clone()),
                _ => None,
            })
            .collect();
        assert!(notes.iter().any(|n| n == "rise time 0.27 s"), "{notes:?}");
        assert!(
            notes
                .iter()
                .any(|n| n.starts_with("peak 1.25 at 0.686 s, overshoot 25.4 %")),
            "{notes:?}"
        );
        assert!(notes.iter().any(|n| n == "settling time 1.8 s (2 %)"), "{notes:?}");
        // The settling band: two grey lines at 0.98 and 1.02.
        let band: Vec<f64> = f.panels[0]
            .series
            .iter()
            .filter(|s| s.style == SeriesStyle::Reference)
            .map(|s| s.y[0])
            .collect();
        assert_eq!(band, vec![0.98, 1.02]);
    }
}
