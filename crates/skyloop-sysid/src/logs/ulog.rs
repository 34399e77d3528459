//! PX4 ULog logs through the `px4-ulog` crate's streaming parser, decoding every numeric field to f64.
//!
//! A log cut off mid-record or with a corrupt record keeps its valid prefix and gets a note; a log
//! whose header or definitions cannot be parsed is refused with the parser's reason. The file's
//! records are checked first (module `guard`) so that px4-ulog, which slices payloads unchecked, never
//! sees a record it would panic on.
//!
//! Time: a log's data span runs from its first to its last *live* data message. A message is live
//! when its time stamp is non-zero and later than every earlier one of its topic instance (zeros are
//! topics never published; repeats are stale snapshots written again). Messages stamped more than
//! 1 s before the logger started (the file header's stamp) are snapshots from before logging began,
//! and the span ends at the last live message of a topic with at least two live messages (a lone
//! message's stamp cannot be checked). Times are seconds from the span's start; messages outside the
//! span or not live are left out and counted in a note. Each topic keeps its own sample times, so its
//! rate is its own.

use std::collections::HashMap;
use std::path::Path;

use px4_ulog::stream_parser::model::DropoutMessage;
use px4_ulog::stream_parser::model::{DataMessage, FlattenedFieldType, ParameterMessage};
use px4_ulog::stream_parser::LogParser;

mod guard;

use super::{Channel, Group, Log, LogFormat};
use crate::error::{Result, SysidError};

struct Decoder {
    offset: usize,
    ty: FlattenedFieldType,
}

struct Builder {
    name: String,
    multi: u8,
    decoders: Vec<Decoder>,
    names: Vec<String>,
    time_us: Vec<u64>,
    cols: Vec<Vec<f64>>,
}

fn field_size(ty: &FlattenedFieldType) -> usize {
    use FlattenedFieldType::*;
    match ty {
        Int8 | UInt8 | Bool | Char => 1,
        Int16 | UInt16 => 2,
        Int32 | UInt32 | Float => 4,
        Int64 | UInt64 | Double => 8,
    }
}

fn decode(ty: &FlattenedFieldType, b: &[u8]) -> f64 {
    use FlattenedFieldType::*;
    let a = |n: usize| -> [u8; 8] {
        let mut x = [0u8; 8];
        x[..n].copy_from_slice(&b[..n]);
        x
    };
    match ty {
        Int8 => b[0] as i8 as f64,
        UInt8 | Char => b[0] as f64,
        Bool => (b[0] != 0) as u8 as f64,
        Int16 => i16::from_le_bytes([b[0], b[1]]) as f64,
        UInt16 => u16::from_le_bytes([b[0], b[1]]) as f64,
        Int32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        UInt32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        Float => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        Int64 => i64::from_le_bytes(a(8)) as f64,
        UInt64 => u64::from_le_bytes(a(8)) as f64,
        Double => f64::from_le_bytes(a(8)),
    }
}

impl Builder {
    fn new(msg: &DataMessage) -> Builder {
        let mut decoders = Vec::new();
        let mut names = Vec::new();
        for f in &msg.flattened_format.fields {
            let n = &f.flattened_field_name;
            if n == "timestamp" || n.starts_with("_padding") || f.field_type == FlattenedFieldType::Char {
                continue;
            }
            decoders.push(Decoder {
                offset: f.offset as usize,
                ty: f.field_type.clone(),
            });
            names.push(n.clone());
        }
        let cols = vec![Vec::new(); names.len()];
        Builder {
            name: msg.flattened_format.message_name.clone(),
            multi: msg.multi_id.value(),
            decoders,
            names,
            time_us: Vec::new(),
            cols,
        }
    }

    /// Appends one message; returns false (and appends nothing) when the payload is too short.
    fn push(&mut self, msg: &DataMessage) -> bool {
        let data = msg.data;
        let Some(tf) = &msg.flattened_format.timestamp_field else {
            return false;
        };
        let to = tf.offset as usize;
        let Some(ts) = data.get(to..to + 8) else { return false };
        if self.decoders.iter().any(|d| data.len() < d.offset + field_size(&d.ty)) {
            return false;
        }
        let mut t = [0u8; 8];
        t.copy_from_slice(ts);
        self.time_us.push(u64::from_le_bytes(t));
        for (d, c) in self.decoders.iter().zip(self.cols.iter_mut()) {
            c.push(decode(&d.ty, &data[d.offset..]));
        }
        true
    }
}

