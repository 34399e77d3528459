//! The noise picture of a flight (`skyloop noise LOG`): spectra of the gyro (raw where the log holds
//! it, and filtered), the D term and the motor commands per axis; spectrograms against throttle and
//! time with the motors' harmonics; the peaks, named; the flown gyro filter chain's response and
//! delay; and a what-if, a changed chain applied to the logged signals.
//!
//! How the what-if is applied: frame by frame (0.25 s), each frame's density is multiplied by
//! |H(e^{jωT})|² of the chain at that frame's operating point (throttle for a dynamic lowpass,
//! tracked peaks for the dynamic notch, eRPM for the RPM notches), with the firmware's discrete
//! filters at its loop rate ([`skyloop_control::filter`]). Where the log holds the raw gyro the
//! candidate chain filters it; elsewhere the logged (filtered) gyro is re-filtered by the ratio of
//! the candidate to the flown chain. Logs are usually written below the loop rate, so a filtering
//! in the time domain at the log rate would not be the firmware's; the frequency-domain form is
//! exact for content below the log's Nyquist frequency (aliased content above it is weighted as
//! where it lands, which the report says).

pub mod figures;
pub mod frames;
pub mod peaks;
pub mod report;

use crate::error::{Error, Result};
use crate::firmware::channels::noise_channels;
use crate::firmware::filters::{FilterChain, OperatingPoint, Path, RawGyroTap, Stage, StageKind};
use crate::firmware::Axis;
use crate::firmware::{flown_chain, raw_gyro_tap};
use crate::identify::airborne_segments;
use frames::{strongest_peaks, Frame, FrameSource, FRAME_S};
use num_complex::Complex64;
use peaks::Peak;
use skyloop_sysid::logs::Span;
use skyloop_sysid::spectral::psd::SegmentPsd;

/// What to analyse.
#[derive(Debug, Clone)]
pub struct NoiseRequest<'a> {
    /// The log file.
    pub path: &'a std::path::Path,
    /// Blackbox session (from 1; None: the longest).
    pub session: Option<usize>,
    /// Axes (empty: roll, pitch and yaw).
    pub axes: Vec<Axis>,
    /// A changed filter chain (`--filters`, see [`FilterChain::with_changes`]).
    pub filters: Option<&'a str>,
    /// Called with a progress line now and then (stderr in the CLI).
    pub progress: Option<fn(&str)>,
}

/// A spectrogram: PSD in dB over rows of `x` (throttle % or time s) and columns of frequency.
#[derive(Debug, Clone, PartialEq)]
pub struct Heat {
    /// Row positions (throttle in %, or time in s).
    pub x: Vec<f64>,
    /// Frequencies, Hz.
    pub freq_hz: Vec<f64>,
    /// PSD, dB re 1 unit²/Hz, one row per x (NaN where no frame fell).
    pub psd_db: Vec<Vec<f64>>,
    /// Frames averaged per row.
    pub frames: Vec<usize>,
    /// The motors' mean rotation frequency per row, Hz (None without eRPM).
    pub motor_hz: Vec<Option<f64>>,
}

/// A filter chain's frequency response at the flight's median operating point.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainResponse {
    /// Frequencies, Hz.
    pub freq_hz: Vec<f64>,
    /// Gain, dB.
    pub gain_db: Vec<f64>,
    /// Phase, degrees (unwrapped).
    pub phase_deg: Vec<f64>,
    /// (frequency Hz, phase delay ms = −phase/(360·f)) at 10, 20, 50 and 100 Hz.
    pub delay_ms_at: Vec<(f64, f64)>,
}

/// How well the flown chain applied to the raw gyro reproduces the logged filtered gyro.
#[derive(Debug, Clone, PartialEq)]
pub struct Validation {
    /// The lowest and highest frequency compared, Hz (bins where logged and predicted are both
    /// ≥ 10 dB above the logged gyro's floor).
    pub band_hz: (f64, f64),
    /// The logged gyro's noise floor, dB re 1 unit²/Hz.
    pub floor_db: f64,
    /// RMS of predicted − logged PSD over the band, dB.
    pub rms_db: f64,
    /// Mean of predicted − logged, dB.
    pub mean_db: f64,
    /// Largest |predicted − logged|, dB.
    pub max_abs_db: f64,
    /// Frequency bins compared.
    pub bins: usize,
}

