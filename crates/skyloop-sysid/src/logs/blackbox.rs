//! Betaflight/INAV blackbox logs through the `blackbox-log` crate. A file may hold several sessions
//! (one per arming); each is decoded on its own, and one that cannot be decoded is reported.

use blackbox_log::frame::{Frame, FrameDef};
use blackbox_log::units::si;
use blackbox_log::{ParserEvent, Value};

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

fn to_f64(v: Value) -> f64 {
    match v {
        Value::Amperage(a) => a.get::<si::electric_current::ampere>(),
        Value::Voltage(u) => u.get::<si::electric_potential::volt>(),
        Value::Acceleration(a) => a.get::<si::acceleration::standard_gravity>(),
        Value::Rotation(r) => r.get::<si::angular_velocity::degree_per_second>(),
        Value::Boolean(b) => b as u8 as f64,
        Value::GpsCoordinate(x) | Value::GpsHeading(x) => x,
        Value::Altitude(h) => h.get::<si::length::meter>(),
        Value::Velocity(v) => v.get::<si::velocity::meter_per_second>(),
        Value::Unsigned(x) => x as f64,
        Value::Signed(x) => x as f64,
        // Flag sets and enums have no numeric meaning beyond their raw bits (handled by the caller).
        Value::FlightMode(_) | Value::State(_) | Value::FailsafePhase(_) => f64::NAN,
    }
}

fn frame_values<F: Frame>(f: &F) -> Vec<f64>
where
    F::Value: Into<Value>,
{
    (0..f.len())
        .map(|i| match f.get(i).map(Into::into) {
            Some(v) => {
                let x = to_f64(v);
                if x.is_nan() {
                    f.get_raw(i).map_or(f64::NAN, |r| r as f64)
                } else {
                    x
                }
            }
            None => f64::NAN,
        })
        .collect()
}

struct Acc {
    names: Vec<String>,
    time_s: Vec<f64>,
    cols: Vec<Vec<f64>>,
}

impl Acc {
    fn new(names: Vec<String>) -> Acc {
        let cols = vec![Vec::new(); names.len()];
        Acc {
            names,
            time_s: Vec::new(),
            cols,
        }
    }
    fn push(&mut self, t: f64, vals: &[f64]) {
        if vals.len() != self.cols.len() {
            return;
        }
        self.time_s.push(t);
        for (c, v) in self.cols.iter_mut().zip(vals) {
            c.push(*v);
        }
    }
    fn into_group(self, name: &str, t0: f64) -> Option<Group> {
        if self.time_s.is_empty() {
            return None;
        }
        let time_s = self.time_s.iter().map(|t| t - t0).collect();
        let channels = self
            .names
            .into_iter()
            .zip(self.cols)
            .map(|(name, values)| Channel { name, values })
            .collect();
        Some(Group {
            name: name.to_string(),
            prefix: None,
            time_s,
            channels,
        })
    }
}

