//! The frame loop of one session: frames are read in order, each checked before it is trusted, and
//! decoding resynchronises on the next frame marker after damage.
//!
//! A frame is trusted only when (as Betaflight's log viewer checks) it decodes without running out of
//! data, is at most [`MAX_FRAME_LEN`] bytes long, and is followed by a frame marker or the end of the
//! data. A main frame must also move `loopIteration` forward by less than [`MAX_ITERATION_JUMP`] and
//! `time` forward by less than [`MAX_TIME_JUMP_US`] from the last trusted main frame (or the last
//! logging-resume event). A P-frame is decoded only while the history it is predicted from is intact,
//! that is since a trusted I-frame with no damage in between. Anything else is counted in [`Stats`] and
//! dropped; decoding goes on at the next byte that can start a frame.

use super::encoding::{group_size, id as enc, Cursor, Malformed};
use super::header::{FieldDef, Header};
use super::predictor::{self, id as pred, Context, Missing};

/// Longest frame a trusted frame may be, bytes (the viewer's limit).
pub const MAX_FRAME_LEN: usize = 256;
/// Largest forward step of `loopIteration` between main frames.
pub const MAX_ITERATION_JUMP: i64 = 5000;
/// Largest forward step of `time` between main frames, µs.
pub const MAX_TIME_JUMP_US: i64 = 10_000_000;

/// Event numbers of `E` frames.
mod event {
    pub const SYNC_BEEP: u8 = 0;
    pub const INFLIGHT_ADJUSTMENT: u8 = 13;
    pub const LOGGING_RESUME: u8 = 14;
    pub const DISARM: u8 = 15;
    pub const FLIGHT_MODE: u8 = 30;
    pub const IMU_FAILURE: u8 = 40;
    pub const LOG_END: u8 = 255;
}

/// Decoded frames of one kind, row after row.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Rows {
    /// Fields per row.
    pub width: usize,
    /// Row-major values as the firmware's 32-bit fields hold them (unsigned fields ≥ 0).
    pub values: Vec<i64>,
    /// Time of each row, µs on the flight controller's clock (for slow frames: the last main frame's).
    pub time_us: Vec<i64>,
}

impl Rows {
    fn new(width: usize) -> Rows {
        Rows {
            width,
            ..Rows::default()
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time_us.len()
    }

    /// True when there are no rows.
    pub fn is_empty(&self) -> bool {
        self.time_us.is_empty()
    }

    /// Row `i`.
    pub fn row(&self, i: usize) -> &[i64] {
        &self.values[i * self.width..(i + 1) * self.width]
    }

    fn push(&mut self, t: i64, row: &[i64]) {
        self.time_us.push(t);
        self.values.extend_from_slice(row);
    }
}

/// How decoding of a session ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// At the log-end event.
    LogEnd,
    /// At the end of the session's data, between frames.
    EndOfData,
    /// The last frame was cut off by the end of the data.
    Truncated,
    /// The decoded-value budget (a multiple of the input size) ran out: hostile or broken input.
    Budget,
}

/// What decoding a session met.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stats {
    /// Places where bytes did not form a trusted frame (each resynchronisation counts once).
    pub corrupt: usize,
    /// P-frames dropped because the frames they are predicted from were lost.
    pub unanchored: usize,
    /// Main frames that decoded but jumped in iteration or time.
    pub implausible: usize,
    /// GPS frames dropped because no GPS home frame preceded them.
    pub gps_without_home: usize,
    /// Logging-resume events (the firmware paused logging and went on).
    pub resumes: usize,
    /// How decoding ended.
    pub end: End,
}

/// Everything decoded from one session.
#[derive(Debug, Clone, PartialEq)]
pub struct Decoded {
    /// I- and P-frames, in the I-frame field order.
    pub main: Rows,
    /// `true` for rows that came from an I-frame.
    pub main_is_intra: Vec<bool>,
    /// Slow (`S`) frames.
    pub slow: Rows,
    /// GPS (`G`) frames.
    pub gps: Rows,
    /// Damage and how decoding ended.
    pub stats: Stats,
}

/// Why a frame's bytes are not trusted.
enum Bad {
    /// Ran out of data inside the frame.
    Truncated,
    /// Not a frame: resynchronise.
    Corrupt,
}

impl From<Malformed> for Bad {
    fn from(m: Malformed) -> Bad {
        match m {
            Malformed::Truncated => Bad::Truncated,
            Malformed::TooLong => Bad::Corrupt,
        }
    }
}

