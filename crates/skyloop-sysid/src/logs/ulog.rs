//! PX4 ULog logs through the `px4-ulog` crate's streaming parser, decoding every numeric field to f64.
//!
//! A log cut off mid-record or with a corrupt record keeps its valid prefix and gets a note; a log
//! whose header or definitions cannot be parsed is refused with the parser's reason.

use std::collections::HashMap;
use std::path::Path;

use px4_ulog::stream_parser::model::{DataMessage, FlattenedFieldType};
use px4_ulog::stream_parser::{read_file_with_simple_callback, Message, SimpleCallbackResult};

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

/// Reads a ULog file.
pub fn read_path(path: &Path) -> Result<Log> {
    let source = path.display().to_string();
    let path_str = path
        .to_str()
        .ok_or_else(|| SysidError::Io(format!("{source}: path is not UTF-8")))?;
    let mut by_key: HashMap<(String, u8), usize> = HashMap::new();
    let mut by_msg_id: HashMap<u16, usize> = HashMap::new();
    let mut builders: Vec<Builder> = Vec::new();
    let mut short = 0usize;
    let mut dropouts_ms = 0u64;
    let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        read_file_with_simple_callback(path_str, &mut |m: &Message| {
            match m {
                Message::Data(msg) => {
                    let idx = *by_msg_id.entry(msg.msg_id).or_insert_with(|| {
                        let key = (msg.flattened_format.message_name.clone(), msg.multi_id.value());
                        *by_key.entry(key).or_insert_with(|| {
                            builders.push(Builder::new(msg));
                            builders.len() - 1
                        })
                    });
                    if !builders[idx].push(msg) {
                        short += 1;
                    }
                }
                Message::DropoutMessage(d) => dropouts_ms += d.duration_ms as u64,
                _ => {}
            }
            SimpleCallbackResult::KeepReading
        })
    }));
    let completeness = match run {
        Ok(Ok(c)) => c,
        Ok(Err(e)) => return Err(SysidError::Log(format!("{source}: not a readable ULog file: {e}"))),
        Err(_) => {
            return Err(SysidError::Log(format!(
                "{source}: the ULog parser failed on corrupt data"
            )))
        }
    };
    // Topics that were never published are logged with time stamp 0: leave them out of the time origin.
    let t0 = builders
        .iter()
        .filter_map(|b| b.time_us.iter().filter(|&&t| t > 0).min())
        .min()
        .copied()
        .unwrap_or(0);
    let mut notes = Vec::new();
    let mut groups = Vec::with_capacity(builders.len());
    let mut last_t = 0.0f64;
    let mut multi_topics: HashMap<String, u8> = HashMap::new();
    for b in &builders {
        let e = multi_topics.entry(b.name.clone()).or_insert(0);
        *e = (*e).max(b.multi);
    }
    for b in builders {
        if b.time_us.is_empty() {
            continue;
        }
        let time_s: Vec<f64> = b
            .time_us
            .iter()
            .map(|&t| (t.saturating_sub(t0)) as f64 * 1e-6)
            .collect();
        last_t = last_t.max(time_s.iter().copied().fold(0.0, f64::max));
        let name = if b.multi == 0 {
            b.name.clone()
        } else {
            format!("{}[{}]", b.name, b.multi)
        };
        let channels = b
            .names
            .into_iter()
            .zip(b.cols)
            .map(|(name, values)| Channel { name, values })
            .collect();
        groups.push(Group {
            prefix: Some(name.clone()),
            name,
            time_s,
            channels,
        });
    }
    groups.sort_by(|a, b| a.name.cmp(&b.name));
    match completeness {
        px4_ulog::full_parser::Completeness::Complete => {}
        px4_ulog::full_parser::Completeness::Truncated => {
            notes.push(format!("log truncated mid-record: data read up to {last_t:.3} s"))
        }
        px4_ulog::full_parser::Completeness::MalformedRecord(r) => notes.push(format!(
            "corrupt record after {last_t:.3} s ({r}); data before it was kept"
        )),
    }
    if short > 0 {
        notes.push(format!("{short} data messages shorter than their format were skipped"));
    }
    if dropouts_ms > 0 {
        notes.push(format!("the logger reported {dropouts_ms} ms of dropouts"));
    }
    let log = Log {
        source,
        format: LogFormat::Ulog,
        groups,
        notes,
    };
    super::check_not_empty(&log)?;
    Ok(log)
}
