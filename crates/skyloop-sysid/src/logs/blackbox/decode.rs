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

/// One frame candidate as read, before the check that it is followed by a frame marker.
struct Candidate {
    /// Whether its bytes decoded.
    parsed: Result<(), Bad>,
    /// Offset of the first byte after it.
    end: usize,
    /// Whether the read window stopped short of the end of the data.
    cut_by_window: bool,
    /// Loop iteration and time (µs) of a logging-resume event.
    resume: Option<(i64, i64)>,
    /// Whether it is the log-end event.
    log_end: bool,
}

/// The decoding state of one session: the rows so far and what the next frames are checked against.
struct Decoder<'a> {
    h: &'a Header,
    data: &'a [u8],
    /// Columns of `loopIteration` and `time` in main rows (0 when absent).
    it_i: usize,
    time_i: usize,
    /// Column of `motor[0]` in main rows.
    motor0: Option<usize>,
    /// Column of `time` in GPS rows.
    gps_time: Option<usize>,
    main: Rows,
    main_is_intra: Vec<bool>,
    slow: Rows,
    gps: Rows,
    stats: Stats,
    /// Most values that may be stored.
    budget: usize,
    /// Values stored so far.
    stored: usize,
    prev: Option<Vec<i64>>,
    prev2: Option<Vec<i64>>,
    history_ok: bool,
    anchor: Option<Anchor>,
    /// A rejected I-frame; a second one consistent with it starts a new timeline (a real gap).
    rejected_i: Option<Anchor>,
    /// Time of the last trusted main frame, µs.
    last_main_time: i64,
    home: Option<[i64; 2]>,
    gps_prev: Option<Vec<i64>>,
    slow_pending: Option<Vec<i64>>,
    in_damage: bool,
    /// The current frame's values: encoded after reading, decoded after the predictors.
    raw: Vec<i64>,
}

