//! `skyloop log compare A B`: two flights of one craft side by side, before and after a change (a
//! PID or filter change). Per axis: the closed-loop tracking response setpoint → gyro (what the
//! pilot feels), the plant PID sum → gyro (what the engineer models), the causal step and the gyro
//! noise, of both logs overlaid; the header settings that differ; and a verdict that names a change
//! only where it exceeds the estimates' uncertainty ([`verdict`]).
//!
//! The parts are the existing ones: [`crate::identify::identify_log`] for the plant,
//! [`crate::tune::fir_step::causal_step`] for the step, [`crate::noise::analyze_log`] for the
//! spectra and the header model `FirmwareTuning` for the settings. What one log cannot give (an
//! axis without stick input, a log without airborne time) is kept as its reason and shown as
//! "not identified: …"; only a file that cannot be read fails the comparison.

pub mod figures;
pub mod headers;
pub mod report;
pub mod side;
pub mod verdict;

use crate::error::{Error, Result};
use crate::firmware::FirmwareTuning;
use crate::firmware::{Axis, Firmware};
use crate::noise::{NoiseAnalysis, NoiseRequest};
pub use headers::HeaderDiff;
use serde::Serialize;
use skyloop_sysid::logs::Log;
use std::path::Path;
pub use verdict::CurveDiff;

/// Least squared coherence of a tracking point that is compared or measured from.
pub const COHERENCE_MIN: f64 = 0.5;

/// A part of one log's analysis, or why it could not be had.
pub type Measured<T> = std::result::Result<T, String>;

/// What to compare.
#[derive(Debug, Clone)]
pub struct CompareRequest<'a> {
    /// Log A (before).
    pub a: &'a Path,
    /// Log B (after).
    pub b: &'a Path,
    /// Blackbox session of A (from 1; None: the longest).
    pub session_a: Option<usize>,
    /// Blackbox session of B.
    pub session_b: Option<usize>,
    /// Called with a progress line as each stage starts.
    pub progress: Option<fn(&str)>,
}

/// The closed-loop tracking response setpoint → gyro of one log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Tracking {
    /// Frequencies, Hz (logarithmic; shared by both logs).
    pub freq_hz: Vec<f64>,
    /// |T|, dB.
    pub mag_db: Vec<f64>,
    /// Phase, degrees (unwrapped).
    pub phase_deg: Vec<f64>,
    /// Standard error of the magnitude, dB.
    pub std_db: Vec<f64>,
    /// Standard error of the phase, degrees.
    pub std_deg: Vec<f64>,
    /// Squared coherence.
    pub coherence: Vec<f64>,
    /// −3 dB bandwidth: the lowest coherent frequency where |T| falls below −3 dB, Hz.
    pub bandwidth_hz: Option<f64>,
    /// Largest |T| over the coherent points (dB, Hz): the loop's resonance.
    pub peak: Option<(f64, f64)>,
}

impl Tracking {
    /// The response with its bandwidth and peak found over the coherent points.
    pub fn new(
        freq_hz: Vec<f64>,
        mag_db: Vec<f64>,
        phase_deg: Vec<f64>,
        std_db: Vec<f64>,
        std_deg: Vec<f64>,
        coherence: Vec<f64>,
    ) -> Tracking {
        let ok: Vec<usize> = (0..freq_hz.len().min(mag_db.len()).min(coherence.len()))
            .filter(|&k| side::coherent(coherence[k]) && mag_db[k].is_finite())
            .collect();
        let peak = ok
            .iter()
            .max_by(|&&a, &&b| mag_db[a].total_cmp(&mag_db[b]))
            .map(|&k| (mag_db[k], freq_hz[k]));
        let bandwidth_hz = ok.windows(2).find_map(|w| {
            let (i, j) = (w[0], w[1]);
            (mag_db[i] >= -3.0 && mag_db[j] < -3.0).then(|| {
                let s = (-3.0 - mag_db[i]) / (mag_db[j] - mag_db[i]);
                (freq_hz[i].ln() + s * (freq_hz[j].ln() - freq_hz[i].ln())).exp()
            })
        });
        Tracking {
            freq_hz,
            mag_db,
            phase_deg,
            std_db,
            std_deg,
            coherence,
            bandwidth_hz,
            peak,
        }
    }
}