/// Decodes session `number` (1-based, as Blackbox Explorer counts) into groups `main`, `slow`, `gps`.
fn decode_session(bytes: &[u8], number: usize, source: &str) -> Result<(Log, String)> {
    let file = blackbox_log::File::new(bytes);
    let index = number;
    let parsed = if number == 0 { None } else { file.parse(number - 1) };
    let headers = match parsed {
        Some(Ok(h)) => h,
        Some(Err(e)) => {
            return Err(SysidError::Log(format!(
                "{source}: session {index} has unusable headers: {e}"
            )))
        }
        None => {
            return Err(SysidError::Log(format!(
                "{source}: no session {index} (the file holds {} sessions, numbered from 1)",
                file.log_count()
            )))
        }
    };
    let firmware = headers.firmware_revision().to_string();
    let mut parser = headers.data_parser();
    let main_names: Vec<String> = parser.main_frame_def().iter().map(|d| d.name.to_string()).collect();
    let slow_names: Vec<String> = parser.slow_frame_def().iter().map(|d| d.name.to_string()).collect();
    let gps_names: Vec<String> = parser
        .gps_frame_def()
        .map(|d| d.iter().map(|f| f.name.to_string()).collect())
        .unwrap_or_default();
    let (mut main, mut slow, mut gps) = (Acc::new(main_names), Acc::new(slow_names), Acc::new(gps_names));
    let mut last_t = f64::NAN;
    let mut backwards = 0usize;
    while let Some(ev) = parser.next() {
        match ev {
            ParserEvent::Main(f) => {
                let t = f.time_raw() as f64 * 1e-6;
                if last_t.is_finite() && t <= last_t {
                    // A time stamp that does not advance comes from a damaged frame: drop it.
                    backwards += 1;
                    continue;
                }
                last_t = t;
                main.push(t, &frame_values(&f));
            }
            ParserEvent::Slow(f) if last_t.is_finite() => slow.push(last_t, &frame_values(&f)),
            ParserEvent::Gps(f) => gps.push(f.time_raw() as f64 * 1e-6, &frame_values(&f)),
            _ => {}
        }
    }
    let t0 = main.time_s.first().copied().unwrap_or(0.0);
    let mut notes = Vec::new();
    if backwards > 0 {
        notes.push(format!("{backwards} main frames with non-increasing time were dropped"));
    }
    let groups: Vec<Group> = [
        main.into_group("main", t0),
        slow.into_group("slow", t0),
        gps.into_group("gps", t0),
    ]
    .into_iter()
    .flatten()
    .collect();
    if groups.first().map_or(true, |g| g.name != "main" || g.time_s.len() < 2) {
        return Err(SysidError::Log(format!(
            "{source}: session {index} holds no decodable main frames (empty or truncated)"
        )));
    }
    let log = Log {
        source: format!("{source} (session {index})"),
        format: LogFormat::Blackbox,
        groups,
        notes,
    };
    Ok((log, firmware))
}

fn guarded<T>(f: impl FnOnce() -> Result<T>, source: &str) -> Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|_| {
        Err(SysidError::Log(format!(
            "{source}: the blackbox decoder failed on corrupt data"
        )))
    })
}

/// Summaries of every session in a blackbox file.
pub fn sessions(bytes: &[u8], source: &str) -> Vec<SessionSummary> {
    let count = blackbox_log::File::new(bytes).log_count();
    (1..=count)
        .map(|i| match guarded(|| decode_session(bytes, i, source), source) {
            Ok((log, firmware)) => {
                let g = &log.groups[0];
                SessionSummary {
                    index: i,
                    firmware,
                    error: None,
                    main_frames: g.time_s.len(),
                    duration_s: g.time_s.last().copied().unwrap_or(0.0),
                    rate_hz: super::median_rate_hz(&g.time_s),
                }
            }
            Err(e) => SessionSummary {
                index: i,
                firmware: String::new(),
                error: Some(e.to_string()),
                main_frames: 0,
                duration_s: 0.0,
                rate_hz: 0.0,
            },
        })
        .collect()
}

/// Reads session `session` (1-based) of a blackbox file, or when `None` the session with the most main frames.
pub fn read_bytes(bytes: &[u8], source: &str, session: Option<usize>) -> Result<Log> {
    if let Some(i) = session {
        return guarded(|| decode_session(bytes, i, source), source).map(|(l, _)| l);
    }
    let all = sessions(bytes, source);
    if all.is_empty() {
        return Err(SysidError::Log(format!("{source}: no blackbox session found")));
    }
    let best = all.iter().filter(|s| s.error.is_none()).max_by_key(|s| s.main_frames);
    match best {
        Some(s) => {
            let (mut log, _) = guarded(|| decode_session(bytes, s.index, source), source)?;
            let bad = all.iter().filter(|s| s.error.is_some()).count();
            if all.len() > 1 {
                log.notes.push(format!(
                    "file holds {} sessions ({} not decodable); using session {}, the longest (choose with --session)",
                    all.len(),
                    bad,
                    s.index
                ));
            }
            Ok(log)
        }
        None => Err(SysidError::Log(format!(
            "{source}: none of its {} sessions could be decoded (first problem: {})",
            all.len(),
            all[0].error.clone().unwrap_or_default()
        ))),
    }
}