/// The noise picture of one axis.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisNoise {
    /// The axis.
    pub axis: Axis,
    /// Frequencies of every spectrum, Hz.
    pub freq_hz: Vec<f64>,
    /// Named spectra (PSD in dB re 1 unit²/Hz): `gyro`, `gyro_raw`, `dterm`, `motors`,
    /// `gyro_predicted` (flown chain on the raw gyro), `gyro_what_if`, `dterm_what_if`.
    pub spectra: Vec<(&'static str, Vec<f64>)>,
    /// Peaks of the pre-filter gyro (raw where logged), named.
    pub peaks: Vec<Peak>,
    /// The flown gyro chain's response.
    pub gyro_chain: ChainResponse,
    /// The what-if gyro chain's response.
    pub what_if_chain: Option<ChainResponse>,
    /// Flown chain on the raw gyro against the logged filtered gyro.
    pub validation: Option<Validation>,
    /// Spectrogram against throttle (5 % bins).
    pub by_throttle: Heat,
    /// Spectrogram against time.
    pub by_time: Heat,
}

/// The noise picture of a flight.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseAnalysis {
    /// The log file.
    pub source: String,
    /// The firmware as the header names it.
    pub firmware: String,
    /// Rate of the analysed signals, Hz.
    pub log_rate_hz: f64,
    /// The filter chain's loop rate, Hz.
    pub loop_hz: f64,
    /// Frame length, s.
    pub frame_s: f64,
    /// Frames analysed.
    pub frames: usize,
    /// Airborne time analysed, s.
    pub airborne_s: f64,
    /// Units of gyro, D term and motor commands.
    pub units: [&'static str; 3],
    /// The flown chain.
    pub flown: FilterChain,
    /// The what-if chain and its changes.
    pub what_if: Option<(FilterChain, Vec<String>)>,
    /// The raw gyro channels, when logged.
    pub raw_gyro: Option<RawGyroTap>,
    /// Per axis.
    pub axes: Vec<AxisNoise>,
    /// What is assumed or could not be done.
    pub notes: Vec<String>,
}

/// Rows of the throttle spectrogram (5 % each).
const THROTTLE_BINS: usize = 20;
/// Most columns of the time spectrogram.
const TIME_COLUMNS: usize = 300;
/// The flown filter's power gain below which the logged signal is not divided by it (−20 dB): at a
/// static notch's centre the logged gyro is sensor and quantization noise, not the vibration the
/// notch removed.
const MIN_FLOWN_GAIN2: f64 = 1e-2;

/// The noise picture of `req`'s log.
///
/// # Errors
/// An unreadable log, a log skyloop cannot name the channels of, a bad `--filters`, or a flight
/// with no airborne stretch as long as one frame.
pub fn analyze(req: &NoiseRequest) -> Result<NoiseAnalysis> {
    let say = |s: &str| {
        if let Some(p) = req.progress {
            p(s)
        }
    };
    say("reading the log");
    let (log, notes) = crate::firmware::open_log(req.path, req.session)?;
    analyze_log(&log, notes, req)
}

