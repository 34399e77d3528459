//! Raw channels of a flight log for the user's own eyes and tools: `skyloop log export` (CSV, one row
//! per logged frame, values as decoded, no resampling) and `skyloop log plot` (channels against time
//! with the airborne segments identification would use shaded).

use std::io::Write;
use std::path::Path;

use crate::firmware::Axis;
use crate::identify::airborne_segments;
use skyloop_plot::figure::Band;
use skyloop_plot::traces::{traces_figure, Trace, TracePanel};
use skyloop_sysid::logs::Log;
use skyloop_sysid::logs::Span;

use crate::error::{Error, Result};

/// The samples of `fields`, which must all belong to one group (one blackbox frame kind, one ULog
/// topic instance): (the group's time, s from the log start, the columns).
///
/// # Errors
/// No field, a field the log lacks, or fields of different groups (the message names them).
pub fn fields_of_one_group(log: &Log, fields: &[String]) -> Result<(Vec<f64>, Vec<Vec<f64>>)> {
    let Some(first) = fields.first() else {
        return Err(Error::Input("--fields names no field".into()));
    };
    let group_of = |name: &str| -> Result<usize> {
        let (t, _) = log.channel(name)?;
        Ok(log
            .groups
            .iter()
            .position(|g| std::ptr::eq(g.time_s.as_slice(), t))
            .unwrap_or(0))
    };
    let g0 = group_of(first)?;
    let mut cols = Vec::with_capacity(fields.len());
    for f in fields {
        let g = group_of(f)?;
        if g != g0 {
            return Err(Error::Input(format!(
                "--fields: '{first}' is logged in '{}' and '{f}' in '{}', at their own rates; export the fields of one group (topic) at a time",
                log.groups[g0].name, log.groups[g].name
            )));
        }
        cols.push(log.channel(f)?.1.to_vec());
    }
    Ok((log.groups[g0].time_s.clone(), cols))
}

/// Writes `time_s` (the flight controller's clock, s, as logged) and `fields` as CSV, one row per
/// logged frame; returns the number of rows.
///
/// # Errors
/// See [`fields_of_one_group`]; a file that cannot be written.
pub fn export_csv(log: &Log, fields: &[String], out: &Path) -> Result<usize> {
    let (t, cols) = fields_of_one_group(log, fields)?;
    let file = std::fs::File::create(out).map_err(|e| Error::write(out, e))?;
    let mut w = std::io::BufWriter::new(file);
    let mut write = || -> std::io::Result<()> {
        writeln!(w, "time_s,{}", fields.join(","))?;
        for (i, ti) in t.iter().enumerate() {
            // Microsecond clocks: six decimals keep every logged tick.
            write!(w, "{:.6}", ti + log.clock_origin_s)?;
            for c in &cols {
                write!(w, ",{}", c[i])?;
            }
            writeln!(w)?;
        }
        w.flush()
    };
    write().map_err(|e| Error::write(out, e))?;
    Ok(t.len())
}

/// The airborne segments `skyloop identify --axis` would search (on the roll gyro's time base);
/// empty for a log without firmware (CSV) or without flight.
pub fn airborne_spans(log: &Log) -> Vec<Span> {
    let Ok(ch) = crate::firmware::rate_loop_channels(log, Axis::Roll) else {
        return Vec::new();
    };
    let Ok(c) = crate::firmware::airborne_criteria(log) else {
        return Vec::new();
    };
    airborne_segments(log, &ch.output, &c, None, None)
        .map(|a| a.segments)
        .unwrap_or_default()
}

/// Plots `fields` against time (one panel per field, s from the log start) with the airborne
/// segments shaded, to an SVG or PNG by extension; returns the segments shaded.
///
/// # Errors
/// A field the log lacks, or a file that cannot be written.
pub fn plot_fields(log: &Log, fields: &[String], out: &Path) -> Result<Vec<Span>> {
    if fields.is_empty() {
        return Err(Error::Input("--fields names no field".into()));
    }
    let spans = airborne_spans(log);
    let mut panels = Vec::new();
    for f in fields {
        let (t, v) = log.series(f)?;
        panels.push(TracePanel {
            y_label: f.clone(),
            traces: vec![Trace {
                label: f.clone(),
                t,
                y: v,
            }],
            references: vec![],
        });
    }
    let mut fig = traces_figure(&log.source, &panels);
    for (p, tp) in fig.panels.iter_mut().zip(&panels) {
        let y = &tp.traces[0].y;
        let (lo, hi) = y
            .iter()
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        if !(hi >= lo) {
            continue;
        }
        for (k, s) in spans.iter().enumerate() {
            p.bands.push(Band {
                label: if k == 0 {
                    "airborne (identified)".into()
                } else {
                    String::new()
                },
                x: vec![s.from_s, s.to_s],
                lower: vec![lo; 2],
                upper: vec![hi; 2],
                color: 2,
            });
        }
    }
    fig.save(out)?;
    Ok(spans)
}

/// The `skyloop log info --json` object of a log read from `file`: `file`, `format`, `duration_s`,
/// `clock_origin_s`, `notes`, `groups` (name, fields, samples, rate_hz, duration_s), `sessions` (a
/// blackbox file's sessions, read from `bytes`, the whole file; empty for other formats or without
/// bytes) and `tuning` (the firmware's settings from the header, or null).
pub fn info_json(file: &str, log: &Log, bytes: Option<&[u8]>) -> serde_json::Value {
    use skyloop_sysid::logs::{blackbox, LogFormat};
    let sessions = match bytes {
        Some(b) if log.format == LogFormat::Blackbox => blackbox::sessions(b, file),
        _ => Vec::new(),
    };
    serde_json::json!({
        "file": file,
        "format": format!("{:?}", log.format).to_lowercase(),
        "duration_s": log.duration_s(),
        "clock_origin_s": log.clock_origin_s,
        "notes": log.notes,
        "groups": log.info(),
        "sessions": sessions,
        "tuning": crate::firmware::FirmwareTuning::from_log(log),
    })
}