/// The plant PID sum → gyro identified from one log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plant {
    /// Frequencies of the estimate, Hz.
    pub freq_hz: Vec<f64>,
    /// |P|, dB.
    pub mag_db: Vec<f64>,
    /// Phase, degrees.
    pub phase_deg: Vec<f64>,
    /// Standard error of the magnitude, dB.
    pub std_db: Vec<f64>,
    /// Squared coherence.
    pub coherence: Vec<f64>,
    /// K of K·e^(−Td·s)/(s·(τs+1)) and its standard error, in `gain_unit`.
    pub k: (f64, f64),
    /// τ and its standard error, s.
    pub tau_s: (f64, f64),
    /// Td and its standard error, s.
    pub td_s: (f64, f64),
    /// The yaw model's reaction-torque zero Tz (K·(Tz·s + 1)·e^(−Td·s)/(s·(τs+1))) and its
    /// standard error, s, when the fit has one.
    pub tz_s: Option<(f64, f64)>,
    /// Fit percentage.
    pub fit_percent: f64,
    /// Unit of K.
    pub gain_unit: String,
    /// The band fitted, Hz.
    pub fit_band_hz: Option<(f64, f64)>,
}

/// The causal step setpoint → gyro of one log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StepSummary {
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Response per unit setpoint step.
    pub y: Vec<f64>,
    /// Its jackknife standard error.
    pub y_std: Vec<f64>,
    /// 10–90 % rise time against the final value, ms.
    pub rise_time_ms: Option<f64>,
    /// Overshoot of the final value, %.
    pub overshoot_pct: Option<f64>,
    /// Standard error of the overshoot, % (the step's at its peak).
    pub overshoot_std_pct: f64,
    /// The final value: the mean of the last quarter of the response.
    pub final_value: f64,
    /// Share of the fit's residual that the future setpoint explains (a pilot in the loop).
    pub acausal_fraction: f64,
}

/// The gyro noise of one axis of one log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoiseBands {
    /// Frequencies, Hz.
    pub freq_hz: Vec<f64>,
    /// PSD of the logged gyro, dB re 1 unit²/Hz.
    pub psd_db: Vec<f64>,
    /// Mean square over 20–100 Hz, dB re 1 unit².
    pub low_db: Option<f64>,
    /// Mean square from 100 Hz to `high_top_hz`, dB re 1 unit².
    pub high_db: Option<f64>,
    /// Upper edge of the high band, Hz: the lower of the two logs' Nyquist frequencies.
    pub high_top_hz: f64,
    /// The log's Nyquist frequency, Hz.
    pub nyquist_hz: f64,
    /// The gyro's unit.
    pub unit: &'static str,
    /// Frames averaged.
    pub frames: usize,
}

/// One log's measurements of one axis.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisSide {
    /// Closed-loop tracking response.
    pub tracking: Measured<Tracking>,
    /// Identified plant.
    pub plant: Measured<Plant>,
    /// Causal step.
    pub step: Measured<StepSummary>,
    /// Gyro noise.
    pub noise: Measured<NoiseBands>,
}

/// One axis of both logs, compared.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisComparison {
    /// The axis.
    pub axis: Axis,
    /// Log A's side.
    pub a: AxisSide,
    /// Log B's side.
    pub b: AxisSide,
    /// Tracking magnitude and phase compared (None when either is missing).
    pub tracking_diff: Option<(CurveDiff, CurveDiff)>,
    /// The steps compared.
    pub step_diff: Option<CurveDiff>,
    /// The axis' verdict line.
    pub verdict: String,
    /// The verdict names a change beyond the uncertainty.
    pub changed: bool,
}