/// Reads the encoded (not yet predicted) values of one frame into `out`.
fn read_raw(c: &mut Cursor<'_>, defs: &[FieldDef], out: &mut Vec<i64>) -> Result<(), Bad> {
    let n = defs.len();
    out.clear();
    out.resize(n, 0);
    let mut i = 0;
    while i < n {
        let e = defs[i].encoding;
        match e {
            enc::SIGNED_VB => out[i] = i64::from(c.signed_vb()?),
            enc::UNSIGNED_VB => out[i] = i64::from(c.unsigned_vb()?),
            enc::NEG_14BIT => out[i] = i64::from(c.neg_14bit()?),
            enc::NULL => out[i] = 0,
            enc::TAG8_8SVB => {
                let run = defs[i..]
                    .iter()
                    .take(8)
                    .take_while(|f| f.encoding == enc::TAG8_8SVB)
                    .count();
                let k = group_size(e, run);
                c.tag8_8svb(&mut out[i..i + k], k)?;
                i += k;
                continue;
            }
            enc::TAG2_3S32 | enc::TAG2_3SVARIABLE => {
                // The group always holds the next three fields, whatever their own encodings say.
                let mut v = [0i64; 3];
                if e == enc::TAG2_3S32 {
                    c.tag2_3s32(&mut v)?;
                } else {
                    c.tag2_3svariable(&mut v)?;
                }
                let k = 3.min(n - i);
                out[i..i + k].copy_from_slice(&v[..k]);
                i += 3;
                continue;
            }
            enc::TAG8_4S16 => {
                let mut v = [0i64; 4];
                c.tag8_4s16(&mut v)?;
                let k = 4.min(n - i);
                out[i..i + k].copy_from_slice(&v[..k]);
                i += 4;
                continue;
            }
            // The header check refuses every other encoding.
            _ => return Err(Bad::Corrupt),
        }
        i += 1;
    }
    Ok(())
}

/// Adds the predictions to `raw` in field order (later fields may depend on earlier ones).
fn apply_predictors(defs: &[FieldDef], raw: &mut [i64], ctx: &Context<'_>) -> Result<(), Missing> {
    let mut home_slot = 0;
    for i in 0..defs.len() {
        let p = defs[i].predictor;
        let base = if p == pred::ZERO {
            0
        } else {
            predictor::predict(p, i, &raw[..i], home_slot, ctx)?
        };
        if p == pred::HOME_COORD {
            home_slot += 1;
        }
        raw[i] = predictor::to_field_width(raw[i].wrapping_add(base), defs[i].signed);
    }
    Ok(())
}

/// Parses an event frame's payload; `Ok(Some((iteration, time)))` for a logging-resume event,
/// `Err(true)` for the log end.
fn read_event(c: &mut Cursor<'_>) -> Result<Option<(i64, i64)>, EventEnd> {
    let kind = c.byte().map_err(|_| EventEnd::Bad(Bad::Truncated))?;
    let m = |e: Malformed| EventEnd::Bad(e.into());
    match kind {
        event::SYNC_BEEP | event::DISARM | event::IMU_FAILURE => {
            c.unsigned_vb().map_err(m)?;
        }
        event::FLIGHT_MODE => {
            c.unsigned_vb().map_err(m)?;
            c.unsigned_vb().map_err(m)?;
        }
        event::INFLIGHT_ADJUSTMENT => {
            let func = c.byte().map_err(|_| EventEnd::Bad(Bad::Truncated))?;
            if func & 0x80 != 0 {
                c.bytes(4).map_err(|_| EventEnd::Bad(Bad::Truncated))?;
            } else {
                c.signed_vb().map_err(m)?;
            }
        }
        event::LOGGING_RESUME => {
            let iteration = i64::from(c.unsigned_vb().map_err(m)?);
            let time = i64::from(c.unsigned_vb().map_err(m)?);
            return Ok(Some((iteration, time)));
        }
        event::LOG_END => {
            let text = c.bytes(10).map_err(|_| EventEnd::Bad(Bad::Truncated))?;
            return Err(if text == b"End of log" {
                EventEnd::LogEnd
            } else {
                EventEnd::Bad(Bad::Corrupt)
            });
        }
        _ => return Err(EventEnd::Bad(Bad::Corrupt)),
    }
    Ok(None)
}

enum EventEnd {
    LogEnd,
    Bad(Bad),
}

