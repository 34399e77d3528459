//! Betaflight blackbox logs (also INAV and EmuFlight, which share the format), decoded by skyloop's own
//! reader from the format's documentation: [`header`] reads a session's text header, [`decode`] its
//! frames with [`encoding`] and [`predictor`]. A file may hold several sessions (one per arming); each
//! is decoded on its own, and one that cannot be decoded is reported, not guessed at.
//!
//! Damage is never trusted: a frame that does not decode cleanly, is too long, is not followed by a
//! frame marker or jumps in time is dropped and counted, and decoding resynchronises at the next frame
//! marker; P-frames are only decoded from an intact history. The counts appear in [`Log::notes`].
//!
//! Firmware differences handled from the headers: Betaflight 3.x and INAV write `P interval` as
//! `num/denom`, Betaflight 4.x as the denominator alone (with `P ratio`); `motor[0]` is predicted from
//! `minthrottle` (predictor 4, 3.x, INAV) or from `motorOutput` (predictor 11, 4.x); battery voltage
//! is in 0.01 V from Betaflight 4.0 and in INAV, 0.1 V in Betaflight 3.1 to 3.5, ADC counts before.
//! EmuFlight writes Betaflight's layout. Event frames are understood for sync beep, in-flight
//! adjustment, logging resume, disarm, flight mode, IMU failure and log end; any other event byte is treated as
//! damage (resynchronised and counted), since its length is unknown.

pub mod decode;
pub mod encoding;
pub mod header;
pub mod predictor;

use self::decode::{Decoded, End, Rows};
use self::header::{Firmware, Header, HeaderError};
use super::{Channel, Group, Log, LogFormat};
use crate::error::{Result, SysidError};

/// What one session of a blackbox file holds.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SessionSummary {
    /// Session number, counted from 1 as Betaflight's Blackbox Explorer does.
    pub index: usize,
    /// Firmware string, e.g. "Betaflight 4.2.0 (...)", when the headers parsed.
    pub firmware: String,
    /// Why the session cannot be used; `None` when it decoded.
    pub error: Option<String>,
    /// Number of main frames decoded.
    pub main_frames: usize,
    /// First to last main frame, s.
    pub duration_s: f64,
    /// Median main-frame rate, Hz.
    pub rate_hz: f64,
}

/// One session decoded to the integers the firmware logged.
#[derive(Debug, Clone, PartialEq)]
pub struct RawSession {
    /// Session number, from 1.
    pub index: usize,
    /// Its header.
    pub header: Header,
    /// Its frames and the damage met.
    pub decoded: Decoded,
}

/// Number of sessions (log-start markers) in a blackbox file.
pub fn session_count(bytes: &[u8]) -> usize {
    header::session_starts(bytes).len()
}

/// Decodes session `number` (1-based) to integers. Errors name the file and session: no such
/// session, headers that cannot be used.
pub fn decode_session(bytes: &[u8], number: usize, source: &str) -> Result<RawSession> {
    let starts = header::session_starts(bytes);
    if number == 0 || number > starts.len() {
        return Err(SysidError::Log(format!(
            "{source}: no session {number} (the file holds {} sessions, numbered from 1)",
            starts.len()
        )));
    }
    let begin = starts[number - 1];
    let end = starts.get(number).copied().unwrap_or(bytes.len());
    let session = &bytes[begin..end];
    let header = header::parse(session).map_err(|e| match e {
        HeaderError::Truncated => SysidError::Log(format!(
            "{source}: session {number} ends inside its headers ({} bytes from the session start)",
            session.len()
        )),
        HeaderError::Invalid(why) => SysidError::Log(format!("{source}: session {number} has unusable headers: {why}")),
    })?;
    let decoded = decode::decode(&header, &session[header.data_start.min(session.len())..]);
    Ok(RawSession {
        index: number,
        header,
        decoded,
    })
}

/// How a field's integers become the units [`Channel`] documents.
#[derive(Clone, Copy)]
enum Scale {
    Times(f64),
    // Dividing keeps decimal steps exact (50.397491°, not 50.397490999999995°).
    Over(f64),
}

fn scale_of(name: &str, h: &Header) -> Option<Scale> {
    let base = name.split('[').next().unwrap_or(name);
    match base {
        // Betaflight and INAV log the gyro in deg/s times the gyro_scale float (1.0 on Betaflight 4).
        "gyroADC" => Some(Scale::Times(h.gyro_scale)),
        "accSmooth" => h.acc_1g.map(Scale::Over),
        "vbatLatest" | "vbat" => match h.firmware {
            Firmware::Betaflight(major, _) if major >= 4 => Some(Scale::Over(100.0)),
            Firmware::Inav(_) | Firmware::EmuFlight(..) => Some(Scale::Over(100.0)),
            Firmware::Betaflight(3, minor) if minor >= 1 => Some(Scale::Over(10.0)),
            // Older firmware logs ADC counts: 3.3 V reference, 12 bits, vbatscale in 1/10 mV steps.
            _ => h.vbat_scale.map(|s| Scale::Times(3.3 * s / 4095.0 / 10.0)),
        },
        "amperageLatest" => Some(Scale::Over(100.0)),
        "GPS_coord" => Some(Scale::Over(1e7)),
        "GPS_speed" => Some(Scale::Over(100.0)),
        "GPS_ground_course" => Some(Scale::Over(10.0)),
        _ => None,
    }
}

