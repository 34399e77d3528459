//! ArduPilot DataFlash (`.bin`) logs, read from ArduPilot's documentation of the format.
//!
//! Every message is `0xA3 0x95 <type u8>` followed by a payload laid out by that type's FMT
//! message (type 128: type u8, length u8 of the whole message, name char\[4\], format char\[16\],
//! labels char\[64\]). The format characters and their scaling are in the `fields` module; in short, values
//! are as logged except `c C e E` (÷100) and `L` (latitude/longitude, ÷1e7, degrees), the scaling
//! the format letter itself states. The FMTU/MULT multipliers are **not** applied (pymavlink does
//! not apply them either, and the values then match its output): a field whose FMTU multiplier is,
//! say, 1e-2 stays in the logged integer units.
//!
//! Groups and channels:
//! - one group per message type, named by the FMT name (`RATE`, `PIDR`, ...), with the numeric
//!   fields as channels (`RATE.RDes`); text fields (`n N Z`) are not channels; an `a` field
//!   (int16\[32\]) gives `Name[0]`..`Name[31]`;
//! - a type whose FMTU unit string marks an instance field with `#` (IMU's `I`, BARO's `I`, ...)
//!   gives one group per instance: `IMU` for instance 0 and `IMU[1]` for instance 1, as the ULog
//!   reader names multi-instance topics (`SCR[name]` for a text instance);
//! - time: the message's `TimeUS` (or an old log's `TimeMS`), s. `Group::time_s` counts from the
//!   earliest time stamp in the log and [`Log::clock_origin_s`] is that stamp, so `time_s +
//!   clock_origin_s` is `TimeUS` / 10⁶. Messages without a time stamp (FMT, FILE, replay messages)
//!   give no group; a note counts them.
//!
//! Settings: every PARM message as (`Name`, `Value` as text; the last one wins in
//! [`Log::setting`]), plus `Firmware revision` (the MSG banner such as "ArduCopter V4.5.7
//! (2a3dc4b7)", else VER's `FWS`) and `Frame` (from MSG "Frame: QUAD/X").
//!
//! Robustness: bytes that do not start a message of a defined type are skipped to the next
//! `0xA3 0x95` (counted in a note); a message running past the end of the file ends the read with a
//! note; a type whose format has an unknown character or disagrees with its FMT length is skipped
//! with a note; a type redefined by a later, different FMT keeps its first definition and its
//! messages after the redefinition are skipped (framing follows the new length). A file without any
//! FMT message is refused. Memory grows with the file only: no allocation is sized by a length read
//! from the file (a message is at most 255 bytes).

pub(crate) mod decode;
pub(crate) mod fields;
pub(crate) mod frame;

use std::path::Path;

use super::{Channel, Group, Log, LogFormat};
use crate::error::{Result, SysidError};
use decode::{definitions, Decoder};
use frame::Framer;

pub use frame::{FMT_LEN, FMT_TYPE, HEAD};

/// Whether `bytes` start like a DataFlash log (the message header's sync bytes).
pub fn looks_like_dataflash(bytes: &[u8]) -> bool {
    bytes.starts_with(&HEAD)
}

/// Reads a DataFlash file.
///
/// # Errors
/// The file cannot be read, or see [`read_bytes`].
pub fn read_path(path: &Path) -> Result<Log> {
    let source = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| SysidError::Io(format!("cannot read {source}: {e}")))?;
    read_bytes(&bytes, &source)
}

/// Reads a DataFlash file's bytes; `source` names it in messages.
///
/// # Errors
/// No FMT message ("not a DataFlash log"), or no message with a time stamp.
pub fn read_bytes(bytes: &[u8], source: &str) -> Result<Log> {
    let (types, fmts) = definitions(bytes);
    if fmts == 0 {
        return Err(SysidError::Log(format!(
            "{source}: not a DataFlash log: no FMT message (0xA3 0x95 0x80) that defines the message formats"
        )));
    }
    let mut dec = Decoder::new(types);
    let mut framer = Framer::new(bytes);
    for f in framer.by_ref() {
        dec.on_frame(f);
    }
    let t0 = dec.builders.iter().flat_map(|b| b.time_us.iter().copied()).min();
    let Some(t0) = t0 else {
        return Err(SysidError::Log(format!(
            "{source}: a DataFlash log without any time-stamped message (no TimeUS field with data)"
        )));
    };
    let mut notes = Vec::new();
    let mut groups: Vec<Group> = Vec::with_capacity(dec.builders.len());
    let mut last_s = 0.0f64;
    for b in std::mem::take(&mut dec.builders) {
        let time_s: Vec<f64> = b.time_us.iter().map(|&t| (t - t0) as f64 * 1e-6).collect();
        last_s = time_s.iter().copied().fold(last_s, f64::max);
        let channels = b
            .channel_names
            .into_iter()
            .zip(b.cols)
            .map(|(name, values)| Channel { name, values })
            .collect();
        groups.push(Group {
            prefix: Some(b.name.clone()),
            name: b.name,
            time_s,
            channels,
        });
    }
    groups.sort_by(|a, b| a.name.cmp(&b.name));
    notes.extend(read_notes(&dec, &framer, last_s));
    let log = Log {
        source: source.to_string(),
        format: LogFormat::Dataflash,
        groups,
        notes,
        settings: dec.settings,
        clock_origin_s: t0 as f64 * 1e-6,
    };
    super::check_not_empty(&log)?;
    Ok(log)
}

fn counted(list: &[(String, usize)]) -> String {
    let mut parts: Vec<String> = list.iter().take(12).map(|(n, c)| format!("{n} ({c})")).collect();
    if list.len() > 12 {
        parts.push(format!("and {} more", list.len() - 12));
    }
    parts.join(", ")
}

/// Notes on what the read left out or where it stopped.
fn read_notes(dec: &Decoder, framer: &Framer<'_>, last_s: f64) -> Vec<String> {
    let mut notes = Vec::new();
    if framer.skipped > 0 {
        notes.push(format!(
            "{} bytes that start no message were skipped (resynchronised on the next 0xA3 0x95)",
            framer.skipped
        ));
    }
    for (name, count, why) in &dec.undecodable {
        notes.push(format!("{count} {name} messages were skipped: {why}"));
    }
    if !dec.redefined.is_empty() {
        notes.push(format!(
            "message types redefined by a later FMT with another layout; their messages after it were skipped: {}",
            counted(&dec.redefined)
        ));
    }
    if dec.dropped_instances > 0 {
        notes.push(format!(
            "{} messages of instances beyond the first {} of their type were skipped",
            dec.dropped_instances,
            decode::MAX_INSTANCES
        ));
    }
    if !dec.untimed.is_empty() {
        notes.push(format!(
            "messages without a TimeUS field are not channels: {}",
            counted(&dec.untimed)
        ));
    }
    if let Some(at) = framer.truncated_at {
        notes.push(format!(
            "log truncated: the message at byte {at} runs past the end of the file; data read up to {last_s:.3} s"
        ));
    }
    notes
}