/// The last trusted point of the main-frame timeline.
#[derive(Clone, Copy)]
struct Anchor {
    iteration: i64,
    time: i64,
    /// After a logging-resume event the next I-frame may repeat its iteration and time.
    inclusive: bool,
}

impl Anchor {
    fn admits(&self, iteration: i64, time: i64) -> bool {
        let (di, dt) = (iteration.wrapping_sub(self.iteration), time.wrapping_sub(self.time));
        let forward = if self.inclusive {
            di >= 0 && dt >= 0
        } else {
            di > 0 && dt > 0
        };
        forward && di < MAX_ITERATION_JUMP && dt < MAX_TIME_JUMP_US
    }
}

/// The predictor context of a slow (S), home (H) or GPS (G) frame: no frame skipping and no motors;
/// `prev` is that frame kind's own previous frame (GPS only).
fn side_context<'a>(h: &Header, prev: Option<&'a [i64]>, last_main_time: i64, home: Option<[i64; 2]>) -> Context<'a> {
    Context {
        prev,
        prev2: prev,
        skipped: 0,
        minthrottle: h.minthrottle,
        min_motor: h.min_motor,
        vbatref: h.vbatref,
        last_main_time,
        motor0: None,
        home,
    }
}

/// Decodes the frames of `data` (one session, after its header).
pub fn decode(h: &Header, data: &[u8]) -> Decoded {
    let defs = &h.defs;
    let idx = |name: &str| defs.intra.iter().position(|f| f.name == name);
    let (it_i, time_i) = (idx("loopIteration").unwrap_or(0), idx("time").unwrap_or(0));
    let motor0 = idx("motor[0]");
    let gps_time = defs.gps.iter().position(|f| f.name == "time");
    let mut main = Rows::new(defs.intra.len());
    let mut main_is_intra = Vec::new();
    let mut slow = Rows::new(defs.slow.len());
    let mut gps = Rows::new(defs.gps.len());
    let mut stats = Stats {
        corrupt: 0,
        unanchored: 0,
        implausible: 0,
        gps_without_home: 0,
        resumes: 0,
        end: End::EndOfData,
    };
    // Bounded work and memory on hostile input: real logs hold well under 4 values per byte.
    let budget = data.len().saturating_mul(8).max(1 << 16);
    let mut stored = 0usize;

    let mut prev: Option<Vec<i64>> = None;
    let mut prev2: Option<Vec<i64>> = None;
    let mut history_ok = false;
    let mut anchor: Option<Anchor> = None;
    // A rejected I-frame; a second one consistent with it starts a new timeline (a real gap).
    let mut rejected_i: Option<Anchor> = None;
    let mut last_main_time: i64 = 0;
    let mut home: Option<[i64; 2]> = None;
    let mut gps_prev: Option<Vec<i64>> = None;
    let mut slow_pending: Option<Vec<i64>> = None;
    let mut in_damage = false;
    let mut raw = Vec::new();

    let is_marker = |b: u8| match b {
        b'I' | b'E' => true,
        b'P' => !defs.inter.is_empty(),
        b'S' => !defs.slow.is_empty(),
        b'G' => !defs.gps.is_empty(),
        b'H' => !defs.home.is_empty(),
        _ => false,
    };

    let mut pos = 0usize;
    while pos < data.len() {
        let marker = data[pos];
        if !is_marker(marker) {
            if !in_damage {
                stats.corrupt += 1;
                in_damage = true;
                history_ok = false;
            }
            pos += 1;
            continue;
        }
        let start = pos;
        // A trusted frame is at most MAX_FRAME_LEN bytes, so no read needs to look further: this
        // bounds the work spent at each candidate marker while resynchronising through damage.
        let window = data.len().min(start + MAX_FRAME_LEN + 1);
        let cut_by_window = window < data.len();
        let mut c = Cursor::new(&data[..window], pos + 1);
        let frame_defs: &[FieldDef] = match marker {
            b'I' => &defs.intra,
            b'P' => &defs.inter,
            b'S' => &defs.slow,
            b'G' => &defs.gps,
            b'H' => &defs.home,
            _ => &[],
        };
        let mut resume = None;
        let mut log_end = false;
        let parsed = if marker == b'E' {
            match read_event(&mut c) {
                Ok(r) => {
                    resume = r;
                    Ok(())
                }
                Err(EventEnd::LogEnd) => {
                    log_end = true;
                    Ok(())
                }
                Err(EventEnd::Bad(b)) => Err(b),
            }
        } else {
            read_raw(&mut c, frame_defs, &mut raw)
        };
        let end = c.pos();
        let framed = match parsed {
            Err(Bad::Truncated) if cut_by_window => false,
            Err(Bad::Truncated) => {
                stats.end = End::Truncated;
                break;
            }
            Err(Bad::Corrupt) => false,
            Ok(()) => end - start <= MAX_FRAME_LEN && (log_end || end >= data.len() || is_marker(data[end])),
        };
        if !framed {
            // Not a frame after all: look for the next marker from the byte after this one.
            if !in_damage {
                stats.corrupt += 1;
                in_damage = true;
            }
            history_ok = false;
            pos = start + 1;
            continue;
        }
        in_damage = false;
        pos = end;
        if log_end {
            stats.end = End::LogEnd;
            break;
        }
        if let Some((iteration, time)) = resume {
            stats.resumes += 1;
            anchor = Some(Anchor {
                iteration,
                time,
                inclusive: true,
            });
            continue;
        }
        if stored.saturating_add(raw.len()) > budget {
            stats.end = End::Budget;
            break;
        }
        match marker {
            b'I' | b'P' => {
                let intra = marker == b'I';
                if !intra && !history_ok {
                    stats.unanchored += 1;
                    continue;
                }
                let skipped = match (intra, anchor) {
                    (false, Some(a)) => h.skipped_after(a.iteration),
                    _ => 0,
                };
                let ctx = Context {
                    prev: if intra { None } else { prev.as_deref() },
                    prev2: if intra { None } else { prev2.as_deref() },
                    skipped,
                    minthrottle: h.minthrottle,
                    min_motor: h.min_motor,
                    vbatref: h.vbatref,
                    last_main_time,
                    motor0,
                    home,
                };
                if apply_predictors(frame_defs, &mut raw, &ctx).is_err() {
                    stats.corrupt += 1;
                    history_ok = false;
                    continue;
                }
                let here = Anchor {
                    iteration: raw[it_i],
                    time: raw[time_i],
                    inclusive: false,
                };
                let ok = anchor.is_none_or(|a| a.admits(here.iteration, here.time));
                // Two consecutive I-frames consistent with each other but not with the anchor: the
                // timeline really moved (a gap without a resume event); follow it.
                let restart = !ok && intra && rejected_i.is_some_and(|r| r.admits(here.iteration, here.time));
                if !ok && !restart {
                    stats.implausible += 1;
                    history_ok = false;
                    if intra {
                        rejected_i = Some(here);
                    }
                    continue;
                }
                rejected_i = None;
                anchor = Some(here);
                last_main_time = here.time;
                history_ok = true;
                if intra {
                    prev2 = Some(raw.clone());
                    prev = Some(raw.clone());
                } else {
                    prev2 = prev.take();
                    prev = Some(raw.clone());
                }
                main.push(here.time, &raw);
                main_is_intra.push(intra);
                stored += raw.len();
                if let Some(s) = slow_pending.take() {
                    slow.push(here.time, &s);
                    stored += s.len();
                }
            }
            b'S' => {
                let ctx = side_context(h, None, last_main_time, home);
                if apply_predictors(frame_defs, &mut raw, &ctx).is_err() {
                    stats.corrupt += 1;
                    continue;
                }
                if main.is_empty() {
                    // Shown from the first main frame on.
                    slow_pending = Some(raw.clone());
                } else {
                    slow.push(last_main_time, &raw);
                    stored += raw.len();
                }
            }
            b'H' => {
                let ctx = side_context(h, None, last_main_time, None);
                if apply_predictors(frame_defs, &mut raw, &ctx).is_ok() && raw.len() >= 2 {
                    home = Some([raw[0], raw[1]]);
                }
            }
            b'G' => {
                let ctx = side_context(h, gps_prev.as_deref(), last_main_time, home);
                match apply_predictors(frame_defs, &mut raw, &ctx) {
                    Ok(()) => {
                        let t = gps_time.map_or(last_main_time, |i| raw[i]);
                        gps.push(t, &raw);
                        stored += raw.len();
                        gps_prev = Some(raw.clone());
                    }
                    Err(Missing::Home) => stats.gps_without_home += 1,
                    Err(Missing::Motor0) => stats.corrupt += 1,
                }
            }
            _ => {}
        }
    }
    Decoded {
        main,
        main_is_intra,
        slow,
        gps,
        stats,
    }
}