/// [`analyze`] on a log already read and prepared ([`crate::firmware::open_log`]), `notes` its
/// preparation notes; `req.path` and `req.session` are not used.
///
/// # Errors
/// As [`analyze`], less the reading.
pub fn analyze_log(
    log: &skyloop_sysid::logs::Log,
    mut notes: Vec<String>,
    req: &NoiseRequest,
) -> Result<NoiseAnalysis> {
    let say = |s: &str| {
        if let Some(p) = req.progress {
            p(s)
        }
    };
    let ch = noise_channels(log).ok_or_else(|| {
        Error::Input(format!(
            "{}: noise needs a Betaflight, INAV or PX4 log (ArduPilot and CSV logs are not supported yet)",
            log.source
        ))
    })?;
    let (flown, chain_notes) =
        flown_chain(log).ok_or_else(|| Error::Input(format!("{}: the log states no filter settings", log.source)))?;
    notes.extend(chain_notes);
    let what_if = req.filters.map(|s| flown.with_changes(s)).transpose()?;
    let tap = raw_gyro_tap(log);
    let axes: Vec<Axis> = if req.axes.is_empty() {
        vec![Axis::Roll, Axis::Pitch, Axis::Yaw]
    } else {
        req.axes.clone()
    };
    let idx: Vec<usize> = axes.iter().map(|a| a.index()).collect();
    let src = FrameSource::new(log, &ch, tap.as_ref().map(|t| &t.channels), &idx)?;
    let spans = airborne(log, ch.gyro[idx[0]].as_deref().unwrap_or_default(), &mut notes);
    let starts = src.starts(&spans);
    if starts.is_empty() {
        return Err(Error::Input(format!(
            "{}: no airborne stretch holds one {FRAME_S} s frame",
            log.source
        )));
    }
    if ch.rotation.is_none() && flown.stages.iter().any(|s| matches!(s.kind, StageKind::Rpm { .. })) {
        notes.push("the RPM filter is on but no eRPM is logged: its notches cannot be placed and are left out of the modelled chain (log eRPM, Betaflight 4.3+, to include them)".into());
    }
    let seg = SegmentPsd::new(src.nfft, src.dt_s);
    let evals = Evaluators::new(&flown, what_if.as_ref().map(|w| &w.0), tap.as_ref(), &seg.freq_hz())?;
    if tap.is_none()
        && what_if.as_ref().is_some_and(|(w, _)| {
            w.stages
                .iter()
                .filter(|s| is_tracking(s))
                .any(|s| !flown.stages.contains(s))
        })
    {
        notes.push("the what-if changes a tracking notch but the log holds no raw gyro: only the new notches are applied (what the flown ones removed cannot be seen); log debug GYRO_SCALED for an exact what-if".into());
    }
    let mut acc: Vec<Accum> = idx
        .iter()
        .map(|_| Accum::new(seg.bins(), starts.len().min(TIME_COLUMNS)))
        .collect();
    let mut ops: Vec<OperatingPoint> = Vec::new();
    for (n, &k) in starts.iter().enumerate() {
        if n % (starts.len() / 10).max(1) == 0 {
            say(&format!("spectra: frame {} of {}", n + 1, starts.len()));
        }
        let frame = src.frame(&seg, k)?;
        let col = n * acc[0].time.len() / starts.len();
        for (a, acc) in acc.iter_mut().enumerate() {
            let op = OperatingPoint {
                peaks_hz: strongest_peaks(
                    frame.raw[a].as_ref().unwrap_or(&frame.gyro[a]),
                    1.0 / (src.nfft as f64 * src.dt_s),
                    5,
                ),
                ..frame.op.clone()
            };
            acc.add(&frame, a, &op, &evals, col)?;
            if a == 0 {
                ops.push(op);
            }
        }
    }
    say("peaks and filter responses");
    let freq = seg.freq_hz();
    let median_op = median_operating_point(&ops);
    let mut out_axes = Vec::new();
    for (a, acc) in acc.into_iter().enumerate() {
        out_axes.push(acc.finish(axes[a], &freq, &flown, what_if.as_ref().map(|w| &w.0), &median_op)?);
    }
    Ok(NoiseAnalysis {
        source: log.source.clone(),
        firmware: log
            .setting("Firmware revision")
            .unwrap_or("unknown firmware")
            .to_string(),
        log_rate_hz: src.rate_hz(),
        loop_hz: flown.loop_hz,
        frame_s: src.nfft as f64 * src.dt_s,
        frames: starts.len(),
        airborne_s: spans.iter().map(Span::len_s).sum(),
        units: [ch.gyro_unit, ch.dterm_unit, ch.motor_unit],
        flown,
        what_if,
        raw_gyro: tap,
        axes: out_axes,
        notes,
    })
}

/// The airborne segments (the firmware's tests), or the whole log with a note when none is found.
fn airborne(log: &skyloop_sysid::logs::Log, base: &str, notes: &mut Vec<String>) -> Vec<Span> {
    let found = crate::firmware::airborne_criteria(log).and_then(|c| airborne_segments(log, base, &c, None, None));
    match found {
        Ok(a) => a.segments,
        Err(e) => {
            notes.push(format!("no airborne segment found ({e}); the whole log is analysed"));
            let (t, _) = log.series(base).unwrap_or_default();
            vec![Span {
                from_s: t.first().copied().unwrap_or(0.0),
                to_s: t.last().copied().unwrap_or(0.0),
            }]
        }
    }
}

/// A chain split into its static part (evaluated once) and its dynamic stages (per frame).
struct ChainEval {
    fixed: Vec<Complex64>,
    dynamic: FilterChain,
}

impl ChainEval {
    fn new(chain: &FilterChain, path: Path, keep: impl Fn(&Stage) -> bool, freq: &[f64]) -> Result<ChainEval> {
        let part = |dynamic: bool| FilterChain {
            loop_hz: chain.loop_hz,
            stages: chain
                .stages
                .iter()
                .filter(|s| keep(s) && is_dynamic(&s.kind) == dynamic)
                .cloned()
                .collect(),
        };
        Ok(ChainEval {
            fixed: part(false).response(path, freq, &OperatingPoint::default())?,
            dynamic: part(true),
        })
    }