/// What identifies one log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Flight {
    /// The file (and session) as the reader names it.
    pub source: String,
    /// Firmware family ("Betaflight", "PX4", …; "unknown" for CSV).
    pub firmware: String,
    /// The firmware's revision as the header gives it.
    pub revision: String,
    /// Duration, s.
    pub duration_s: f64,
    /// Notes of the reader and the analyses.
    pub notes: Vec<String>,
}

/// Two flights compared.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Log A.
    pub a: Flight,
    /// Log B.
    pub b: Flight,
    /// Roll, pitch, yaw.
    pub axes: Vec<AxisComparison>,
    /// The header settings that differ.
    pub header_diffs: Vec<HeaderDiff>,
    /// The verdict, one line per axis, then the settings, then a summary.
    pub verdict: Vec<String>,
    /// What the comparison assumes or could not do.
    pub notes: Vec<String>,
}

fn open(path: &Path, session: Option<usize>) -> Result<(Log, Vec<String>)> {
    crate::firmware::open_log(path, session).map_err(|e| {
        let m = e.to_string();
        let name = path.display().to_string();
        Error::Input(if m.contains(&name) { m } else { format!("{name}: {m}") })
    })
}

fn flight(log: &Log, notes: Vec<String>) -> Flight {
    let revision = log
        .setting("Firmware revision")
        .map(str::to_string)
        .or_else(|| match FirmwareTuning::from_log(log) {
            Some(FirmwareTuning::ArduPilot(a)) => Some(a.firmware_revision.clone()),
            _ => None,
        })
        .unwrap_or_default();
    Flight {
        source: log.source.clone(),
        firmware: Firmware::of_log(log).map_or("unknown".to_string(), |f| f.display_name().to_string()),
        revision,
        duration_s: log.duration_s(),
        notes,
    }
}

/// Compares two logs (see the module documentation).
///
/// # Errors
/// A file that cannot be read or decoded (the message names it). Everything after reading is
/// per part: a missing part is reported, not an error.
pub fn compare_logs(req: &CompareRequest) -> Result<Comparison> {
    let say = |s: &str| {
        if let Some(p) = req.progress {
            p(s)
        }
    };
    say("reading A");
    let (la, na) = open(req.a, req.session_a)?;
    say("reading B");
    let (lb, nb) = open(req.b, req.session_b)?;
    let noise_of = |log: &Log, notes: &[String], path: &Path, session: Option<usize>, which: &str| {
        say(&format!("{which}: gyro noise spectra"));
        let r = NoiseRequest {
            path,
            session,
            axes: Vec::new(),
            filters: None,
            progress: None,
        };
        crate::noise::analyze_log(log, notes.to_vec(), &r).map_err(|e| e.to_string())
    };
    let noise_a = noise_of(&la, &na, req.a, req.session_a, "A");
    let noise_b = noise_of(&lb, &nb, req.b, req.session_b, "B");
    let mut axes = Vec::new();
    for axis in [Axis::Roll, Axis::Pitch, Axis::Yaw] {
        axes.push(compare_axis(req, axis, (&la, &noise_a), (&lb, &noise_b), &say));
    }
    let (fa, fb) = (flight(&la, na), flight(&lb, nb));
    let (ta, tb) = (FirmwareTuning::from_log(&la), FirmwareTuning::from_log(&lb));
    let header_diffs = headers::diff(ta.as_ref(), tb.as_ref());
    let mut notes = Vec::new();
    if fa.firmware != fb.firmware {
        notes.push(format!(
            "the logs are of different firmware ({} and {}): responses and noise are compared, the settings are not comparable key by key",
            fa.firmware, fb.firmware
        ));
    } else if fa.revision != fb.revision {
        notes.push(format!(
            "the firmware revisions differ ({} and {}): a setting of the same name may act differently",
            fa.revision, fb.revision
        ));
    }
    for (which, n) in [("A", &noise_a), ("B", &noise_b)] {
        if let Err(e) = n {
            notes.push(format!("no noise picture of {which}: {e}"));
        }
    }
    let verdict = summary(&axes, &header_diffs, req.a == req.b && req.session_a == req.session_b);
    Ok(Comparison {
        a: fa,
        b: fb,
        axes,
        header_diffs,
        verdict,
        notes,
    })
}