fn group_of(name: &str, rows: &Rows, defs: &[header::FieldDef], h: &Header, t0: i64) -> Option<Group> {
    if rows.is_empty() || rows.width == 0 {
        return None;
    }
    let n = rows.len();
    // `time` is the group's time vector, not a channel.
    let channels = defs
        .iter()
        .enumerate()
        .filter(|(_, f)| f.name != "time")
        .map(|(j, f)| {
            let k = scale_of(&f.name, h);
            let values = (0..n)
                .map(|i| {
                    let v = rows.values[i * rows.width + j] as f64;
                    match k {
                        Some(Scale::Times(k)) => v * k,
                        Some(Scale::Over(k)) => v / k,
                        None => v,
                    }
                })
                .collect();
            Channel {
                name: f.name.clone(),
                values,
            }
        })
        .collect();
    Some(Group {
        name: name.to_string(),
        prefix: None,
        time_s: rows.time_us.iter().map(|&t| t.wrapping_sub(t0) as f64 * 1e-6).collect(),
        channels,
    })
}

fn notes_of(raw: &RawSession, last_s: f64) -> Vec<String> {
    let s = &raw.decoded.stats;
    let mut notes = Vec::new();
    if s.corrupt > 0 || s.unanchored > 0 || s.implausible > 0 {
        notes.push(format!(
            "damaged data: {} stretches of bytes skipped and decoding resynchronised, {} P-frames dropped for a lost history, {} main frames dropped for implausible iteration or time",
            s.corrupt, s.unanchored, s.implausible
        ));
    }
    if s.gps_without_home > 0 {
        notes.push(format!(
            "{} GPS frames before any GPS home frame were dropped",
            s.gps_without_home
        ));
    }
    if s.resumes > 1 {
        notes.push(format!("logging paused and resumed {} times", s.resumes - 1));
    }
    match s.end {
        End::Truncated => notes.push(format!(
            "log truncated: its last frame is cut off; data read up to {last_s:.3} s"
        )),
        End::Budget => notes.push(format!(
            "decoding stopped at {last_s:.3} s: more values than the file's size allows for a real log"
        )),
        End::LogEnd | End::EndOfData => {}
    }
    notes
}

/// The log of one decoded session: groups `main`, `slow`, `gps`, with time from the first main frame.
fn to_log(raw: &RawSession, source: &str) -> Result<Log> {
    let h = &raw.header;
    let d = &raw.decoded;
    let index = raw.index;
    if d.main.len() < 2 {
        return Err(SysidError::Log(format!(
            "{source}: session {index} holds no decodable main frames (empty or truncated)"
        )));
    }
    let t0 = d.main.time_us[0];
    let groups: Vec<Group> = [
        group_of("main", &d.main, &h.defs.intra, h, t0),
        group_of("slow", &d.slow, &h.defs.slow, h, t0),
        group_of("gps", &d.gps, &h.defs.gps, h, t0),
    ]
    .into_iter()
    .flatten()
    .collect();
    let last_s = d.main.time_us.last().map_or(0.0, |&t| t.wrapping_sub(t0) as f64 * 1e-6);
    Ok(Log {
        source: format!("{source} (session {index})"),
        format: LogFormat::Blackbox,
        groups,
        notes: notes_of(raw, last_s),
        clock_origin_s: t0 as f64 * 1e-6,
        settings: h.lines.iter().map(|(k, v)| (k.clone(), v.trim().to_string())).collect(),
    })
}

fn summary(index: usize, decoded: Result<RawSession>, source: &str) -> (SessionSummary, Option<Log>) {
    let failed = |firmware: String, e: SysidError| SessionSummary {
        index,
        firmware,
        error: Some(e.to_string()),
        main_frames: 0,
        duration_s: 0.0,
        rate_hz: 0.0,
    };
    let raw = match decoded {
        Ok(r) => r,
        Err(e) => return (failed(String::new(), e), None),
    };
    let firmware = raw.header.firmware_revision.clone();
    match to_log(&raw, source) {
        Ok(log) => {
            let t = &log.groups[0].time_s;
            let s = SessionSummary {
                index,
                firmware,
                error: None,
                main_frames: t.len(),
                duration_s: t.last().copied().unwrap_or(0.0),
                rate_hz: super::median_rate_hz(t),
            };
            (s, Some(log))
        }
        Err(e) => (failed(firmware, e), None),
    }
}

/// Summaries of every session in a blackbox file.
pub fn sessions(bytes: &[u8], source: &str) -> Vec<SessionSummary> {
    (1..=session_count(bytes))
        .map(|i| summary(i, decode_session(bytes, i, source), source).0)
        .collect()
}

/// Reads session `session` (1-based) of a blackbox file, or when `None` the session with the most main
/// frames.
pub fn read_bytes(bytes: &[u8], source: &str, session: Option<usize>) -> Result<Log> {
    if let Some(i) = session {
        return decode_session(bytes, i, source).and_then(|raw| to_log(&raw, source));
    }
    let count = session_count(bytes);
    if count == 0 {
        return Err(SysidError::Log(format!("{source}: no blackbox session found")));
    }
    // (main frames, session number, log) of the longest session so far.
    let mut best: Option<(usize, usize, Log)> = None;
    let mut bad = 0;
    let mut first_problem = None;
    for i in 1..=count {
        let (s, log) = summary(i, decode_session(bytes, i, source), source);
        match log {
            Some(log) if best.as_ref().is_none_or(|(n, _, _)| s.main_frames > *n) => {
                best = Some((s.main_frames, i, log))
            }
            Some(_) => {}
            None => {
                bad += 1;
                first_problem = first_problem.or(s.error);
            }
        }
    }
    match best {
        Some((_, chosen, mut log)) => {
            if count > 1 {
                log.notes.push(format!(
                    "file holds {count} sessions ({bad} not decodable); using session {chosen}, the longest (choose with --session)"
                ));
            }
            Ok(log)
        }
        None => Err(SysidError::Log(format!(
            "{source}: none of its {count} sessions could be decoded (first problem: {})",
            first_problem.unwrap_or_default()
        ))),
    }
}