    /// |H|² per bin at `op`.
    fn gain2(&self, path: Path, freq: &[f64], op: &OperatingPoint) -> Result<Vec<f64>> {
        let d = self.dynamic.response(path, freq, op)?;
        Ok(self.fixed.iter().zip(d).map(|(a, b)| (a * b).norm_sqr()).collect())
    }
}

fn is_dynamic(k: &StageKind) -> bool {
    matches!(
        k,
        StageKind::DynamicLowpass { .. } | StageKind::DynamicNotch { .. } | StageKind::Rpm { .. }
    )
}

/// Every chain the accumulation applies.
struct Evaluators {
    freq: Vec<f64>,
    /// The flown stages the raw tap has not yet passed.
    after_tap: Option<ChainEval>,
    what_if: Option<WhatIfEval>,
}

/// The what-if's chains. With the raw gyro, the candidate's stages after the tap filter it. Without
/// it the logged signals are re-filtered by candidate/flown; a tracking notch (dynamic, RPM) is
/// left out of both when unchanged (it cancels), and when changed only the candidate's is applied:
/// where the flown one sat and what it removed cannot be seen in the filtered log.
struct WhatIfEval {
    raw_gyro: Option<ChainEval>,
    gyro_new: ChainEval,
    gyro_old: ChainEval,
    dterm_new: ChainEval,
    dterm_old: ChainEval,
}

fn is_tracking(s: &Stage) -> bool {
    matches!(s.kind, StageKind::DynamicNotch { .. } | StageKind::Rpm { .. })
}

impl Evaluators {
    fn new(
        flown: &FilterChain,
        what_if: Option<&FilterChain>,
        tap: Option<&RawGyroTap>,
        freq: &[f64],
    ) -> Result<Evaluators> {
        let after = |c: &FilterChain| -> Result<Option<ChainEval>> {
            tap.map(|t| ChainEval::new(c, Path::Gyro, |s| !t.applied.contains(&s.name), freq))
                .transpose()
        };
        let what_if = match what_if {
            None => None,
            Some(w) => {
                let unchanged = |s: &Stage| flown.stages.contains(s);
                let old = |s: &Stage| !is_tracking(s);
                let new = |s: &Stage| !(is_tracking(s) && unchanged(s));
                Some(WhatIfEval {
                    raw_gyro: after(w)?,
                    gyro_new: ChainEval::new(w, Path::Gyro, new, freq)?,
                    gyro_old: ChainEval::new(flown, Path::Gyro, old, freq)?,
                    dterm_new: ChainEval::new(w, Path::Dterm, new, freq)?,
                    dterm_old: ChainEval::new(flown, Path::Dterm, old, freq)?,
                })
            }
        };
        Ok(Evaluators {
            freq: freq.to_vec(),
            after_tap: after(flown)?,
            what_if,
        })
    }
}

/// Sums of one axis' densities over the frames.
struct Accum {
    count: usize,
    /// Each frame's throttle and strongest pre-filter peaks (for naming the peaks).
    tracks: Vec<(f64, Vec<f64>)>,
    sums: Vec<(&'static str, Vec<f64>)>,
    throttle: Vec<(Vec<f64>, usize, f64, usize)>,
    time: Vec<(Vec<f64>, usize, f64)>,
}

impl Accum {
    fn new(bins: usize, columns: usize) -> Accum {
        Accum {
            count: 0,
            tracks: Vec::new(),
            sums: Vec::new(),
            throttle: vec![(vec![0.0; bins], 0, 0.0, 0); THROTTLE_BINS],
            time: vec![(vec![0.0; bins], 0, 0.0); columns.max(1)],
        }
    }

    fn add_to(&mut self, name: &'static str, d: &[f64]) {
        match self.sums.iter_mut().find(|(n, _)| *n == name) {
            Some((_, s)) => s.iter_mut().zip(d).for_each(|(a, b)| *a += b),
            None => self.sums.push((name, d.to_vec())),
        }
    }