/// How long before the logger's start (the file header's time stamp) a message may be stamped and
/// still count as data: a slow topic's last sample before logging began, µs.
const PRE_START_US: u64 = 1_000_000;

/// The file header's time stamp (the logger's start), µs; `None` when the file is too short.
fn header_timestamp_us(bytes: &[u8]) -> Option<u64> {
    let mut t = [0u8; 8];
    t.copy_from_slice(bytes.get(8..16)?);
    Some(u64::from_le_bytes(t))
}

/// Which messages of one topic instance (time stamps in file order) are live: non-zero and later than
/// every earlier one. Zeros come from topics never published; repeats are stale snapshots that the
/// logger wrote again without the topic being updated.
fn live_mask(t: &[u64]) -> Vec<bool> {
    let mut best = 0u64;
    t.iter()
        .map(|&x| {
            let live = x > 0 && x > best;
            best = best.max(x);
            live
        })
        .collect()
}

/// The log's data span (first, last time stamp), µs: from the earliest live message not stamped more
/// than [`PRE_START_US`] before the logger started, to the latest live message of a topic instance
/// with at least two live messages (a lone message's stamp cannot be checked against anything).
/// tools/gen_ulog.py computes the same from pyulog's reading.
fn data_span(builders: &[Builder], header_us: Option<u64>) -> Option<(u64, u64)> {
    let lives: Vec<Vec<u64>> = builders
        .iter()
        .map(|b| {
            live_mask(&b.time_us)
                .into_iter()
                .zip(&b.time_us)
                .filter(|(l, _)| *l)
                .map(|(_, &t)| t)
                .collect()
        })
        .collect();
    let max_live = lives.iter().flatten().copied().max()?;
    let cut = header_us
        .filter(|&s| s > 0 && s <= max_live)
        .map_or(0, |s| s.saturating_sub(PRE_START_US));
    let start = lives.iter().flatten().copied().filter(|&t| t >= cut).min()?;
    let end = lives
        .iter()
        .filter(|l| l.len() >= 2)
        .filter_map(|l| l.iter().copied().max())
        .max()
        .unwrap_or(max_live);
    (end >= start).then_some((start, end))
}

/// Reads a ULog file.
pub fn read_path(path: &Path) -> Result<Log> {
    let source = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| SysidError::Io(format!("cannot read {source}: {e}")))?;
    read_bytes(&bytes, &source)
}

/// How far px4-ulog got through the file.
enum Outcome {
    Complete,
    Truncated,
    Malformed(String),
}

/// What the parser's callbacks collect: one builder per topic instance, and the file's counts.
#[derive(Default)]
struct Collected {
    builders: Vec<Builder>,
    /// Data messages shorter than their format, skipped.
    short: usize,
    /// Logger dropouts reported in the file, ms.
    dropouts_ms: u64,
    settings: Vec<(String, String)>,
}

/// Runs px4-ulog over the guard's safe ranges of `bytes`, collecting into `c`; the outer `Err` is
/// a parser panic, the inner `Err` the parser's reason for refusing the header or definitions.
fn parse_records(bytes: &[u8], c: &mut Collected) -> std::thread::Result<std::result::Result<Outcome, String>> {
    let Collected {
        builders,
        short,
        dropouts_ms,
        settings,
    } = c;
    let mut by_key: HashMap<(String, u8), usize> = HashMap::new();
    let mut by_msg_id: HashMap<u16, usize> = HashMap::new();
    let safe = guard::safe_ranges(bytes);
    // The guard keeps px4-ulog away from every record it is known to panic on; catch_unwind stays as
    // a last line of defence (its panic message would still reach stderr, hence the guard).
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let mut on_data = |msg: &DataMessage| {
            let idx = *by_msg_id.entry(msg.msg_id).or_insert_with(|| {
                let key = (msg.flattened_format.message_name.clone(), msg.multi_id.value());
                *by_key.entry(key).or_insert_with(|| {
                    builders.push(Builder::new(msg));
                    builders.len() - 1
                })
            });
            if !builders[idx].push(msg) {
                *short += 1;
            }
        };
        let mut on_dropout = |d: &DropoutMessage| *dropouts_ms += u64::from(d.duration_ms);
        let mut on_param = |p: &ParameterMessage| {
            settings.push(match p {
                ParameterMessage::Float(k, v, _) => (k.to_string(), v.to_string()),
                ParameterMessage::Int32(k, v, _) => (k.to_string(), v.to_string()),
            })
        };
        let mut parser = LogParser::default();
        parser.set_data_message_callback(&mut on_data);
        parser.set_dropout_message_callback(&mut on_dropout);
        parser.set_parameter_message_callback(&mut on_param);
        for (i, &(a, b)) in safe.ranges.iter().enumerate() {
            if i > 0 {
                // An appended section starts a fresh record stream.
                parser.clear_leftover();
            }
            if let Err(e) = parser.consume_bytes(&bytes[a..b]) {
                return if parser.in_data() {
                    Ok(Outcome::Malformed(readable(&e.to_string())))
                } else {
                    Err(readable(&e.to_string()))
                };
            }
        }
        Ok(match &safe.cut {
            Some((at, why)) => Outcome::Malformed(format!("at byte {at}: {why}")),
            None if parser.has_leftover() => Outcome::Truncated,
            None => Outcome::Complete,
        })
    }))
}