/// Both sides of one axis and their comparison.
fn compare_axis(
    req: &CompareRequest,
    axis: Axis,
    a: (&Log, &Measured<NoiseAnalysis>),
    b: (&Log, &Measured<NoiseAnalysis>),
    say: &dyn Fn(&str),
) -> AxisComparison {
    let (da, db) = (side::axis_data(a.0, axis), side::axis_data(b.0, axis));
    // One grid for both: up to 1/2.5 of the slower log's rate.
    let rate = |d: &Result<side::AxisData>| d.as_ref().map_or(f64::INFINITY, |d| 1.0 / d.data.dt_s);
    let fmax = side::TRACKING_FMAX_HZ.min(rate(&da).min(rate(&db)) / 2.5);
    let top_hz = [side::noise_top_hz(a.1), side::noise_top_hz(b.1)]
        .into_iter()
        .flatten()
        .fold(f64::INFINITY, f64::min);
    let one = |which: &str, log: &Log, d: Result<side::AxisData>, noise: &Measured<NoiseAnalysis>, path, session| {
        say(&format!("{which}: {} axis", axis.name()));
        let d = d.map_err(|e| e.to_string());
        AxisSide {
            tracking: d
                .as_ref()
                .map_err(Clone::clone)
                .and_then(|d| side::tracking(d, fmax).map_err(|e| e.to_string())),
            step: d
                .as_ref()
                .map_err(Clone::clone)
                .and_then(|d| side::step(d).map_err(|e| e.to_string())),
            plant: side::plant(log, path, session, axis).map_err(|e| e.to_string()),
            noise: side::noise(noise, axis, top_hz),
        }
    };
    let sa = one("A", a.0, da, a.1, req.a, req.session_a);
    let sb = one("B", b.0, db, b.1, req.b, req.session_b);
    let tracking_diff = match (&sa.tracking, &sb.tracking) {
        (Ok(x), Ok(y)) => verdict::tracking_diff(x, y),
        _ => None,
    };
    // B's step on A's times (the logs' rates may differ), over the span both cover.
    let step_diff = match (&sa.step, &sb.step) {
        (Ok(x), Ok(y)) => {
            let (yb, sb_) = (
                side::resample(&y.t_s, &y.y, &x.t_s),
                side::resample(&y.t_s, &y.y_std, &x.t_s),
            );
            let end = y.t_s.last().copied().unwrap_or(0.0);
            Some(verdict::curve_diff(&x.t_s, (&x.y, &x.y_std), (&yb, &sb_), |k| {
                x.t_s[k] <= end
            }))
        }
        _ => None,
    };
    let (line, changed) = verdict::axis_verdict(axis.name(), &sa, &sb, tracking_diff.as_ref(), step_diff.as_ref());
    AxisComparison {
        axis,
        a: sa,
        b: sb,
        tracking_diff,
        step_diff,
        verdict: line,
        changed,
    }
}

/// The verdict: one line per axis, the settings, and whether anything changed at all.
fn summary(axes: &[AxisComparison], diffs: &[HeaderDiff], same_file: bool) -> Vec<String> {
    let mut out: Vec<String> = axes.iter().map(|a| a.verdict.clone()).collect();
    out.extend(verdict::header_verdict(diffs));
    let changed = axes.iter().any(|a| a.changed);
    if same_file {
        out.push("A and B are the same log".into());
    }
    out.push(if !changed && diffs.is_empty() {
        "no change: equal settings, and no measured difference beyond the estimates' uncertainty".into()
    } else if !changed {
        "the settings differ, but no measured difference exceeds the estimates' uncertainty".into()
    } else {
        "changed: see the lines above (differences within the uncertainty are not listed as changes)".into()
    });
    out
}
