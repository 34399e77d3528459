//! The report's flight strip: the axis's setpoint and gyro over the whole flight with the stretches
//! the identification used shaded, and a table of why the others were not used.

use crate::identify::SegmentVerdict;
use crate::tune::log::LogTuneOutcome;
use skyloop_plot::figure::{Band, Figure, Panel, Series};
use skyloop_plot::Report;

/// Most table rows (the JSON's `segments` has every stretch).
const MAX_ROWS: usize = 14;

/// The flight strip figure (None when the log's gyro could not be read back for it).
pub(super) fn strip_figure(out: &LogTuneOutcome) -> Option<Figure> {
    let s = &out.strip;
    if s.t_s.len() < 2 {
        return None;
    }
    let finite = |v: &[f64]| v.iter().copied().filter(|x| x.is_finite()).collect::<Vec<_>>();
    let mut all = finite(&s.gyro);
    if let Some(r) = &s.setpoint {
        all.extend(finite(r));
    }
    let lo = all.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let pad = 0.05 * (hi - lo).max(1.0);
    let (lo, hi) = (lo - pad, hi + pad);
    let mut bands = Vec::new();
    for (i, seg) in out.identification.timeline.iter().filter(|g| g.used).enumerate() {
        bands.push(Band {
            label: if i == 0 {
                "used for the identification".into()
            } else {
                String::new()
            },
            x: vec![seg.start_s, seg.end_s],
            lower: vec![lo, lo],
            upper: vec![hi, hi],
            color: 2,
        });
    }
    // The gyro first, the dashed setpoint over it: where the loop tracks, both stay visible.
    let mut series = vec![Series::line("gyro", s.t_s.clone(), s.gyro.clone()).colored(0)];
    if let Some(r) = &s.setpoint {
        series.push(Series::dashed("setpoint", s.t_s.clone(), r.clone()).colored(1));
    }
    let unit = out
        .identification
        .units
        .as_ref()
        .map_or(String::new(), |u| format!(" [{}]", u.output));
    let panel = Panel {
        x_label: "log time [s]".into(),
        y_label: format!("{} rate{unit}", out.axis.name()),
        series,
        bands,
        y_range: Some((lo, hi)),
        ..Panel::default()
    };
    Some(Figure::new(
        format!(
            "The flight, {}: setpoint, gyro and the stretches used (shaded)",
            out.axis.name()
        ),
        vec![panel],
    ))
}

/// The flight-strip section: the figure and the table of stretches.
pub(super) fn segments_section(rep: &mut Report, out: &LogTuneOutcome) -> Option<Figure> {
    let tl = &out.identification.timeline;
    let fig = strip_figure(out);
    let sec = rep.section("The flight: what the identification used");
    let (used, total) = SegmentVerdict::used_of_total_s(tl);
    sec.text(format!(
        "{used:.1} s of {total:.1} s used, in {} stretches where every airborne test holds (no motor at a limit, throttle off idle, gyro below saturation), each trimmed by a margin; a log that ends in flight loses its last second.",
        tl.iter().filter(|s| s.used).count()
    ));
    if let Some(f) = &fig {
        sec.figure(f.clone(), "Setpoint (dashed) and gyro of this axis over the whole log; the shaded stretches are the ones the estimate used.");
    }
    let rows = SegmentVerdict::headline(tl, MAX_ROWS)
        .into_iter()
        .map(|s| {
            vec![
                format!("{:.2}", s.start_s),
                format!("{:.2}", s.end_s),
                if s.used {
                    "used".to_string()
                } else {
                    "not used".to_string()
                },
                s.reason.clone(),
            ]
        })
        .collect();
    sec.table(&["from [s]", "to [s]", "", "why"], rows);
    fig
}