/// Refuses a file shorter than its 16-byte header or without any data message.
fn check_has_data(bytes: &[u8], builders: &[Builder], completeness: &Outcome, source: &str) -> Result<()> {
    if bytes.len() < 16 {
        return Err(SysidError::Log(format!(
            "{source}: not a readable ULog file: {} bytes, fewer than its 16-byte file header",
            bytes.len()
        )));
    }
    if builders.is_empty() {
        let why = match completeness {
            Outcome::Malformed(why) => format!("corrupt before any data ({why})"),
            Outcome::Truncated => "it ends inside its definitions, before any data message".to_string(),
            Outcome::Complete => "it holds no data messages".to_string(),
        };
        return Err(SysidError::Log(format!("{source}: not a readable ULog file: {why}")));
    }
    Ok(())
}

/// The topics' groups trimmed to the data span, and what was left out.
#[derive(Default)]
struct Trimmed {
    groups: Vec<Group>,
    /// The latest kept sample time, s from the span's start.
    last_t: f64,
    /// Messages left out (not live or outside the span).
    stale: usize,
    /// Topics all of whose messages were left out.
    stale_topics: Vec<String>,
}

/// Keeps each topic's live messages within the span `t0..=t_end` (µs), timed in s from `t0`.
fn trim_to_span(builders: Vec<Builder>, t0: u64, t_end: u64) -> Trimmed {
    let mut out = Trimmed {
        groups: Vec::with_capacity(builders.len()),
        ..Trimmed::default()
    };
    for b in builders {
        let name = if b.multi == 0 {
            b.name.clone()
        } else {
            format!("{}[{}]", b.name, b.multi)
        };
        let keep: Vec<bool> = live_mask(&b.time_us)
            .into_iter()
            .zip(&b.time_us)
            .map(|(live, &t)| live && t >= t0 && t <= t_end)
            .collect();
        let kept = keep.iter().filter(|&&k| k).count();
        out.stale += b.time_us.len() - kept;
        if kept == 0 {
            if !b.time_us.is_empty() {
                out.stale_topics.push(name);
            }
            continue;
        }
        let pick = |v: &[f64]| -> Vec<f64> { v.iter().zip(&keep).filter(|(_, &k)| k).map(|(x, _)| *x).collect() };
        let time_s: Vec<f64> = b
            .time_us
            .iter()
            .zip(&keep)
            .filter(|(_, &k)| k)
            .map(|(&t, _)| (t - t0) as f64 * 1e-6)
            .collect();
        out.last_t = out.last_t.max(time_s.last().copied().unwrap_or(0.0));
        let channels = b
            .names
            .into_iter()
            .zip(b.cols)
            .map(|(name, values)| Channel {
                name,
                values: pick(&values),
            })
            .collect();
        out.groups.push(Group {
            prefix: Some(name.clone()),
            name,
            time_s,
            channels,
        });
    }
    out
}

