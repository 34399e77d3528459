//! The comparison as text (the CLI's summary) and as JSON (`compare.json`, `--json`).

use super::{AxisComparison, AxisSide, Comparison, Measured};
use serde_json::{json, Value};
use std::fmt::Write;

fn reason<T>(m: &Measured<T>) -> Option<String> {
    m.as_ref().err().map(|e| format!("not identified: {e}"))
}

fn part<T: serde::Serialize>(m: &Measured<T>) -> Value {
    match m {
        Ok(v) => serde_json::to_value(v).unwrap_or(Value::Null),
        Err(e) => json!({ "not_identified": e }),
    }
}

fn side_json(s: &AxisSide) -> Value {
    json!({
        "tracking": part(&s.tracking),
        "plant": part(&s.plant),
        "step": part(&s.step),
        "gyro_noise": part(&s.noise),
    })
}

/// Four significant digits, without an exponent in the usual range.
pub(crate) fn sig(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = (3 - x.abs().log10().floor() as i32).clamp(0, 8) as usize;
    format!("{x:.digits$}")
}

/// One row of the table: a label and the A and B cells.
type Row = (String, String, String);

fn rows_of(a: &AxisComparison) -> Vec<Row> {
    let mut rows: Vec<Row> = Vec::new();
    let cell = |s: &AxisSide, f: &dyn Fn(&AxisSide) -> Option<String>| f(s).unwrap_or_else(|| "-".into());
    let mut add = |label: &str, f: &dyn Fn(&AxisSide) -> Option<String>| {
        rows.push((label.to_string(), cell(&a.a, f), cell(&a.b, f)));
    };
    add("tracking -3 dB bandwidth", &|s| {
        s.tracking
            .as_ref()
            .ok()
            .and_then(|t| t.bandwidth_hz)
            .map(|b| format!("{b:.1} Hz"))
    });
    add("tracking peak", &|s| {
        s.tracking
            .as_ref()
            .ok()
            .and_then(|t| t.peak)
            .map(|(d, f)| format!("{d:+.1} dB at {f:.0} Hz"))
    });
    add("step rise 10-90 %", &|s| {
        s.step
            .as_ref()
            .ok()
            .and_then(|t| t.rise_time_ms)
            .map(|r| format!("{r:.1} ms"))
    });
    add("step overshoot", &|s| {
        s.step.as_ref().ok().and_then(|t| {
            t.overshoot_pct
                .map(|o| format!("{o:.0} ± {:.0} %", t.overshoot_std_pct))
        })
    });
    let unit = [&a.a, &a.b]
        .iter()
        .find_map(|s| s.plant.as_ref().ok().map(|p| p.gain_unit.clone()))
        .unwrap_or_default();
    add(&format!("plant K [{unit}]"), &|s| {
        s.plant
            .as_ref()
            .ok()
            .map(|p| format!("{} ± {}", sig(p.k.0), sig(p.k.1)))
    });
    add("plant tau", &|s| {
        s.plant
            .as_ref()
            .ok()
            .map(|p| format!("{:.1} ± {:.1} ms", 1e3 * p.tau_s.0, 1e3 * p.tau_s.1))
    });
    add("plant Td", &|s| {
        s.plant
            .as_ref()
            .ok()
            .map(|p| format!("{:.1} ± {:.1} ms", 1e3 * p.td_s.0, 1e3 * p.td_s.1))
    });
    if [&a.a, &a.b]
        .iter()
        .any(|s| s.plant.as_ref().is_ok_and(|p| p.tz_s.is_some()))
    {
        add("plant Tz (yaw zero)", &|s| {
            s.plant
                .as_ref()
                .ok()
                .and_then(|p| p.tz_s)
                .map(|(v, e)| format!("{:.1} ± {:.1} ms", 1e3 * v, 1e3 * e))
        });
    }
    add("gyro noise 20-100 Hz", &|s| {
        s.noise
            .as_ref()
            .ok()
            .and_then(|n| n.low_db)
            .map(|d| format!("{d:.1} dB"))
    });
    let top = [&a.a, &a.b]
        .iter()
        .find_map(|s| s.noise.as_ref().ok().map(|n| n.high_top_hz))
        .unwrap_or(f64::NAN);
    add(&format!("gyro noise 100-{top:.0} Hz"), &|s| {
        s.noise
            .as_ref()
            .ok()
            .and_then(|n| n.high_db)
            .map(|d| format!("{d:.1} dB"))
    });
    rows
}

impl Comparison {
    /// `{a, b, axes: [{axis, a: {tracking, plant, step, gyro_noise}, b, tracking_diff, step_diff,
    /// verdict, changed}], header_diffs: [{key, a, b}], verdict, notes}`; a part that could not be
    /// had is `{"not_identified": reason}`.
    pub fn to_json(&self) -> Value {
        let axes: Vec<Value> = self
            .axes
            .iter()
            .map(|a| {
                json!({
                    "axis": a.axis.name(),
                    "a": side_json(&a.a),
                    "b": side_json(&a.b),
                    "tracking_diff": a.tracking_diff.map(|(m, p)| json!({
                        "magnitude_db": m, "phase_deg": p,
                        "distinguishable": m.distinguishable() || p.distinguishable(),
                    })),
                    "step_diff": a.step_diff.map(|d| json!({
                        "step": d, "distinguishable": d.distinguishable(),
                    })),
                    "verdict": a.verdict,
                    "changed": a.changed,
                })
            })
            .collect();
        json!({
            "a": self.a,
            "b": self.b,
            "axes": axes,
            "header_diffs": self.header_diffs,
            "verdict": self.verdict,
            "notes": self.notes,
        })
    }

    /// The summary a pilot reads: the logs, a table per axis (A and B side by side, or why a part
    /// is missing), the settings that differ, and the verdict.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        for (k, f) in [("A", &self.a), ("B", &self.b)] {
            let _ = writeln!(s, "{k}: {} — {}, {:.1} s", f.source, f.revision, f.duration_s);
        }
        for n in &self.notes {
            let _ = writeln!(s, "note: {n}");
        }
        for a in &self.axes {
            let _ = writeln!(s, "\n{}", a.axis.name());
            let _ = writeln!(s, "  {:<30} {:<28} {:<28}", "", "A", "B");
            for (label, x, y) in rows_of(a) {
                if x != "-" || y != "-" {
                    let _ = writeln!(s, "  {label:<30} {x:<28} {y:<28}");
                }
            }
            for (k, side) in [("A", &a.a), ("B", &a.b)] {
                let missing = [
                    ("tracking", reason(&side.tracking)),
                    ("step", reason(&side.step)),
                    ("plant", reason(&side.plant)),
                    ("gyro noise", reason(&side.noise)),
                ];
                for (what, r) in missing {
                    if let Some(r) = r {
                        let _ = writeln!(s, "  {k} {what}: {r}");
                    }
                }
            }
        }
        let _ = writeln!(s, "\nsettings that differ (A → B):");
        if self.header_diffs.is_empty() {
            let _ = writeln!(s, "  none");
        }
        for d in &self.header_diffs {
            let _ = writeln!(
                s,
                "  {}: {} → {}",
                d.key,
                d.a.as_deref().unwrap_or("not set"),
                d.b.as_deref().unwrap_or("not set")
            );
        }
        let _ = writeln!(s, "\nverdict:");
        for v in &self.verdict {
            let _ = writeln!(s, "  {v}");
        }
        s
    }
}