    fn add(&mut self, f: &Frame, a: usize, op: &OperatingPoint, ev: &Evaluators, col: usize) -> Result<()> {
        self.count += 1;
        let mul = |d: &[f64], g: &[f64]| d.iter().zip(g).map(|(x, y)| x * y).collect::<Vec<f64>>();
        let ratio = |new: &[f64], old: &[f64]| {
            new.iter()
                .zip(old)
                .map(|(n, o)| n / o.max(MIN_FLOWN_GAIN2))
                .collect::<Vec<f64>>()
        };
        self.add_to("gyro", &f.gyro[a]);
        if let Some(m) = &f.motors {
            self.add_to("motors", m);
        }
        if let Some(r) = &f.raw[a] {
            self.add_to("gyro_raw", r);
        }
        if let Some(d) = &f.dterm[a] {
            self.add_to("dterm", d);
        }
        if let (Some(r), Some(t)) = (&f.raw[a], &ev.after_tap) {
            self.add_to("gyro_predicted", &mul(r, &t.gain2(Path::Gyro, &ev.freq, op)?));
        }
        if let Some(w) = &ev.what_if {
            let hg_new = w.gyro_new.gain2(Path::Gyro, &ev.freq, op)?;
            let hg_old = w.gyro_old.gain2(Path::Gyro, &ev.freq, op)?;
            let gyro = match (&f.raw[a], &w.raw_gyro) {
                (Some(r), Some(t)) => mul(r, &t.gain2(Path::Gyro, &ev.freq, op)?),
                _ => mul(&f.gyro[a], &ratio(&hg_new, &hg_old)),
            };
            self.add_to("gyro_what_if", &gyro);
            if let Some(d) = &f.dterm[a] {
                let new = mul(&hg_new, &w.dterm_new.gain2(Path::Dterm, &ev.freq, op)?);
                let old = mul(&hg_old, &w.dterm_old.gain2(Path::Dterm, &ev.freq, op)?);
                self.add_to("dterm_what_if", &mul(d, &ratio(&new, &old)));
            }
        }
        let heat = f.raw[a].as_ref().unwrap_or(&f.gyro[a]);
        let motor = (!op.motor_hz.is_empty()).then(|| op.motor_hz.iter().sum::<f64>() / op.motor_hz.len() as f64);
        if let Some(t) = op.throttle {
            self.tracks.push((t, op.peaks_hz.clone()));
            let b = ((t * THROTTLE_BINS as f64) as usize).min(THROTTLE_BINS - 1);
            let row = &mut self.throttle[b];
            row.0.iter_mut().zip(heat).for_each(|(x, y)| *x += y);
            row.1 += 1;
            if let Some(m) = motor {
                row.2 += m;
                row.3 += 1;
            }
        }
        let last = self.time.len() - 1;
        let c = &mut self.time[col.min(last)];
        c.0.iter_mut().zip(heat).for_each(|(x, y)| *x += y);
        c.1 += 1;
        c.2 += f.t_s;
        Ok(())
    }

    fn finish(
        self,
        axis: Axis,
        freq: &[f64],
        flown: &FilterChain,
        what_if: Option<&FilterChain>,
        op: &OperatingPoint,
    ) -> Result<AxisNoise> {
        let n = self.count.max(1) as f64;
        let spectra: Vec<(&'static str, Vec<f64>)> = self
            .sums
            .iter()
            .map(|(name, s)| (*name, s.iter().map(|v| db(v / n)).collect()))
            .collect();
        let get = |name: &str| spectra.iter().find(|(n, _)| *n == name).map(|(_, v)| v.clone());
        let by_throttle = heat_rows(
            freq,
            self.throttle.iter().enumerate().map(|(b, (s, c, m, mc))| {
                let x = (b as f64 + 0.5) * 100.0 / THROTTLE_BINS as f64;
                (x, s.as_slice(), *c, (*mc > 0).then(|| m / *mc as f64))
            }),
        );
        let by_time = heat_rows(
            freq,
            self.time
                .iter()
                .filter(|(_, c, _)| *c > 0)
                .map(|(s, c, t)| (t / *c as f64, s.as_slice(), *c, None)),
        );
        let pre = get("gyro_raw").or_else(|| get("gyro")).unwrap_or_default();
        let validation = match (get("gyro_predicted"), get("gyro")) {
            (Some(p), Some(g)) => validate(freq, &p, &g),
            _ => None,
        };
        Ok(AxisNoise {
            axis,
            peaks: peaks::find(freq, &pre, &by_throttle, &self.tracks),
            gyro_chain: chain_response(flown, op)?,
            what_if_chain: what_if.map(|w| chain_response(w, op)).transpose()?,
            validation,
            freq_hz: freq.to_vec(),
            spectra,
            by_throttle,
            by_time,
        })
    }
}

fn db(v: f64) -> f64 {
    10.0 * v.max(1e-30).log10()
}

fn heat_rows<'a>(freq: &[f64], rows: impl Iterator<Item = (f64, &'a [f64], usize, Option<f64>)>) -> Heat {
    let mut h = Heat {
        x: Vec::new(),
        freq_hz: freq.to_vec(),
        psd_db: Vec::new(),
        frames: Vec::new(),
        motor_hz: Vec::new(),
    };
    for (x, s, c, m) in rows {
        h.x.push(x);
        h.psd_db.push(
            s.iter()
                .map(|v| if c > 0 { db(v / c as f64) } else { f64::NAN })
                .collect(),
        );
        h.frames.push(c);
        h.motor_hz.push(m);
    }
    h
}