/// The note on messages left out for stale time stamps, if any were.
fn stale_note(stale: usize, mut stale_topics: Vec<String>) -> Option<String> {
    if stale == 0 {
        return None;
    }
    let mut note = format!(
        "{stale} messages with stale time stamps (zero, repeating an earlier one, or outside the data span) were left out"
    );
    if !stale_topics.is_empty() {
        stale_topics.truncate(12);
        note.push_str(&format!("; topics with no other messages: {}", stale_topics.join(", ")));
    }
    Some(note)
}

/// Notes on how far the file was read (`last_t` in s), skipped short messages and dropouts.
fn reading_notes(completeness: Outcome, last_t: f64, short: usize, dropouts_ms: u64) -> Vec<String> {
    let mut notes = Vec::new();
    match completeness {
        Outcome::Complete => {}
        Outcome::Truncated => notes.push(format!("log truncated mid-record: data read up to {last_t:.3} s")),
        Outcome::Malformed(r) => notes.push(format!(
            "corrupt record after {last_t:.3} s ({r}); data before it was kept"
        )),
    }
    if short > 0 {
        notes.push(format!("{short} data messages shorter than their format were skipped"));
    }
    if dropouts_ms > 0 {
        notes.push(format!("the logger reported {dropouts_ms} ms of dropouts"));
    }
    notes
}

/// Reads a ULog file's bytes; `source` names it in messages.
pub fn read_bytes(bytes: &[u8], source: &str) -> Result<Log> {
    let source = source.to_string();
    let mut c = Collected::default();
    let completeness = match parse_records(bytes, &mut c) {
        Ok(Ok(outcome)) => outcome,
        Ok(Err(e)) => return Err(SysidError::Log(format!("{source}: not a readable ULog file: {e}"))),
        Err(_) => {
            return Err(SysidError::Log(format!(
                "{source}: the ULog parser failed on corrupt data"
            )))
        }
    };
    check_has_data(bytes, &c.builders, &completeness, &source)?;
    let header_us = header_timestamp_us(bytes);
    let span = data_span(&c.builders, header_us)
        .ok_or_else(|| SysidError::Log(format!("{source}: no data message carries a time stamp (all are zero)")))?;
    let (t0, t_end) = span;
    let Trimmed {
        mut groups,
        last_t,
        stale,
        stale_topics,
    } = trim_to_span(c.builders, t0, t_end);
    let mut notes: Vec<String> = stale_note(stale, stale_topics).into_iter().collect();
    groups.sort_by(|a, b| a.name.cmp(&b.name));
    notes.extend(reading_notes(completeness, last_t, c.short, c.dropouts_ms));
    let log = Log {
        source,
        format: LogFormat::Ulog,
        groups,
        notes,
        settings: c.settings,
        clock_origin_s: t0 as f64 * 1e-6,
    };
    super::check_not_empty(&log)?;
    Ok(log)
}

/// The parser's message without the Rust `Debug` dump of its internal structures that some of its
/// errors carry (`... FlattenedFormat { message_name: "rate", fields: [...] }`): the reader of an
/// error wants what is wrong with the file, not the parser's data structures.
fn readable(msg: &str) -> String {
    let b = msg.as_bytes();
    let cut = (0..b.len()).find(|&i| {
        b[i].is_ascii_uppercase()
            && (i == 0 || !b[i - 1].is_ascii_alphanumeric())
            && msg[i..]
                .find(|c: char| !c.is_ascii_alphanumeric())
                .is_some_and(|n| msg[i + n..].starts_with(" {") || msg[i + n..].starts_with(" ["))
    });
    let head = cut
        .map_or(msg, |i| &msg[..i])
        .trim_end_matches([' ', ':', '(', ','])
        .trim();
    if head.is_empty() {
        "malformed message definitions".into()
    } else if cut.is_some() {
        format!("{head} (malformed message definitions)")
    } else {
        head.to_string()
    }
}

#[cfg(test)]
mod readable_tests {
    use super::readable;

    #[test]
    fn debug_dumps_are_cut_from_parser_messages() {
        let m = readable(
            r#"unknown format for nested type: FlattenedFormat { message_name: "rate", fields: [FlattenedField { name: "x" }] }"#,
        );
        assert_eq!(m, "unknown format for nested type (malformed message definitions)");
        assert_eq!(readable("unexpected end of data"), "unexpected end of data");
        assert_eq!(readable("Format { a: 1 }"), "malformed message definitions");
    }
}