impl<'a> Decoder<'a> {
    /// An empty decoder for `data`, with the column indices and value budget it needs.
    fn new(h: &'a Header, data: &'a [u8]) -> Decoder<'a> {
        let defs = &h.defs;
        let idx = |name: &str| defs.intra.iter().position(|f| f.name == name);
        Decoder {
            h,
            data,
            it_i: idx("loopIteration").unwrap_or(0),
            time_i: idx("time").unwrap_or(0),
            motor0: idx("motor[0]"),
            gps_time: defs.gps.iter().position(|f| f.name == "time"),
            main: Rows::new(defs.intra.len()),
            main_is_intra: Vec::new(),
            slow: Rows::new(defs.slow.len()),
            gps: Rows::new(defs.gps.len()),
            stats: Stats {
                corrupt: 0,
                unanchored: 0,
                implausible: 0,
                gps_without_home: 0,
                resumes: 0,
                end: End::EndOfData,
            },
            // Bounded work and memory on hostile input: real logs hold well under 4 values per byte.
            budget: data.len().saturating_mul(8).max(1 << 16),
            stored: 0,
            prev: None,
            prev2: None,
            history_ok: false,
            anchor: None,
            rejected_i: None,
            last_main_time: 0,
            home: None,
            gps_prev: None,
            slow_pending: None,
            in_damage: false,
            raw: Vec::new(),
        }
    }

    /// Whether byte `b` can start a frame of a kind this header defines.
    fn is_marker(&self, b: u8) -> bool {
        let defs = &self.h.defs;
        match b {
            b'I' | b'E' => true,
            b'P' => !defs.inter.is_empty(),
            b'S' => !defs.slow.is_empty(),
            b'G' => !defs.gps.is_empty(),
            b'H' => !defs.home.is_empty(),
            _ => false,
        }
    }

    /// The field layout of frames that start with `marker` (empty for events).
    fn frame_defs(&self, marker: u8) -> &'a [FieldDef] {
        let defs = &self.h.defs;
        match marker {
            b'I' => &defs.intra,
            b'P' => &defs.inter,
            b'S' => &defs.slow,
            b'G' => &defs.gps,
            b'H' => &defs.home,
            _ => &[],
        }
    }

    /// Handles the byte at `pos`; the offset to go on at, or `None` when decoding ends.
    fn step(&mut self, pos: usize) -> Option<usize> {
        let data = self.data;
        let marker = data[pos];
        if !self.is_marker(marker) {
            if !self.in_damage {
                self.stats.corrupt += 1;
                self.in_damage = true;
                self.history_ok = false;
            }
            return Some(pos + 1);
        }
        let start = pos;
        let frame = self.read_candidate(marker, start);
        let end = frame.end;
        let framed = match frame.parsed {
            Err(Bad::Truncated) if frame.cut_by_window => false,
            Err(Bad::Truncated) => {
                self.stats.end = End::Truncated;
                return None;
            }
            Err(Bad::Corrupt) => false,
            Ok(()) => end - start <= MAX_FRAME_LEN && (frame.log_end || end >= data.len() || self.is_marker(data[end])),
        };
        if !framed {
            // Not a frame after all: look for the next marker from the byte after this one.
            if !self.in_damage {
                self.stats.corrupt += 1;
                self.in_damage = true;
            }
            self.history_ok = false;
            return Some(start + 1);
        }
        self.in_damage = false;
        if frame.log_end {
            self.stats.end = End::LogEnd;
            return None;
        }
        if let Some((iteration, time)) = frame.resume {
            self.stats.resumes += 1;
            self.anchor = Some(Anchor {
                iteration,
                time,
                inclusive: true,
            });
            return Some(end);
        }
        if self.stored.saturating_add(self.raw.len()) > self.budget {
            self.stats.end = End::Budget;
            return None;
        }
        match marker {
            b'I' | b'P' => self.main_frame(marker == b'I'),
            b'S' => self.slow_frame(),
            b'H' => self.home_frame(),
            b'G' => self.gps_frame(),
            _ => {}
        }
        Some(end)
    }

    /// Reads the frame or event that starts with `marker` at `start` (field values into `raw`).
    fn read_candidate(&mut self, marker: u8, start: usize) -> Candidate {
        let data = self.data;
        // A trusted frame is at most MAX_FRAME_LEN bytes, so no read needs to look further: this
        // bounds the work spent at each candidate marker while resynchronising through damage.
        let window = data.len().min(start + MAX_FRAME_LEN + 1);
        let cut_by_window = window < data.len();
        let mut c = Cursor::new(&data[..window], start + 1);
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
            read_raw(&mut c, self.frame_defs(marker), &mut self.raw)
        };
        Candidate {
            parsed,
            end: c.pos(),
            cut_by_window,
            resume,
            log_end,
        }
    }

    /// Decodes the I- or P-frame in `raw` and keeps it if it continues the timeline.
    fn main_frame(&mut self, intra: bool) {
        if !intra && !self.history_ok {
            self.stats.unanchored += 1;
            return;
        }
        let skipped = match (intra, self.anchor) {
            (false, Some(a)) => self.h.skipped_after(a.iteration),
            _ => 0,
        };
        let ctx = Context {
            prev: if intra { None } else { self.prev.as_deref() },
            prev2: if intra { None } else { self.prev2.as_deref() },
            skipped,
            minthrottle: self.h.minthrottle,
            min_motor: self.h.min_motor,
            vbatref: self.h.vbatref,
            last_main_time: self.last_main_time,
            motor0: self.motor0,
            home: self.home,
        };
        let defs = self.frame_defs(if intra { b'I' } else { b'P' });
        if apply_predictors(defs, &mut self.raw, &ctx).is_err() {
            self.stats.corrupt += 1;
            self.history_ok = false;
            return;
        }
        let here = Anchor {
            iteration: self.raw[self.it_i],
            time: self.raw[self.time_i],
            inclusive: false,
        };
        if self.admits_main(here, intra) {
            self.keep_main(here, intra);
        }
    }

    /// Whether a main frame at `here` continues the timeline; counts and remembers it when not.
    fn admits_main(&mut self, here: Anchor, intra: bool) -> bool {
        let ok = self.anchor.is_none_or(|a| a.admits(here.iteration, here.time));
        // Two consecutive I-frames consistent with each other but not with the anchor: the
        // timeline really moved (a gap without a resume event); follow it.
        let restart = !ok && intra && self.rejected_i.is_some_and(|r| r.admits(here.iteration, here.time));
        if !ok && !restart {
            self.stats.implausible += 1;
            self.history_ok = false;
            if intra {
                self.rejected_i = Some(here);
            }
            return false;
        }
        true
    }

    /// Stores the trusted main frame in `raw` (and a slow frame waiting for it) and moves the anchor to `here`.
    fn keep_main(&mut self, here: Anchor, intra: bool) {
        let raw = &self.raw;
        self.rejected_i = None;
        self.anchor = Some(here);
        self.last_main_time = here.time;
        self.history_ok = true;
        if intra {
            self.prev2 = Some(raw.clone());
            self.prev = Some(raw.clone());
        } else {
            self.prev2 = self.prev.take();
            self.prev = Some(raw.clone());
        }
        self.main.push(here.time, raw);
        self.main_is_intra.push(intra);
        self.stored += raw.len();
        if let Some(s) = self.slow_pending.take() {
            self.slow.push(here.time, &s);
            self.stored += s.len();
        }
    }

    /// Decodes the slow (S) frame in `raw` and stores it at the last main frame's time.
    fn slow_frame(&mut self) {
        let ctx = side_context(self.h, None, self.last_main_time, self.home);
        if apply_predictors(self.frame_defs(b'S'), &mut self.raw, &ctx).is_err() {
            self.stats.corrupt += 1;
            return;
        }
        if self.main.is_empty() {
            // Shown from the first main frame on.
            self.slow_pending = Some(self.raw.clone());
        } else {
            self.slow.push(self.last_main_time, &self.raw);
            self.stored += self.raw.len();
        }
    }

    /// Decodes the GPS home (H) frame in `raw` and takes its first two fields as the home position.
    fn home_frame(&mut self) {
        let ctx = side_context(self.h, None, self.last_main_time, None);
        if apply_predictors(self.frame_defs(b'H'), &mut self.raw, &ctx).is_ok() && self.raw.len() >= 2 {
            self.home = Some([self.raw[0], self.raw[1]]);
        }
    }

    /// Decodes the GPS (G) frame in `raw` and stores it at its own `time` (else the last main frame's).
    fn gps_frame(&mut self) {
        let ctx = side_context(self.h, self.gps_prev.as_deref(), self.last_main_time, self.home);
        match apply_predictors(self.frame_defs(b'G'), &mut self.raw, &ctx) {
            Ok(()) => {
                let t = self.gps_time.map_or(self.last_main_time, |i| self.raw[i]);
                self.gps.push(t, &self.raw);
                self.stored += self.raw.len();
                self.gps_prev = Some(self.raw.clone());
            }
            Err(Missing::Home) => self.stats.gps_without_home += 1,
            Err(Missing::Motor0) => self.stats.corrupt += 1,
        }
    }

    /// The rows and statistics decoded.
    fn finish(self) -> Decoded {
        Decoded {
            main: self.main,
            main_is_intra: self.main_is_intra,
            slow: self.slow,
            gps: self.gps,
            stats: self.stats,
        }
    }
}

/// Decodes the frames of `data` (one session, after its header).
pub fn decode(h: &Header, data: &[u8]) -> Decoded {
    let mut d = Decoder::new(h, data);
    let mut pos = 0usize;
    while pos < data.len() {
        match d.step(pos) {
            Some(next) => pos = next,
            None => break,
        }
    }
    d.finish()
}