/// Predicted (flown chain on the raw gyro) against logged, from 5 Hz up, over the bins where both
/// stand at least 10 dB above the logged gyro's noise floor (the median of its top fifth of
/// frequencies: the flat tail of sensor and integer-logging quantization noise).
fn validate(freq: &[f64], pred: &[f64], logged: &[f64]) -> Option<Validation> {
    let mut tail: Vec<f64> = logged[logged.len() * 4 / 5..].to_vec();
    tail.sort_by(f64::total_cmp);
    let floor = *tail.get(tail.len() / 2)?;
    let diffs: Vec<(f64, f64)> = freq
        .iter()
        .zip(pred.iter().zip(logged))
        .filter(|(f, (p, l))| **f >= 5.0 && **l >= floor + 10.0 && **p >= floor + 10.0)
        .map(|(f, (p, l))| (*f, p - l))
        .collect();
    if diffs.len() < 3 {
        return None;
    }
    let k = diffs.len() as f64;
    Some(Validation {
        band_hz: (diffs[0].0, diffs[diffs.len() - 1].0),
        rms_db: (diffs.iter().map(|(_, d)| d * d).sum::<f64>() / k).sqrt(),
        mean_db: diffs.iter().map(|(_, d)| d).sum::<f64>() / k,
        max_abs_db: diffs.iter().map(|(_, d)| d.abs()).fold(0.0, f64::max),
        bins: diffs.len(),
        floor_db: floor,
    })
}

/// The median throttle, motor speeds and tracked peaks of the frames.
fn median_operating_point(ops: &[OperatingPoint]) -> OperatingPoint {
    let median = |mut v: Vec<f64>| -> Option<f64> {
        v.retain(|x| x.is_finite());
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied()
    };
    let motors = ops.iter().map(|o| o.motor_hz.len()).max().unwrap_or(0);
    OperatingPoint {
        throttle: median(ops.iter().filter_map(|o| o.throttle).collect()),
        motor_hz: (0..motors)
            .filter_map(|m| median(ops.iter().filter_map(|o| o.motor_hz.get(m).copied()).collect()))
            .collect(),
        peaks_hz: (0..5)
            .filter_map(|p| median(ops.iter().filter_map(|o| o.peaks_hz.get(p).copied()).collect()))
            .collect(),
    }
}

/// The gyro chain's response at `op` on a log grid from 1 Hz to the loop's Nyquist frequency.
fn chain_response(chain: &FilterChain, op: &OperatingPoint) -> Result<ChainResponse> {
    let top = (0.5 * chain.loop_hz).min(2000.0);
    let freq: Vec<f64> = (0..240).map(|k| 10f64.powf(top.log10() * k as f64 / 239.0)).collect();
    let h = chain.response(Path::Gyro, &freq, op)?;
    let phase = skyloop_sysid::spectral::unwrap_deg(h.iter().map(|z| z.arg().to_degrees()));
    let at = [10.0, 20.0, 50.0, 100.0]
        .into_iter()
        .filter(|f| *f < top)
        .map(|f| {
            let z = chain.response(Path::Gyro, &[f], op).map(|v| v[0]);
            // The phase at f continues the unwrapped curve: take the grid's nearest unwrap offset.
            let k = freq.iter().position(|x| *x >= f).unwrap_or(0);
            let p = z.map(|z| {
                let raw = z.arg().to_degrees();
                raw + 360.0 * ((phase[k] - raw) / 360.0).round()
            });
            p.map(|p| (f, -p / (360.0 * f) * 1000.0))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(ChainResponse {
        gain_db: h.iter().map(|z| db(z.norm_sqr())).collect(),
        phase_deg: phase,
        delay_ms_at: at,
        freq_hz: freq,
    })
}
