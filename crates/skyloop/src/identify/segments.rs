//! The parts of a log an identification uses: the longest stretch where `--where` holds, the
//! airborne segments with `--axis`, or else the whole selected span.

use std::ops::Range;

use super::airborne::{airborne_segments, SegmentVerdict};
use super::channels::Channels;
use super::remarks::Remarks;
use super::request::IdentifyRequest;
use crate::error::{Error, Result};
use skyloop_sysid::logs::Span;
use skyloop_sysid::logs::{segments_where, Condition, Log, UniformData};

/// The channels on one uniform grid and the records (sample ranges) of it to estimate on.
pub(crate) struct Selection {
    /// Input, output and (when there is one) instrument, in that order, then the condition's column.
    pub data: UniformData,
    /// The records, in time order, as sample ranges of `data`.
    pub ranges: Vec<Range<usize>>,
    /// The same records as spans of the log's clock, s.
    pub segments: Vec<Span>,
    /// The selected span cut into stretches used or not, and why.
    pub timeline: Vec<SegmentVerdict>,
}

/// Resamples the channels (and the `--where` condition's column) onto one grid over
/// `--from`..`--to` and picks the records.
///
/// # Errors
/// A column the log does not hold, a condition that does not parse or never holds for 2 s, or no
/// airborne segment.
pub(crate) fn select(log: &Log, a: &IdentifyRequest, ch: &Channels, rm: &mut Remarks) -> Result<Selection> {
    let mut cols = ch.specs();
    let cond = a.condition.as_deref().map(Condition::parse).transpose()?;
    if let Some(c) = &cond {
        cols.push(&c.column);
    }
    let data = log.uniform(&cols, a.rate, a.from, a.to)?;
    let mut timeline = None;
    let ranges: Vec<Range<usize>> = if let Some(c) = &cond {
        vec![where_holds(&data, c, a.condition.as_deref().unwrap_or(""), rm)?]
    } else if let Some(p) = &ch.preset {
        let t_end = t_of(&data, data.len() - 1);
        let air = airborne_segments(log, &ch.output, &p.criteria, Some(data.t0_s), Some(t_end))?;
        timeline = Some(air.timeline.clone());
        let total: f64 = air.segments.iter().map(Span::len_s).sum();
        let excluded: Vec<String> = air
            .excluded_s
            .iter()
            .filter(|(_, s)| *s > 0.0)
            .map(|(r, s)| format!("{r} {s:.1} s"))
            .collect();
        rm.note(format!(
            "{} airborne segments, {total:.1} s of {:.1} s searched (excluded: {})",
            air.segments.len(),
            air.searched.len_s(),
            if excluded.is_empty() {
                "nothing".to_string()
            } else {
                excluded.join(", ")
            }
        ));
        air.segments
            .iter()
            .map(|s| data.range_of(s))
            .filter(|r| r.end > r.start + 1)
            .collect()
    } else {
        std::iter::once(0..data.len()).collect()
    };
    let segments: Vec<Span> = ranges
        .iter()
        .map(|r| Span {
            from_s: t_of(&data, r.start),
            to_s: t_of(&data, r.end - 1),
        })
        .collect();
    // Without the airborne search: the chosen stretch used, the rest of the span not.
    let timeline = timeline.unwrap_or_else(|| {
        let why = if cond.is_some() {
            "the --where condition does not hold for 2 s or more"
        } else {
            "outside --from/--to"
        };
        let end = t_of(&data, data.len().saturating_sub(1));
        let mut tl = Vec::new();
        let mut at = data.t0_s;
        for s in &segments {
            if s.from_s > at {
                tl.push(SegmentVerdict {
                    start_s: at,
                    end_s: s.from_s,
                    used: false,
                    reason: why.into(),
                });
            }
            let reason = if cond.is_some() {
                "the --where condition holds"
            } else {
                "the selected span"
            };
            tl.push(SegmentVerdict {
                start_s: s.from_s,
                end_s: s.to_s,
                used: true,
                reason: reason.into(),
            });
            at = s.to_s;
        }
        if end > at {
            tl.push(SegmentVerdict {
                start_s: at,
                end_s: end,
                used: false,
                reason: why.into(),
            });
        }
        tl
    });
    Ok(Selection {
        data,
        ranges,
        segments,
        timeline,
    })
}

/// Time of grid sample `i`, s.
fn t_of(data: &UniformData, i: usize) -> f64 {
    data.t0_s + i as f64 * data.dt_s
}

/// The longest stretch of at least 2 s where the condition (the grid's last column) holds.
fn where_holds(data: &UniformData, c: &Condition, text: &str, rm: &mut Remarks) -> Result<Range<usize>> {
    let column = data.columns.last().map(Vec::as_slice).unwrap_or_default();
    let mask: Vec<bool> = column.iter().map(|&x| c.holds(x)).collect();
    let min_len = (2.0 / data.dt_s).ceil() as usize;
    let seg = segments_where(&mask, min_len)
        .into_iter()
        .max_by_key(|r| r.len())
        .ok_or_else(|| Error::Input(format!("'{text}' never holds for 2 s or more in the selected span")))?;
    rm.note(format!(
        "using {:.2} s .. {:.2} s where {text}",
        t_of(data, seg.start),
        t_of(data, seg.end)
    ));
    Ok(seg)
}
