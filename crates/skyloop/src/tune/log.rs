//! `skyloop tune LOG --axis roll`: identify the axis from the flight log, read the gains and
//! filters the craft flew with from the log header, analyse that tune, check the model against the
//! step response deconvolved from the log, and propose gains that keep the firmware's filters and
//! meet the goals over the identified uncertainty.
//!
//! Model and filters. The identified plant runs from the PID sum to the gyro *as the PID sees it*
//! (Betaflight logs `gyroADC` after the gyro lowpass and notch chain; PX4 logs
//! `vehicle_angular_velocity` after `IMU_GYRO_CUTOFF`), so the gyro filters are already inside
//! the plant and are not applied a second time; the D-term lowpass chain (Betaflight
//! `dterm_lowpass*`, PX4 `IMU_DGYRO_CUTOFF`) is part of the controller, as flown. A dynamic
//! lowpass is taken at the low end of its range (hover throttle: the most lag). With Betaflight's
//! d_min active (0 < d_min < d) the flown tune is analysed with D = d_min, the D the firmware
//! applies away from fast stick moves and prop wash (the testdata acro log's axisD follows
//! DTERM_SCALE·d_min within a few %, 23 % below DTERM_SCALE·d); the proposal's CLI lines set
//! d_min to 0 so that its constant D is what flies.
//!
//! Uncertainty. The identification gives one model with standard errors (never smaller than its
//! jackknife spread), not per-segment models; the goals must hold for the nominal fit and for
//! each of K, τ, Td moved by ±`sigma` standard errors with the others at their fit (6 more
//! plants), clamped to K ≥ K/20, τ ≥ 0.1 ms, Td ≥ 0.

use super::candidates::{front, search, Scores, Screen, SearchLimits};
use super::deconv::{step_from_log, DeconvOptions, MeasuredStep};
use super::filter_tuning::{
    add_filter_candidates, cutoff_rule, describe, variant_of, FilterChange, GyroVariant, ProposedFilters,
};
use super::flight::{fly, FlightCheck, FlightSetup};
use super::live::LiveLoop;
use super::noise::{self, NoiseReport};
use super::verdict::{proposal_text, Verdict, VerdictKind};
use super::{outcome_for_gains, tune, with_hold, Firmware, GenericStructure, Maximize, TuneOutcome, TuneRequest};
use crate::error::{Error, Result};
use crate::firmware::filter_settings::{FilterSettings, Scale};
use crate::firmware::flown::{flown_tune, FlownTune};
use crate::firmware::rate_gains::RateGains;
use crate::firmware::Axis;
use crate::identify::{identify_log, Identification, IdentifyRequest, RATE_LOOP_MODEL, YAW_RATE_LOOP_MODEL};
use serde_json::{json, Value};
use skyloop_lti::interconnect::{feedback, series};
use skyloop_lti::{c64, StateSpace};
use skyloop_robust::structured::verify::{check_loop, sampled_peak, LoopCheck};
use skyloop_sysid::logs::Log;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// A tuning request from a flight log.
#[derive(Debug, Clone)]
pub struct LogTuneRequest {
    /// The flight log (Betaflight blackbox or PX4 ULog).
    pub log: PathBuf,
    /// The axis to identify and tune.
    pub axis: Axis,
    /// Blackbox session (counted from 1; None: the longest).
    pub session: Option<usize>,
    /// Lowest frequency of the identification, Hz (None: identify's default).
    pub fmin_hz: Option<f64>,
    /// Highest frequency of the identification, Hz (None: identify's default).
    pub fmax_hz: Option<f64>,
    /// Firmware (None: the one that wrote the log; given, it must match the log's, except generic,
    /// which tunes C = kp + ki/s + kd·s/(tf·s+1) on the same plant).
    pub firmware: Option<Firmware>,
    /// Generic structure.
    pub structure: GenericStructure,
    /// Generic PID: a fixed derivative filter time constant, s.
    pub d_filter_tau_s: Option<f64>,
    /// Goals as written (`ms<=1.4`, ...).
    pub goals: Vec<String>,
    /// What to maximize.
    pub maximize: Maximize,
    /// Optimizer starts.
    pub starts: usize,
    /// Half-width of the uncertainty box in standard errors (0: nominal only).
    pub sigma: f64,
    /// Fit the feedforward to the proposal (false: keep the flown one).
    pub tune_feedforward: bool,
    /// Largest predicted motor-noise power of a proposal relative to the flown tune's.
    pub noise_budget: f64,
    /// Tune the gyro and D-term lowpass cutoffs beside P, I, D ([`super::filter_tuning`]).
    pub tune_filters: bool,
    /// With `tune_filters`: leave the settings every axis shares as flown (only a per-axis cutoff,
    /// ArduPilot's `FLTD`, may move). [`tune_axes_from_log`] sets it when the axes disagree.
    pub freeze_shared_filters: bool,
    /// Called with the axis and the name of each stage as it starts (no terminal I/O here: the CLI
    /// draws it).
    pub progress: Option<fn(Axis, &str)>,
}

impl LogTuneRequest {
    /// Defaults: identify's band, ±2σ, generic PID structure, the pilot's objective (the highest
    /// crossover at no loss of robustness), noise budget 1.25, 8 starts.
    /// `firmware`: a [`Firmware`], or None to take it from the log.
    pub fn new(log: PathBuf, axis: Axis, firmware: impl Into<Option<Firmware>>) -> Self {
        LogTuneRequest {
            log,
            axis,
            session: None,
            fmin_hz: None,
            fmax_hz: None,
            firmware: firmware.into(),
            structure: GenericStructure::Pid,
            d_filter_tau_s: None,
            goals: Vec::new(),
            maximize: Maximize::Tracking,
            starts: 8,
            sigma: 2.0,
            tune_feedforward: true,
            noise_budget: 1.25,
            tune_filters: false,
            freeze_shared_filters: false,
            progress: None,
        }
    }
}

/// One tune (current or proposed) analysed on the nominal identified plant, exact delay.
#[derive(Debug, Clone)]
pub struct TuneAnalysis {
    /// The gains, with the firmware's keys.
    pub gains: Value,
    /// C_fb (y → u), continuous, plant units.
    pub feedback_controller: StateSpace,
    /// C_r (setpoint → u).
    pub reference_path: StateSpace,
    /// Margins and peaks (exact delay, the loop's hold included).
    pub margins: LoopCheck,
    /// The worst margins over the uncertainty set.
    pub worst: LoopCheck,
    /// Largest |C_fb(jω)| above the noise-limit frequency (plant units).
    pub noise_gain: f64,
    /// Predicted setpoint → gyro step (Padé order 6 for the delays inside the loop).
    pub step_t_s: Vec<f64>,
    /// See `step_t_s`.
    pub step_y: Vec<f64>,
    /// Rise time 10–90 %, s.
    pub rise_time_s: Option<f64>,
    /// Overshoot, %.
    pub overshoot_pct: Option<f64>,
    /// The gains flown in the 6-DOF quadrotor (see [`super::flight`]); None for an unstable loop
    /// or a log whose units are not known.
    pub flight: Option<FlightCheck>,
}

/// The proposal from a log.
#[derive(Debug, Clone)]
pub struct LogTuneOutcome {
    /// The identification behind the plant.
    pub identification: Identification,
    /// The nominal plant (no hold), plant units.
    pub plant: StateSpace,
    /// Its parameters and standard errors.
    pub params: BTreeMap<String, (f64, f64)>,
    /// The uncertainty set (nominal first; no hold).
    pub plants: Vec<StateSpace>,
    /// The filters and loop rate read from the header, as used.
    pub filters: Vec<String>,
    /// The tune that was flown, analysed (None when the header carries no gains for the axis or
    /// the firmware is generic).
    pub current: Option<TuneAnalysis>,
    /// The proposal.
    pub proposed: TuneOutcome,
    /// The proposal analysed like the current tune.
    pub proposed_analysis: TuneAnalysis,
    /// The step response deconvolved from the log (None when the log has too little stick input).
    pub measured_step: Option<MeasuredStep>,
    /// Why there is no measured step.
    pub measured_step_error: Option<String>,
    /// RMS of (predicted current − measured) over the measured step's span, per unit step.
    pub model_step_rms: Option<f64>,
    /// The step measured by the causal FIR fit ([`super::fir_step`]); None when the log has too
    /// little data. Its `acausal_fraction` is the share of the fit's residual the future setpoint
    /// explains.
    pub causal_step: Option<MeasuredStep>,
    /// RMS of (predicted current − causal step), per unit step: the model check.
    pub causal_step_rms: Option<f64>,
    /// Notes (filters inside the plant, what is not modelled).
    pub notes: Vec<String>,
    /// What the pilot must act on: a model that contradicts the flight (the flown tune predicted
    /// unstable, or a predicted step far from the measured one).
    pub warnings: Vec<String>,
    /// Propose, keep, or cannot, in a pilot's words.
    pub verdict: Verdict,
    /// The predicted motor noise of the proposal against the flown tune's (None without flown
    /// gains or a gyro spectrum).
    pub noise: Option<NoiseReport>,
    /// The trade-off front within the bounded change: (gains, screened scores, noise ratio).
    pub front: Vec<(Value, Scores, f64)>,
    /// The filter changes of the proposal (`--tune-filters`), each with its reason.
    pub filter_changes: Vec<FilterChange>,
    /// The proposal's gyro and D-term lowpass chains against the flown ones (None unless
    /// `--tune-filters` moved one).
    pub proposed_filters: Option<ProposedFilters>,
    /// The axis.
    pub axis: Axis,
    /// The flown tune's closed loop setpoint → gyro, measured against predicted.
    pub closed_loop: Option<super::model_check::ClosedLoopCheck>,
    /// The flown loop's |S| and |T| around its crossover on the measured plant, against the model's.
    pub crossover_check: Option<super::model_check::CrossoverCheck>,
    /// What re-analysing other gains on this log's model needs (None without flown gains).
    pub live: Option<LiveLoop>,
    /// The flight's setpoint and gyro of this axis, decimated for the report's time strip.
    pub strip: FlightStrip,
}

/// The setpoint and gyro of an axis over the whole flight, decimated to at most
/// [`FlightStrip::MAX_POINTS`] samples (every k-th: a picture, not data to analyse).
#[derive(Debug, Clone, Default)]
pub struct FlightStrip {
    /// Log seconds.
    pub t_s: Vec<f64>,
    /// The identification's instrument (the setpoint), its units (None: the fit had no instrument).
    pub setpoint: Option<Vec<f64>>,
    /// The identification's output (the gyro), its units.
    pub gyro: Vec<f64>,
}

impl FlightStrip {
    /// Most samples kept.
    pub const MAX_POINTS: usize = 4000;

    /// The strip of `id`'s output and instrument in `log` (empty when a channel cannot be read:
    /// the figure is then left out, nothing else depends on it).
    fn of(log: &Log, id: &Identification) -> FlightStrip {
        let Ok((t, y)) = log.series(&id.output) else {
            return FlightStrip::default();
        };
        let step = t.len().div_ceil(Self::MAX_POINTS).max(1);
        let pick = |v: &[f64]| v.iter().step_by(step).copied().collect::<Vec<f64>>();
        let t_s = pick(&t);
        // Held at its last sample at each kept gyro time (PX4 logs the setpoint at its own rate).
        let setpoint = id.instrument.as_ref().and_then(|name| {
            let (ts, r) = log.series(name).ok()?;
            Some(crate::identify::hold_last(&ts, &r, &t_s))
        });
        FlightStrip {
            t_s,
            setpoint,
            gyro: pick(&y),
        }
    }
}

/// Largest RMS difference between the predicted and the measured step (per unit step) that
/// passes the model check without a warning.
pub const MODEL_STEP_RMS_MAX: f64 = 0.25;

/// Overshoot (%) of the proposal's 6-DOF doublets above which a warning is printed.
pub const FLIGHT_OVERSHOOT_MAX: f64 = 30.0;

/// Largest share of the deconvolved impulse response at negative lag
/// ([`MeasuredStep::acausal_fraction`]) for which the measured step is taken as unbiased.
pub const ACAUSAL_MAX: f64 = 0.1;

/// The rate-loop model K·(Tz·s + 1)·e^(−Td·s)/(s·(τ·s + 1)) with the given parameters (Tz = 0:
/// the roll and pitch model, no zero).
fn rate_model(k: f64, tau: f64, td: f64, tz: f64) -> Result<StateSpace> {
    // Rust prints f64 without exponents, which the expression parser reads.
    let lead = if tz > 0.0 {
        format!("*({tz}*s+1)")
    } else {
        String::new()
    };
    Ok(skyloop_lti::expr::parse_model(&format!(
        "{k}{lead}*exp(-{td}*s)/(s*({tau}*s+1))"
    ))?)
}

/// Tunes from a log (see the module documentation): read and identify, the flown tune from the
/// header, the flown tune analysed and the model checked, candidates and verdict, warnings.
///
/// # Errors
/// An identification that fails (its error names the cause and the flags that change it), a
/// firmware that does not match the log's, or a tuning failure.
pub fn tune_from_log(req: &LogTuneRequest) -> Result<LogTuneOutcome> {
    check_request(req)?;
    progress(req, "identify");
    let (log, derived) = crate::firmware::open_log(&req.log, req.session)?;
    tune_from_read_log(&resolved(req, &log)?, log, derived)
}

/// [`tune_from_log`] for each of `axes` (`req.axis` is replaced), the log read once: an
/// unreadable log is the call's error; each axis's own failure (e.g. too little stick input on
/// yaw) is its entry's, so the other axes still answer.
///
/// # Errors
/// An unreadable or unrecognised log, a `firmware` that does not match it, or `--sigma` out of range.
pub fn tune_axes_from_log(req: &LogTuneRequest, axes: &[Axis]) -> Result<AxesTune> {
    check_request(req)?;
    let (log, derived) = crate::firmware::open_log(&req.log, req.session)?;
    // A firmware that does not match the log is the request's fault, not an axis's.
    let req = &resolved(req, &log)?;
    let outcomes = tune_each_axis(req, axes, &log, &derived);
    Ok(AxesTune {
        firmware: req.fw(),
        outcomes,
    })
}

/// The answer of [`tune_axes_from_log`]: the firmware the log was tuned as, and each axis's outcome
/// or refusal, in the order asked.
pub struct AxesTune {
    /// The firmware given, or the one that wrote the log.
    pub firmware: Firmware,
    /// One per axis asked: its outcome, or why it has none (render with [`super::verdict::Refusal`]).
    pub outcomes: Vec<Result<LogTuneOutcome>>,
}

fn tune_each_axis(req: &LogTuneRequest, axes: &[Axis], log: &Log, derived: &[String]) -> Vec<Result<LogTuneOutcome>> {
    let run = |req: &LogTuneRequest| -> Vec<Result<LogTuneOutcome>> {
        axes.iter()
            .map(|&axis| {
                let r = LogTuneRequest { axis, ..req.clone() };
                progress(&r, "identify");
                tune_from_read_log(&r, log.clone(), derived.to_vec())
            })
            .collect()
    };
    let outs = run(req);
    if !req.tune_filters || axes.len() < 2 {
        return outs;
    }
    // A setting every axis shares (the gyro lowpass, most D-term lowpasses) can take one value
    // only, verified on every axis: when the axes do not all propose the same one (or one cannot
    // be tuned), those settings stay as flown and every axis is tuned again around them.
    let choices: Vec<Scale> = outs.iter().map(shared_choice).collect();
    if choices.iter().all(|c| *c == choices[0]) {
        return outs;
    }
    let why = axes
        .iter()
        .zip(&choices)
        .map(|(a, c)| format!("{} gyro ×{} D-term ×{}", a.name(), c.gyro, c.dterm))
        .collect::<Vec<_>>()
        .join(", ");
    let frozen = LogTuneRequest {
        freeze_shared_filters: true,
        ..req.clone()
    };
    run(&frozen)
        .into_iter()
        .map(|r| {
            r.map(|mut o| {
                o.notes.push(format!(
                    "--tune-filters: the axes proposed different values for the filter settings they share ({why}; an axis without a proposal counts as ×1): those stay as flown; tune one axis with --tune-filters, then the others on a log flown with its settings"
                ));
                o
            })
        })
        .collect()
}

/// The factors an axis's proposal sets the shared filter settings to (×1 where it leaves them, or
/// for an axis that failed or cannot be tuned).
fn shared_choice(r: &Result<LogTuneOutcome>) -> Scale {
    let Ok(o) = r else { return Scale::FLOWN };
    let Some(pf) = o
        .proposed_filters
        .as_ref()
        .filter(|_| o.verdict.kind == VerdictKind::Propose)
    else {
        return Scale::FLOWN;
    };
    let moved = |f: &str| o.filter_changes.iter().any(|c| c.shared && c.filter == f);
    Scale {
        gyro: if moved("gyro") { pf.scale.gyro } else { 1.0 },
        dterm: if moved("dterm") { pf.scale.dterm } else { 1.0 },
    }
}

/// [`tune_from_log`] on a log's bytes already in memory (a browser's dropped file); `req.log` only
/// names it in messages.
///
/// # Errors
/// As [`tune_from_log`].
pub fn tune_from_log_bytes(req: &LogTuneRequest, bytes: &[u8]) -> Result<LogTuneOutcome> {
    check_request(req)?;
    progress(req, "identify");
    let (log, derived) = crate::firmware::open_log_bytes(bytes, &req.log.display().to_string(), req.session)?;
    tune_from_read_log(&resolved(req, &log)?, log, derived)
}

/// The firmware a log tune runs as: the one given, which must be the log's (or generic), or the
/// log's own. Checked before the identification, so a mismatch is refused at once.
fn firmware_for(given: Option<Firmware>, log: &Log) -> Result<Firmware> {
    let of_log = Firmware::of_log(log);
    match (given, of_log) {
        (Some(Firmware::Generic), _) => Ok(Firmware::Generic),
        (Some(g), Some(l)) if g == l => Ok(g),
        (Some(g), Some(l)) => Err(Error::Input(format!(
            "--firmware {} does not match the log, which is a{} {} log; leave --firmware out to use the log's ({})",
            g.name(),
            if l == Firmware::Inav { "n" } else { "" },
            l.display_name(),
            l.name(),
        ))),
        (Some(g), None) => Err(Error::Input(format!(
            "--firmware {} does not match the log, which is a CSV log (it names no firmware): give --firmware generic",
            g.name()
        ))),
        (None, Some(l)) => Ok(l),
        (None, None) => Err(Error::Input(format!(
            "{}: a CSV log names no firmware; give --firmware generic to tune a generic PID on it",
            log.source
        ))),
    }
}

impl LogTuneRequest {
    /// The firmware, resolved by [`firmware_for`] before any stage runs (generic if unresolved).
    fn fw(&self) -> Firmware {
        self.firmware.unwrap_or(Firmware::Generic)
    }
}

/// The request's own ranges, checked before the log is read: `--sigma` and `--starts`.
fn check_request(req: &LogTuneRequest) -> Result<()> {
    if !(req.sigma.is_finite() && (0.0..=5.0).contains(&req.sigma)) {
        return Err(Error::Input(format!("--sigma must be in 0..=5, got {}", req.sigma)));
    }
    super::check_starts(req.starts)
}

/// `req` with its firmware resolved against `log` by [`firmware_for`], once per log read.
fn resolved(req: &LogTuneRequest, log: &Log) -> Result<LogTuneRequest> {
    Ok(LogTuneRequest {
        firmware: Some(firmware_for(req.firmware, log)?),
        ..req.clone()
    })
}

/// The stages after the log is read (and prepared, with `derived` its notes), `req`'s firmware
/// [`resolved`].
fn tune_from_read_log(req: &LogTuneRequest, log: Log, derived: Vec<String>) -> Result<LogTuneOutcome> {
    let first = model_stages(req, log.clone(), derived.clone())?;
    let (req, (mut idn, hdr, fl, stage_notes)) = match refit_request(req, &first.0, &first.2) {
        Some((refit, why)) => match model_stages(&refit, log, derived) {
            Ok(mut second) if second.2.refusal.is_none() => {
                second.3.push(why);
                (refit, second)
            }
            _ => (req.clone(), first),
        },
        None => (req.clone(), first),
    };
    let req = &req;
    let strip = FlightStrip::of(&idn.log, &idn.id);
    let mut notes = std::mem::take(&mut idn.notes);
    notes.extend(stage_notes);
    progress(req, "candidates and 6-DOF");
    let pr = propose_stage(req, &idn, &hdr, &fl)?;
    let warnings = warnings_of(req, &fl, &pr.analysis);
    let live = fl.flown_rg.clone().map(|flown| LiveLoop {
        flown,
        held: fl.held.clone(),
        wn: fl.wn,
        gyro_noise: pr.gyro_noise.clone(),
    });
    Ok(LogTuneOutcome {
        params: BTreeMap::from_iter(
            [
                ("K".to_string(), idn.k),
                ("tau".to_string(), idn.tau),
                ("Td".to_string(), idn.td),
            ]
            .into_iter()
            .chain(idn.tz.map(|tz| ("Tz".to_string(), tz))),
        ),
        identification: idn.id,
        plant: idn.plant,
        plants: idn.plants,
        filters: hdr.filters,
        current: fl.current,
        proposed: pr.proposed,
        proposed_analysis: pr.analysis,
        measured_step: fl.measured_step,
        measured_step_error: fl.measured_step_error,
        model_step_rms: fl.model_step_rms,
        causal_step: fl.causal_step,
        causal_step_rms: fl.causal_step_rms,
        notes,
        warnings,
        verdict: pr.verdict,
        noise: pr.noise,
        front: pr.front,
        filter_changes: pr.filter_changes,
        proposed_filters: pr.proposed_filters,
        axis: req.axis,
        closed_loop: fl.closed_loop,
        crossover_check: fl.crossover,
        live,
        strip,
    })
}

/// Stages 1–3: the axis identified, the flown tune from the header, analysed and checked against
/// the flight; with the notes of stages 2 and 3 (the identification's stay in [`Identified`]).
fn model_stages(
    req: &LogTuneRequest,
    log: Log,
    derived: Vec<String>,
) -> Result<(Identified, Header, Flown, Vec<String>)> {
    let idn = identify_stage(req, log, derived)?;
    let mut notes = Vec::new();
    let hdr = header_stage(req, &idn, &mut notes)?;
    progress(req, "the flown tune");
    let fl = flown_stage(req, &idn, &hdr, &mut notes)?;
    Ok((idn, hdr, fl, notes))
}

/// Where the margins are decided: when the model disagrees with the measured loop around the flown
/// crossover and the request left the band to the preset, the request that fits the model again
/// within half to twice that crossover (the band the check compares), with the note that says so.
/// The refit is kept only if it passes every check of the flown tune (the causal step and the
/// crossover check, now partly in its own band), else the refusal stands.
fn refit_request(req: &LogTuneRequest, idn: &Identified, fl: &Flown) -> Option<(LogTuneRequest, String)> {
    if req.fmin_hz.is_some() || req.fmax_hz.is_some() {
        return None;
    }
    let c = fl.crossover.as_ref().filter(|c| c.disagrees())?;
    let top = idn.id.frf.freq_hz.last().copied()?;
    let (lo, hi) = (
        (c.crossover_hz / 2.0).max(crate::identify::PILOT_LOOP_HZ),
        (2.0 * c.crossover_hz).min(top),
    );
    if hi < 2.0 * lo {
        return None;
    }
    let (m, mf, me) = c.measured_peak();
    let (p, pf) = c.predicted_peak();
    let band = idn
        .id
        .fit_band_hz
        .map_or_else(String::new, |(a, b)| format!(" (fitted {a:.1}–{b:.1} Hz)"));
    let why = format!(
        "the first model{band} disagreed with the flight around the flown crossover ({:.1} Hz: |S| peaks at {m:.1} ± {me:.1} dB at {mf:.1} Hz measured, {p:.1} dB at {pf:.1} Hz predicted): the model was fitted again within {lo:.1}–{hi:.1} Hz, where the margins are decided, and that fit passes the checks",
        c.crossover_hz
    );
    Some((
        LogTuneRequest {
            fmin_hz: Some(lo),
            fmax_hz: Some(hi),
            ..req.clone()
        },
        why,
    ))
}

/// Stage 1: the log read once, the axis identified, the nominal plant and its uncertainty set.
struct Identified {
    log: Log,
    id: Identification,
    /// (value, standard error) of K, tau, Td.
    k: (f64, f64),
    tau: (f64, f64),
    td: (f64, f64),
    /// The yaw model's zero Tz (value, standard error), s, when the fit has one.
    tz: Option<(f64, f64)>,
    plant: StateSpace,
    plants: Vec<StateSpace>,
    log_fw: Option<Firmware>,
    notes: Vec<String>,
}

fn identify_stage(req: &LogTuneRequest, log: Log, derived: Vec<String>) -> Result<Identified> {
    let idreq = IdentifyRequest {
        data: req.log.clone(),
        axis: Some(req.axis.name().to_string()),
        session: req.session,
        fmin_hz: req.fmin_hz,
        fmax_hz: req.fmax_hz,
        ..Default::default()
    };
    // identify's refusals advise `--allow-poor-fit`, an option tune does not have: a tune is
    // never proposed from a fit identify would refuse.
    let id =
        identify_log(&log, &idreq).map_err(|e| match e {
            Error::Input(m) if m.contains("--allow-poor-fit") => Error::Input(format!(
            "{} (tune proposes no gains from such a fit; `skyloop identify LOG --axis {} --allow-poor-fit` shows it)",
            m.replace(", or pass --allow-poor-fit to see it anyway", "")
                .replace(", or pass --allow-poor-fit to see the fit anyway", "")
                .replace("; give --fmin-hz/--fmax-hz or --allow-poor-fit to fit anyway", "; give --fmin-hz/--fmax-hz")
                .replace(" or --allow-poor-fit", ""),
            req.axis.name()
        )),
            other => other,
        })?;
    let log_fw = Firmware::of_log(&log);
    let (_, fit) = id
        .fit
        .as_ref()
        .ok_or_else(|| Error::Failed("the identification gave no parametric fit".into()))?;
    let get = |n: &str| -> Result<(f64, f64)> {
        let v = *fit
            .params
            .get(n)
            .ok_or_else(|| Error::Failed(format!("the fit has no parameter {n}")))?;
        Ok((v, fit.stderr.get(n).copied().unwrap_or(f64::NAN)))
    };
    let (k, sk) = get("K")?;
    let (tau, stau) = get("tau")?;
    let (td, std_) = get("Td")?;
    // The yaw model's reaction-torque zero, when the fit has one.
    let tz = fit.params.contains_key("Tz").then(|| get("Tz")).transpose()?;
    let mut notes = derived;
    notes.push(format!(
        "plant {} identified from {} ({} → {}), fit {:.1} %",
        if tz.is_some() {
            YAW_RATE_LOOP_MODEL
        } else {
            RATE_LOOP_MODEL
        },
        req.log.display(),
        id.input,
        id.output,
        fit.fit_percent
    ));
    let (tz0, stz) = tz.unwrap_or((0.0, 0.0));
    let plant = rate_model(k, tau, td, tz0)?;
    let mut plants = vec![plant.clone()];
    if req.sigma > 0.0 {
        let spread = |s: f64| if s.is_finite() { req.sigma * s } else { 0.0 };
        let named = [("K", sk), ("tau", stau), ("Td", std_), ("Tz", stz)];
        for (n, s) in &named[..if tz.is_some() { 4 } else { 3 }] {
            if !s.is_finite() {
                notes.push(format!(
                    "the standard error of {n} is undetermined: {n} is held at its fit"
                ));
            }
        }
        let (dk, dtau, dtd, dtz) = (spread(sk), spread(stau), spread(std_), spread(stz));
        // One parameter at a time: a corner of the box would be 2σ·√3 from the fit, and τ and
        // Td trade off against each other in the fit (their errors are correlated), so the
        // corners are far less likely than the fit's ±2σ says.
        for (i, d) in [dk, dtau, dtd, dtz].into_iter().enumerate() {
            if d == 0.0 {
                continue;
            }
            for sign in [-1.0, 1.0] {
                let mut v = [k, tau, td, tz0];
                v[i] += sign * d;
                plants.push(rate_model(
                    v[0].max(k / 20.0),
                    v[1].max(1e-4),
                    v[2].max(0.0),
                    v[3].max(0.0),
                )?);
            }
        }
        let zero = if tz.is_some() {
            format!(", Tz {tz0:.5} ± {dtz:.5} s")
        } else {
            String::new()
        };
        notes.push(format!(
            "robust over K, tau, Td{} at ±{}σ: K {:.4} ± {:.4}, tau {:.5} ± {:.5} s, Td {:.5} ± {:.5} s{zero} (one at a time, clamped to K ≥ K/20, tau ≥ 0.1 ms, Td ≥ 0{})",
            if tz.is_some() { ", Tz" } else { "" },
            req.sigma, k, dk, tau, dtau, td, dtd,
            if tz.is_some() { ", Tz ≥ 0" } else { "" }
        ));
    }
    Ok(Identified {
        log,
        k: (k, sk),
        tau: (tau, stau),
        td: (td, std_),
        tz,
        plant,
        plants,
        log_fw,
        notes,
        id,
    })
}

/// Stage 2: the flown tune from the header: the tuning request with the firmware's controller
/// (filters, loop rate, feedforward, plant units), the filter lines for the report, and the flown
/// tune as the firmware model reads it.
struct Header {
    treq: TuneRequest,
    filters: Vec<String>,
    flown: Option<FlownTune>,
}

fn header_stage(req: &LogTuneRequest, idn: &Identified, notes: &mut Vec<String>) -> Result<Header> {
    let mut treq = TuneRequest::new(idn.plant.clone(), req.fw());
    treq.extra_plants = idn.plants[1..].to_vec();
    treq.axis = req.axis;
    treq.structure = req.structure;
    treq.d_filter_tau_s = req.d_filter_tau_s;
    treq.goals = req.goals.clone();
    treq.maximize = req.maximize;
    treq.starts = req.starts;
    treq.tune_feedforward = req.tune_feedforward;
    let flown = flown_tune(&idn.log, req.fw(), req.axis)?;
    let mut filters = Vec::new();
    match &flown {
        Some(f) => {
            filters.clone_from(&f.lines);
            notes.extend(f.notes.iter().cloned());
            treq.controller = Some(f.controller.clone());
            treq.feedforward_flown = f.gains_flown;
        }
        None if req.fw() == Firmware::Generic => {
            notes.push("generic: the current gains are not compared (their units are the firmware's)".into());
        }
        None => notes.push("the log header carries no rate-controller tuning: nothing to compare".into()),
    }
    let settings = flown.as_ref().and_then(|f| f.filter_settings.as_ref());
    if req.tune_filters && settings.is_none_or(|d| d.settings.is_empty()) {
        notes.push(
            "--tune-filters: the filters are left as flown (the log states no gyro or D-term lowpass cutoff)".into(),
        );
    }
    if req.tune_filters {
        notes.extend(tracking_notches_note(&idn.log));
    }
    Ok(Header { treq, filters, flown })
}

/// Why `--tune-filters` leaves a log's tracking notches (dynamic notch, RPM filter) as flown, None
/// when it has none: they sit on peaks that move with throttle, the logged gyro is after them (so
/// what they remove is seen only in a raw-gyro log whose flown chain reproduces the logged gyro),
/// and the loop model is one operating point.
fn tracking_notches_note(log: &Log) -> Option<String> {
    use crate::firmware::{filters::StageKind, flown_chain};
    let (chain, _) = flown_chain(log)?;
    let names: Vec<String> = chain
        .stages
        .iter()
        .filter(|s| matches!(s.kind, StageKind::DynamicNotch { .. } | StageKind::Rpm { .. }))
        .map(|s| s.describe())
        .collect();
    (!names.is_empty()).then(|| {
        format!(
            "--tune-filters: {} left as flown: tracking notches follow peaks that move with throttle and act before the logged gyro; judge a change with `skyloop noise LOG --filters` on a log with the raw gyro (debug GYRO_SCALED) and eRPM",
            names.join("; ")
        )
    })
}

/// Stage 3: the flown tune analysed on the identified plant (exact margins over the uncertainty
/// set, 6-DOF), and the model checked against the flight (the causal step, the closed loop).
struct Flown {
    held: Vec<StateSpace>,
    flight_setup: Option<FlightSetup>,
    wn: f64,
    flown_rg: Option<RateGains>,
    current: Option<TuneAnalysis>,
    measured_step: Option<MeasuredStep>,
    measured_step_error: Option<String>,
    causal_step: Option<MeasuredStep>,
    model_step_rms: Option<f64>,
    causal_step_rms: Option<f64>,
    closed_loop: Option<super::model_check::ClosedLoopCheck>,
    crossover: Option<super::model_check::CrossoverCheck>,
    refusal: Option<String>,
}

fn flown_stage(req: &LogTuneRequest, idn: &Identified, hdr: &Header, notes: &mut Vec<String>) -> Result<Flown> {
    let (log, id, plants, log_fw) = (&idn.log, &idn.id, &idn.plants, idn.log_fw);
    let (k, tau, td) = (idn.k.0, idn.tau.0, idn.td.0);
    let loop_hz = hdr.treq.controller.as_ref().map(RateGains::loop_hz);
    let held: Vec<StateSpace> = plants.iter().map(|p| with_hold(p, loop_hz)).collect::<Result<_>>()?;
    // The nonlinear check flies the identified axis with the log's own units and limits:
    // (loop rate, gyro unit in rad/s, output limit).
    let flight_units = match (log_fw.and_then(|f| f.flight_units()), loop_hz) {
        (Some((unit, limit)), Some(hz)) if idn.tz.is_none() => Some((hz, unit, limit)),
        _ => None,
    };
    if let Some((tz, _)) = idn.tz {
        notes.push(format!(
            "the 6-DOF check is not flown on this axis: the simulator's motors have a lag only, not the reaction-torque lead (Tz = {:.1} ms) of the identified yaw model; the margins, the predicted step and the model checks use the full model",
            1e3 * tz
        ));
    }
    let flight_setup = flight_units.map(|(loop_hz, gyro_unit_rad_s, output_limit)| FlightSetup {
        k,
        tau_s: tau,
        td_s: td,
        loop_hz,
        gyro_unit_rad_s,
        output_limit,
        setpoint_accel_deg_s2: hdr.flown.as_ref().and_then(|f| f.setpoint_accel_deg_s2),
    });
    let wn = 3.0 * skyloop_robust::structured::systune::ultimate_point(&held[0])?.0;
    let flown_rg = hdr.flown.as_ref().and_then(FlownTune::gains).cloned();
    let at_d_max = hdr.flown.as_ref().and_then(FlownTune::at_d_max);
    let current = match &flown_rg {
        Some(g) => {
            if let Some((full, d_max)) = &at_d_max {
                // The same tune at its D maximum, for comparison.
                let m = check_loop(&held[0], &full.feedback_controller()?)?;
                notes.push(format!(
                    "the flown tune with D at its maximum d = {d_max}: disk alpha {:.3}, PM {:.1} deg at {:.2} Hz, GM {:.2} dB, Ms {:.3}",
                    m.disk_alpha, m.phase_margin_deg, m.crossover_hz, m.gain_margin_db, m.ms
                ));
            }
            // The header's gains as the pilot reads them (Betaflight with d_min: D at its maximum).
            let gains_json = at_d_max
                .as_ref()
                .map_or_else(|| g.to_json(), |(full, _)| full.to_json());
            Some(analyse(
                gains_json,
                &g.feedback_controller()?,
                &g.reference_path()?,
                &held,
                wn,
                flight_setup.as_ref(),
            )?)
        }
        None => None,
    };

    // The measured step: setpoint (the instrument) → gyro over the airborne segments.
    let (wiener, causal) = measured(log, id);
    let (measured_step, measured_step_error) = match wiener {
        Ok(s) => (Some(s), None),
        Err(e) => (None, Some(e.to_string())),
    };
    let causal_step = causal.ok();
    let model_step_rms = match (&measured_step, &current) {
        (Some(m), Some(c)) => Some(step_rms(m, c)?),
        _ => None,
    };
    let causal_step_rms = match (&causal_step, &current) {
        (Some(m), Some(c)) => Some(step_rms(m, c)?),
        _ => None,
    };
    let closed_loop = current.as_ref().and_then(|c| {
        super::model_check::closed_loop_check(log, id, &held[0], &c.feedback_controller, &c.reference_path)
            .map_err(|e| notes.push(format!("no closed-loop check: {e}")))
            .ok()
    });
    // Where the margins are decided: S and T of the flown loop on the measured plant around the
    // flown crossover, against the model's.
    let crossover = current.as_ref().and_then(|c| {
        super::model_check::crossover_check(
            &id.frf,
            &plants[0],
            &held[0],
            &c.feedback_controller,
            c.margins.crossover_hz,
        )
        .map_err(|e| notes.push(format!("no check at the flown crossover: {e}")))
        .ok()
    });
    let refusal = refusal(req, current.as_ref(), causal_step_rms).or_else(|| {
        crossover.as_ref().filter(|c| c.disagrees()).map(|c| {
            let (m, mf, me) = c.measured_peak();
            let (p, pf) = c.predicted_peak();
            format!(
                "the model is wrong where the margins are decided: around the flown crossover ({:.1} Hz) the flown loop's |S| peaks at {m:.1} ± {me:.1} dB ({mf:.1} Hz) on the plant the flight measured but at {p:.1} dB ({pf:.1} Hz) on the identified model (the rate-loop model lacks dynamics the data show there: a second lag, a resonance, or filter phase); fly {} stick snaps or a chirp so a richer model can be fitted",
                c.crossover_hz,
                req.axis.name()
            )
        })
    });
    Ok(Flown {
        held,
        flight_setup,
        wn,
        flown_rg,
        current,
        measured_step,
        measured_step_error,
        causal_step,
        model_step_rms,
        causal_step_rms,
        closed_loop,
        crossover,
        refusal,
    })
}

/// Stage 4: candidates, their verification and the verdict (the bounded search around the flown
/// gains where the header has them, the optimizer otherwise).
struct Proposal {
    proposed: TuneOutcome,
    analysis: TuneAnalysis,
    verdict: Verdict,
    front: Vec<(Value, Scores, f64)>,
    noise: Option<NoiseReport>,
    gyro_noise: Option<noise::GyroNoise>,
    filter_changes: Vec<FilterChange>,
    proposed_filters: Option<ProposedFilters>,
}

fn propose_stage(req: &LogTuneRequest, idn: &Identified, hdr: &Header, fl: &Flown) -> Result<Proposal> {
    let (log, id) = (&idn.log, &idn.id);
    let treq = &hdr.treq;
    let (held, wn, refusal) = (&fl.held, fl.wn, &fl.refusal);
    let ax = req.axis.index();
    let mut front_pts = Vec::new();
    let mut noise_report = None;
    let mut gyro_noise = None;
    let mut filter_changes = Vec::new();
    let mut proposed_filters = None;
    let (proposed, proposed_analysis, verdict) = match (&fl.flown_rg, &fl.current) {
        (Some(g), Some(cur)) => {
            let spans: Vec<(f64, f64)> = id.segments.iter().map(|s| (s.from_s, s.to_s)).collect();
            let dterm = format!("axisD[{ax}]");
            let dterm = log.series(&dterm).is_ok().then_some(dterm.as_str());
            let gn = noise::measure(log, &id.output, dterm, &spans, cur.margins.crossover_hz)?;
            gyro_noise = Some(gn.clone());
            if let Some(why) = &refusal {
                let mut out = outcome_for_gains(g, held, &req.goals, Vec::new())?;
                out.cli.clear();
                let mut nr = noise_of(&gn, &gn, g, g, held)?;
                nr.budget = Some(req.noise_budget);
                noise_report = Some(nr);
                (out, cur.clone(), Verdict::cannot(req.axis, why))
            } else {
                let settings = hdr
                    .flown
                    .as_ref()
                    .and_then(|f| f.filter_settings.as_ref())
                    .filter(|_| req.tune_filters)
                    .map(|d| {
                        if req.freeze_shared_filters {
                            d.per_axis_only()
                        } else {
                            d.clone()
                        }
                    })
                    .filter(|d| !d.settings.is_empty());
                let r = grid_proposal(req, g, cur, held, &gn, wn, fl.flight_setup.as_ref(), settings.as_ref())?;
                filter_changes = r.filter_changes;
                proposed_filters = r.proposed_filters;
                front_pts = r.front;
                noise_report = Some(r.noise);
                (r.outcome, r.analysis, r.verdict)
            }
        }
        _ => {
            let mut proposed = tune(treq)?;
            let c_r_proposed = proposed_reference_path(req, &proposed)?;
            let pa = analyse(
                proposed.gains.clone(),
                &proposed.feedback_controller,
                &c_r_proposed,
                held,
                wn,
                fl.flight_setup.as_ref(),
            )?;
            let verdict = match &refusal {
                Some(why) => {
                    proposed.cli.clear();
                    Verdict::cannot(req.axis, why)
                }
                None => Verdict {
                    kind: VerdictKind::Propose,
                    text: format!(
                        "{}: proposal tuned from the identified model (no flown gains to compare with): crossover {:.1} Hz, disk α {:.2}",
                        req.axis.name(), pa.margins.crossover_hz, pa.margins.disk_alpha
                    ),
                },
            };
            (proposed, pa, verdict)
        }
    };
    let mut proposed = proposed;
    if let Some((line, why)) = hdr.flown.as_ref().and_then(FlownTune::constant_d_line) {
        if verdict.kind == VerdictKind::Propose {
            let at = proposed.cli.len().saturating_sub(1);
            proposed.cli.insert(at, line.clone());
            proposed.notes.push(format!("`{line}`: {why}"));
        }
    }
    Ok(Proposal {
        proposed,
        analysis: proposed_analysis,
        verdict,
        front: front_pts,
        noise: noise_report,
        gyro_noise,
        filter_changes,
        proposed_filters,
    })
}

/// Stage 5: what the pilot must act on.
fn warnings_of(req: &LogTuneRequest, fl: &Flown, proposed_analysis: &TuneAnalysis) -> Vec<String> {
    let (current, measured_step, causal_step) = (&fl.current, &fl.measured_step, &fl.causal_step);
    let (causal_step_rms, model_step_rms, closed_loop) = (fl.causal_step_rms, fl.model_step_rms, &fl.closed_loop);
    // The flown tune flew: a model that calls it unstable, or predicts a step far from the one
    // measured, is wrong, and so would be gains tuned on it.
    let mut warnings = Vec::new();
    if let Some(c) = &current {
        if !c.margins.stable {
            warnings.push(
                "the identified model predicts the flown tune to be UNSTABLE, yet it flew: the model is wrong (try another band, --fmin-hz/--fmax-hz, or another session); do not fly the proposal".to_string(),
            );
        }
    }
    // The causal fit is the check's reference where it exists: the deconvolution is biased by a
    // pilot in the loop (and by coloured disturbances), the causal fit much less.
    let acausal = measured_step.as_ref().map_or(0.0, |m| m.acausal_fraction);
    match (causal_step_rms, causal_step) {
        (Some(r), Some(c)) if r > MODEL_STEP_RMS_MAX => warnings.push(format!(
            "the predicted step of the flown tune differs from the step measured in the log (causal fit) by {r:.3} RMS (more than {MODEL_STEP_RMS_MAX}): the model does not describe this craft well; treat the proposal with care{}",
            if c.acausal_fraction > ACAUSAL_MAX {
                format!(" (the future setpoint explains {:.0} % of the fit's residual: a pilot reacting to the craft may bias the measurement too)", 100.0 * c.acausal_fraction)
            } else {
                String::new()
            }
        )),
        (Some(_), _) => {}
        _ => {
            if let Some(r) = model_step_rms.filter(|r| *r > MODEL_STEP_RMS_MAX) {
                if acausal > ACAUSAL_MAX {
                    warnings.push(format!(
                        "the predicted step of the flown tune differs from the step measured in the log by {r:.3} RMS (more than {MODEL_STEP_RMS_MAX}), \
                         but the measured step is itself biased: {:.0} % of the deconvolved impulse response lies before the setpoint moves \
                         (typically a pilot correcting what the craft just did, so the setpoint depends on past gyro), so it comes out short; the check cannot tell whether the model is wrong",
                        100.0 * acausal
                    ));
                } else {
                    warnings.push(format!(
                        "the predicted step of the flown tune differs from the step measured in the log by {r:.3} RMS (more than {MODEL_STEP_RMS_MAX}): the model does not describe this craft well; treat the proposal with care"
                    ));
                }
            }
        }
    }
    if let Some(c) = closed_loop.as_ref().filter(|c| c.disagrees()) {
        warnings.push(format!(
            "the flown tune's closed-loop peak: measured {:.1} dB at {:.1} Hz, predicted {:.1} dB at {:.1} Hz (more than {} dB apart): the model's loop near crossover is off",
            c.measured_peak.0, c.measured_peak.1, c.predicted_peak.0, c.predicted_peak.1, super::model_check::PEAK_DB_MAX
        ));
    }
    if let Some(f) = &proposed_analysis.flight {
        let worst = f.worst_overshoot_pct();
        if f.crashed {
            warnings.push("the proposal CRASHED the 6-DOF quadrotor in the nonlinear check: do not fly it".into());
        } else if worst > FLIGHT_OVERSHOOT_MAX {
            let flown = current
                .as_ref()
                .and_then(|c| c.flight.as_ref())
                .map(FlightCheck::worst_overshoot_pct);
            warnings.push(format!(
                "in the 6-DOF check the proposal overshoots a fast stick move by {worst:.0} %{}: its margins hold, but the tracking is lively; {}the check models no I-term relax; ask for more phase margin (--goal phase_margin_deg>=45){}",
                flown.map(|v| format!(" (the flown tune: {v:.0} %)")).unwrap_or_default(),
                if req.tune_feedforward {
                    "the feedforward is fitted on the linear model, without motor saturation; "
                } else {
                    "the feedforward is kept as flown while P and D change; "
                },
                if req.maximize == Maximize::IntegralGain {
                    ", or maximize the crossover instead of the integral gain (--maximize crossover)"
                } else {
                    ""
                }
            ));
        }
    }
    warnings
}

/// The setpoint → gyro step of the airborne segments, two ways: PID-Analyzer's deconvolution
/// ([`deconv`](super::deconv)) and the causal FIR fit ([`fir_step`](super::fir_step)).
fn measured(log: &Log, id: &Identification) -> (Result<MeasuredStep>, Result<MeasuredStep>) {
    let Some(r) = id.instrument.as_deref() else {
        let e = || Err(Error::Input("no setpoint channel to deconvolve".into()));
        return (e(), e());
    };
    let data = match log.uniform(&[r, id.output.as_str()], None, None, None) {
        Ok(d) => d,
        Err(e) => {
            let msg = Error::from(e).to_string();
            return (Err(Error::Failed(msg.clone())), Err(Error::Failed(msg)));
        }
    };
    let ranges: Vec<std::ops::Range<usize>> = id.segments.iter().map(|s| data.range_of(s)).collect();
    let o = DeconvOptions::default();
    let (x, y) = (&data.columns[0], &data.columns[1]);
    (
        step_from_log(x, y, data.dt_s, &ranges, &o),
        super::fir_step::causal_step(x, y, data.dt_s, &ranges, o.response_s),
    )
}

/// RMS of the predicted step (linearly interpolated) minus the measured one.
fn step_rms(m: &MeasuredStep, c: &TuneAnalysis) -> Result<f64> {
    let (t, y) = (&c.step_t_s, &c.step_y);
    if t.len() < 2 {
        return Err(Error::Failed("predicted step has fewer than 2 samples".into()));
    }
    let at = |x: f64| {
        let dt = t[1] - t[0];
        let i = ((x / dt).floor() as usize).min(t.len() - 2);
        let f = (x - t[i]) / dt;
        y[i] * (1.0 - f) + y[i + 1] * f
    };
    let n = m.t_s.len();
    let s: f64 = m.t_s.iter().zip(&m.y).map(|(&x, &v)| (at(x) - v).powi(2)).sum();
    Ok((s / n as f64).sqrt())
}

pub(crate) fn analyse(
    gains: Value,
    c: &StateSpace,
    cr: &StateSpace,
    held: &[StateSpace],
    wn: f64,
    flight: Option<&FlightSetup>,
) -> Result<TuneAnalysis> {
    let margins = check_loop(&held[0], c)?;
    let mut worst = margins;
    for p in &held[1..] {
        let m = check_loop(p, c)?;
        worst.stable &= m.stable;
        worst.disk_alpha = worst.disk_alpha.min(m.disk_alpha);
        worst.gain_margin_db = worst.gain_margin_db.min(m.gain_margin_db);
        worst.phase_margin_deg = worst.phase_margin_deg.min(m.phase_margin_deg);
        worst.crossover_hz = worst.crossover_hz.min(m.crossover_hz);
        worst.ms = worst.ms.max(m.ms);
        worst.mt = worst.mt.max(m.mt);
    }
    let ev = skyloop_lti::freqresp::FreqEvaluator::new(c)?;
    let noise_gain = sampled_peak(
        |w| {
            ev.eval(c64::new(0.0, w))
                .map(|m| m[(0, 0)].norm())
                .unwrap_or(f64::INFINITY)
        },
        wn,
        wn * 1e3,
        600,
    )
    .1;
    // y/r = P·C_r/(1 + P·C_fb), the delay as Padé order 6 (inside the loop it has no exact
    // state-space form).
    let pp = held[0].try_pade(6)?;
    let cl = series(cr, &feedback(&pp, c, -1.0)?)?;
    let t: Vec<f64> = (0..=500).map(|k| k as f64 * 0.001).collect();
    let st = skyloop_lti::timeresp::step(&cl, Some(&t))?;
    let y = st.y[0][0].clone();
    let info = skyloop_lti::timeresp::stepinfo(&t, &y, Some(1.0));
    // An unstable loop is not flown: its verdict is already in the margins.
    let flight = match flight {
        Some(setup) if margins.stable => Some(fly(setup, c, cr)?),
        _ => None,
    };
    Ok(TuneAnalysis {
        gains,
        feedback_controller: c.clone(),
        reference_path: cr.clone(),
        margins,
        worst,
        noise_gain,
        step_t_s: t,
        step_y: y,
        rise_time_s: info.rise_time_s,
        overshoot_pct: info.overshoot_pct,
        flight,
    })
}

impl TuneAnalysis {
    /// `{gains, margins, worst_margins, noise_gain, step: {t_s, y}, rise_time_s, overshoot_pct}`.
    pub fn to_json(&self) -> Value {
        json!({
            "gains": self.gains,
            "feedback_controller": skyloop_lti::json::LtiJson::from_ss(&self.feedback_controller),
            "margins": super::margins_json(&self.margins),
            "worst_margins": super::margins_json(&self.worst),
            "noise_gain": self.noise_gain,
            "step": {"t_s": self.step_t_s, "y": self.step_y},
            "rise_time_s": self.rise_time_s,
            "overshoot_pct": self.overshoot_pct,
            "flight": self.flight.as_ref().map(FlightCheck::to_json),
        })
    }
}

impl LogTuneOutcome {
    /// The proposal's JSON (as [`TuneOutcome::to_json`]: `gains`, `feedback_controller`,
    /// `margins`, `goals`, `cli`, ...) plus `current` (the flown tune analysed, with `gains` of the
    /// same keys), `proposed` (the proposal analysed likewise), `identification` (params, stderr,
    /// fit percent, band), `segments` (the flight cut into stretches `{start_s, end_s, used,
    /// reason}`: which the identification used and why the others were not), `measured_step` and
    /// `model_step_rms`.
    pub fn to_json(&self) -> Value {
        let mut v = self.proposed.to_json();
        v["segments"] = json!(self.identification.timeline);
        v["current"] = self.current.as_ref().map(TuneAnalysis::to_json).unwrap_or(Value::Null);
        v["proposed"] = self.proposed_analysis.to_json();
        let fit = self.identification.fit.as_ref().map(|(_, f)| f);
        v["identification"] = json!({
            "params": self.params.iter().map(|(k, (x, _))| (k.clone(), json!(x))).collect::<serde_json::Map<_, _>>(),
            "stderr": self.params.iter().map(|(k, (_, s))| (k.clone(), if s.is_finite() { json!(s) } else { Value::Null })).collect::<serde_json::Map<_, _>>(),
            "fit_percent": fit.map(|f| f.fit_percent),
            "segments": self.identification.segments,
            "warnings": self.identification.warnings,
            "plants": self.plants.len(),
        });
        v["filters"] = json!(self.filters);
        v["measured_step"] = match &self.measured_step {
            Some(m) => {
                json!({"t_s": m.t_s, "y": m.y, "y_std": m.y_std, "windows": m.windows, "windows_total": m.windows_total, "acausal_fraction": m.acausal_fraction})
            }
            None => Value::Null,
        };
        v["measured_step_error"] = json!(self.measured_step_error);
        v["model_step_rms"] = json!(self.model_step_rms);
        v["causal_step"] = match &self.causal_step {
            Some(m) => {
                json!({"t_s": m.t_s, "y": m.y, "y_std": m.y_std, "blocks": m.windows, "future_setpoint_share": m.acausal_fraction})
            }
            None => Value::Null,
        };
        v["causal_step_rms"] = json!(self.causal_step_rms);
        v["warnings"] = json!(self.warnings);
        v["axis"] = json!(self.axis.name());
        v["closed_loop_check"] = self
            .closed_loop
            .as_ref()
            .map_or(Value::Null, super::model_check::ClosedLoopCheck::to_json);
        v["crossover_check"] = self
            .crossover_check
            .as_ref()
            .map_or(Value::Null, super::model_check::CrossoverCheck::to_json);
        v["verdict"] = self.verdict.to_json();
        v["noise"] = self.noise.as_ref().map_or(Value::Null, NoiseReport::to_json);
        v["front"] = json!(self
            .front
            .iter()
            .map(|(g, s, r)| json!({
                "gains": g,
                "crossover_hz": s.crossover_hz,
                "disk_alpha": s.alpha,
                "worst_disk_alpha": s.alpha_worst,
                "noise_ratio": r,
            }))
            .collect::<Vec<_>>());
        v["filter_changes"] = json!(self
            .filter_changes
            .iter()
            .map(|c| json!({"name": c.name, "filter": c.filter, "shared": c.shared, "flown_hz": c.flown_hz, "proposed_hz": c.proposed_hz, "reason": c.reason}))
            .collect::<Vec<_>>());
        v["filters_proposed"] = self
            .proposed_filters
            .as_ref()
            .map_or(Value::Null, ProposedFilters::to_json);
        if let Some(pf) = self.proposed_filters.as_ref().filter(|p| p.gyro.0 != p.gyro.1) {
            // The proposal's loop has the gyro lowpass changed inside the plant: say so where a
            // verifier reads how to rebuild the loop.
            v["loop"]["definition"] = json!(
                "L = plant * G_new/G_flown * exp(-extra_delay_s*s) * feedback_controller: the loop the margins are computed for; G_flown and G_new are the gyro lowpass chains in loop.gyro_lowpass (the logged gyro is after the flown one, so the identified plant contains it), extra_delay_s the loop's sample and hold"
            );
            v["loop"]["gyro_lowpass"] = json!({
                "flown": crate::firmware::filter_settings::chain_json(&pf.gyro.0),
                "proposed": crate::firmware::filter_settings::chain_json(&pf.gyro.1),
            });
        }
        if let Some(n) = v["notes"].as_array_mut() {
            for x in &self.notes {
                n.push(json!(x));
            }
        }
        v
    }
}

/// Reports a stage to the caller's progress callback.
fn progress(req: &LogTuneRequest, stage: &str) {
    if let Some(f) = req.progress {
        f(req.axis, stage);
    }
}

/// Why the model cannot carry a proposal, with what to fly; None when it explains the flight.
fn refusal(req: &LogTuneRequest, current: Option<&TuneAnalysis>, causal_rms: Option<f64>) -> Option<String> {
    let c = current?;
    let axis = req.axis.name();
    if !c.margins.stable {
        return Some(format!(
            "the identified model predicts the flown tune to be unstable, yet it flew, so the model is wrong; fly a log with sharper {axis} stick inputs (or a chirp) and try again"
        ));
    }
    match causal_rms {
        Some(r) if r > MODEL_STEP_RMS_MAX => Some(format!(
            "the model misses the flown step measured in the log by {r:.3} RMS (limit {MODEL_STEP_RMS_MAX}); fly a chirp or sharper {axis} stick inputs so the loop can be identified"
        )),
        _ => None,
    }
}

/// The proposal's reference path (setpoint → PID output) of an optimizer outcome.
fn proposed_reference_path(req: &LogTuneRequest, proposed: &TuneOutcome) -> Result<StateSpace> {
    Ok(match &proposed.firmware_gains {
        Some(g) => g.reference_path()?,
        None if req.structure == GenericStructure::Pid2 && proposed.setpoint_weights.is_some() => {
            super::generic_reference_path(&proposed.gains)?
        }
        None => proposed.feedback_controller.clone(),
    })
}

/// The noise report of `proposed` against `flown`: the flown tune on the log's gyro spectrum `gn`,
/// the proposal on `gn_proposed` (the same, or the gyro behind a proposed gyro lowpass), with the
/// D-term check of the flown tune. Each gain set through its own D-term filters.
pub(crate) fn noise_of(
    gn: &noise::GyroNoise,
    gn_proposed: &noise::GyroNoise,
    flown: &RateGains,
    proposed: &RateGains,
    held: &[StateSpace],
) -> Result<NoiseReport> {
    let block = flown.block()?;
    let power = |g: &RateGains, gn: &noise::GyroNoise, band: (f64, f64)| -> Result<f64> {
        let (f, w) = gn.band_weights(band);
        Ok(Screen::new(&g.block()?, &held[..1], 10.0, &f, &w)?.noise(g.continuous()))
    };
    let bands = gn
        .sub_bands()
        .into_iter()
        .map(|b| Ok((b, power(flown, gn, b)?, power(proposed, gn_proposed, b)?)))
        .collect::<Result<Vec<_>>>()?;
    // The flown D path alone predicts the logged D term's spectrum.
    let dterm_check = match &gn.dterm {
        Some(d) => {
            let k = flown.continuous();
            let (f, w) = gn.weights();
            let pred = Screen::new(&block, &held[..1], 10.0, &f, &w)?.noise([0.0, 0.0, k[2]]);
            let logged = d.band_power(gn.band_hz.0, gn.band_hz.1);
            (pred > 0.0).then(|| logged / pred)
        }
        None => None,
    };
    // Per-frequency spectra from 1 Hz to Nyquist (weights S·Δf divided back by Δf).
    let all = (1.0, gn.band_hz.1);
    let (f, w) = gn.band_weights(all);
    let df = if gn.gyro.freq_hz.len() > 1 {
        gn.gyro.freq_hz[1] - gn.gyro.freq_hz[0]
    } else {
        1.0
    };
    let per_f = |g: &RateGains, gn: &noise::GyroNoise| -> Result<Vec<f64>> {
        let (f, w) = gn.band_weights(all);
        let sc = Screen::new(&g.block()?, &held[..1], 10.0, &f, &w)?;
        Ok(sc.noise_terms(g.continuous()).into_iter().map(|v| v / df).collect())
    };
    let spectra = noise::Spectra {
        gyro: w.iter().map(|v| v / df).collect(),
        gyro_proposed: if std::ptr::eq(gn, gn_proposed) {
            Vec::new()
        } else {
            gn_proposed.band_weights(all).1.iter().map(|v| v / df).collect()
        },
        flown: per_f(flown, gn)?,
        proposed: per_f(proposed, gn_proposed)?,
        dterm: gn
            .dterm
            .as_ref()
            .map(|d| {
                d.freq_hz
                    .iter()
                    .zip(&d.density)
                    .filter(|(x, _)| **x >= all.0 && **x <= all.1)
                    .map(|(_, v)| *v)
                    .collect()
            })
            .unwrap_or_default(),
        freq_hz: f,
    };
    Ok(NoiseReport {
        flown: power(flown, gn, gn.band_hz)?,
        proposed: power(proposed, gn_proposed, gn.band_hz)?,
        band_hz: gn.band_hz,
        bands,
        dterm_check,
        spectra,
        budget: None,
    })
}

/// What the grid search settled on.
struct GridResult {
    outcome: TuneOutcome,
    analysis: TuneAnalysis,
    verdict: Verdict,
    noise: NoiseReport,
    front: Vec<(Value, Scores, f64)>,
    filter_changes: Vec<FilterChange>,
    proposed_filters: Option<ProposedFilters>,
}

/// Most ranked candidates re-verified exactly (and flown in the 6-DOF check) before giving up.
const VERIFY_MAX: usize = 6;

/// The bounded search around the flown tune ([`super::candidates`]; with `settings`, the filter
/// factors too, [`super::filter_tuning`]), the exact verification of the best candidates (margins
/// over the uncertainty set, 6-DOF tracking no worse), and the verdict.
#[allow(clippy::too_many_arguments)]
fn grid_proposal(
    req: &LogTuneRequest,
    flown: &RateGains,
    cur: &TuneAnalysis,
    held: &[StateSpace],
    gn: &noise::GyroNoise,
    wn: f64,
    flight: Option<&FlightSetup>,
    settings: Option<&FilterSettings>,
) -> Result<GridResult> {
    if !(req.noise_budget.is_finite() && (1.0..=10.0).contains(&req.noise_budget)) {
        return Err(Error::Input(format!(
            "--noise-budget must be in 1..=10, got {}",
            req.noise_budget
        )));
    }
    let (nf, nw) = gn.weights();
    let f_max = 0.45 * flown.loop_hz().min(4000.0);
    let screen = Screen::new(&flown.block()?, held, f_max, &nf, &nw)?;
    let limits = SearchLimits {
        noise_budget: req.noise_budget,
        alpha_floor: 0.5,
        keep_robustness: req.maximize == Maximize::Tracking,
        rank_by_integral: req.maximize == Maximize::IntegralGain,
    };
    let (mut ranked, mut all, fs) = search(&screen, flown, &limits);
    let (variants, filter_notes) = match settings {
        Some(st) => add_filter_candidates(flown, st, &screen, held, f_max, gn, &fs, &limits, &mut ranked, &mut all)?,
        None => (Vec::new(), Vec::new()),
    };
    let plants = Plants {
        held,
        variants: &variants,
        settings,
    };
    let (chosen, rejected) = verify_candidates(flown, cur, &ranked, &fs, &limits, &plants, wn, flight)?;
    let axis = req.axis.name();
    // The front lists gain sets a pilot can type with the flown filters (its rows carry no filters).
    let with_flown_filters: Vec<_> = all.iter().filter(|c| c.scale.is_flown()).cloned().collect();
    let fr: Vec<(Value, Scores, f64)> = front(&with_flown_filters, &fs, &limits, 5)
        .into_iter()
        .map(|c| {
            (
                c.gains.to_json(),
                c.scores,
                c.scores.noise / fs.noise.max(f64::MIN_POSITIVE),
            )
        })
        .collect();
    let mut notes = vec![format!(
        "bounded change: each of P, I, D within ±{:.0} % of the flown value ({} gain sets scored, {} within the limits); the feedforward is kept as flown",
        100.0 * super::candidates::MAX_CHANGE,
        all.len(),
        ranked.len()
    )];
    notes.extend(filter_notes);
    notes.extend(rejected.into_iter().map(|r| format!("candidate rejected: {r}")));
    let (gains, scale, analysis, verdict) = match chosen {
        Some((c, a)) => {
            let gp = plants.noise_for(gn, c.scale);
            let nr = noise_of(gn, gp, flown, &c.gains, held)?;
            let text = proposal_text(
                axis,
                (cur.margins.crossover_hz, a.margins.crossover_hz),
                (cur.margins.disk_alpha, a.margins.disk_alpha),
                nr.ratio(),
            );
            (c.gains, c.scale, a, Verdict { kind: VerdictKind::Propose, text })
        }
        None => (
            flown.clone(),
            Scale::FLOWN,
            cur.clone(),
            Verdict {
                kind: VerdictKind::Keep,
                text: format!(
                    "{axis}: keep your tune: it is at the frontier of this model (no P, I, D within ±{:.0} % is faster without losing robustness or adding more than {:.0} % motor noise); the trade-off front is listed below",
                    100.0 * super::candidates::MAX_CHANGE,
                    100.0 * (req.noise_budget - 1.0)
                ),
            },
        ),
    };
    let mut noise = noise_of(gn, plants.noise_for(gn, scale), flown, &gains, held)?;
    noise.budget = Some(req.noise_budget);
    // The proposal's goals and margins on its own loop (a changed gyro lowpass is in its plants).
    let mut outcome = outcome_for_gains(&gains, plants.held_for(scale), &req.goals, notes)?;
    let (filter_changes, proposed_filters) = match settings.filter(|_| !scale.is_flown()) {
        Some(st) => {
            let pf = ProposedFilters::new(st, scale, flown, &gains);
            let ch = describe(st, &pf, analysis.margins.crossover_hz, noise.ratio(), req.noise_budget);
            add_filter_lines(&mut outcome, st, scale, &ch);
            (ch, Some(pf))
        }
        None => (Vec::new(), None),
    };
    Ok(GridResult {
        outcome,
        analysis,
        verdict,
        noise,
        front: fr,
        filter_changes,
        proposed_filters,
    })
}

/// The firmware's lines for the filters, before its `save` (Betaflight, INAV), and one note per
/// change with its reason.
fn add_filter_lines(outcome: &mut TuneOutcome, st: &FilterSettings, scale: Scale, changes: &[FilterChange]) {
    let at = outcome
        .cli
        .iter()
        .position(|l| l == "save")
        .unwrap_or(outcome.cli.len());
    outcome.cli.splice(at..at, st.cli_lines(scale));
    for ch in changes {
        outcome.notes.push(format!(
            "{} {} → {} Hz: {}",
            ch.name, ch.flown_hz, ch.proposed_hz, ch.reason
        ));
    }
}

/// The plants and gyro spectra a candidate is judged on: the identified ones, or with a changed
/// gyro lowpass, its [`GyroVariant`].
struct Plants<'a> {
    held: &'a [StateSpace],
    variants: &'a [GyroVariant],
    settings: Option<&'a FilterSettings>,
}

impl Plants<'_> {
    /// The variant of a changed gyro lowpass (None at the flown one).
    fn changed(&self, scale: Scale) -> Option<&GyroVariant> {
        variant_of(self.variants, scale).filter(|v| v.ratio.is_some())
    }

    fn held_for(&self, scale: Scale) -> &[StateSpace] {
        self.changed(scale).map_or(self.held, |v| &v.held)
    }

    fn noise_for<'g>(&'g self, gn: &'g noise::GyroNoise, scale: Scale) -> &'g noise::GyroNoise {
        self.changed(scale).map_or(gn, |v| &v.noise)
    }
}

/// A candidate that passed the verification, with its analysis.
type Verified = (super::candidates::Candidate, TuneAnalysis);

/// The ranked candidates verified in turn (exact delay over the uncertainty set, the 6-DOF
/// check) until one passes: it, with its analysis, and why each one before it was rejected.
#[allow(clippy::too_many_arguments)]
fn verify_candidates(
    flown: &RateGains,
    cur: &TuneAnalysis,
    ranked: &[super::candidates::Candidate],
    fs: &Scores,
    limits: &SearchLimits,
    plants: &Plants,
    wn: f64,
    flight: Option<&FlightSetup>,
) -> Result<(Option<Verified>, Vec<String>)> {
    let floor = 0.5f64.min(cur.worst.disk_alpha);
    let flown_os = cur.flight.as_ref().map(FlightCheck::worst_overshoot_pct);
    let os_limit = flown_os.map(|o| (o + 5.0).max(20.0));
    let mut chosen = None;
    let mut rejected = Vec::new();
    let below_floor = fs.alpha_worst < limits.alpha_floor;
    // One candidate per (P, D, filters): neighbours that differ in I alone fail for the same reason.
    let mut seen = Vec::new();
    let distinct = ranked
        .iter()
        .filter(|c| c.gains != *flown || !c.scale.is_flown())
        .filter(|c| {
            let k = c.gains.continuous();
            let sc = (
                (c.scale.gyro * 100.0).round() as i64,
                (c.scale.dterm * 100.0).round() as i64,
            );
            let key = ((k[0] * 1e6).round() as i64, (k[2] * 1e9).round() as i64, sc);
            let new = !seen.contains(&key);
            seen.push(key);
            new
        });
    for c in distinct.take(VERIFY_MAX) {
        let gain = if limits.keep_robustness {
            c.scores.bandwidth_hz / fs.bandwidth_hz.max(1e-9) - 1.0
        } else {
            c.scores.crossover_hz / fs.crossover_hz.max(1e-9) - 1.0
        };
        let more_robust = c.scores.alpha_worst > fs.alpha_worst + 0.05;
        if gain < super::candidates::MIN_GAIN && !more_robust {
            break;
        }
        let a = analyse(
            c.gains.to_json(),
            &c.gains.feedback_controller()?,
            &c.gains.reference_path()?,
            plants.held_for(c.scale),
            wn,
            flight,
        )?;
        let why = cutoff_rule(plants.settings, c.scale, &c.gains, a.margins.crossover_hz)
            .or_else(|| rejection(&a, cur, floor, os_limit, below_floor));
        match why {
            None => {
                chosen = Some((c.clone(), a));
                break;
            }
            Some(w) => rejected.push(format!("{}: {w}", c.gains.to_json())),
        }
    }
    Ok((chosen, rejected))
}

/// Why a candidate analysed as `a` cannot be proposed over the flown tune `cur`, None when it
/// can: unstable, below the robustness floor, slower and less robust, crashed or tracking worse
/// in the 6-DOF check, or overshooting there.
fn rejection(
    a: &TuneAnalysis,
    cur: &TuneAnalysis,
    floor: f64,
    os_limit: Option<f64>,
    below_floor: bool,
) -> Option<String> {
    let os = a.flight.as_ref().map(FlightCheck::worst_overshoot_pct);
    if !a.margins.stable || !a.worst.stable {
        Some("unstable in the exact check".to_string())
    } else if a.worst.disk_alpha < floor - 1e-3 {
        Some(format!(
            "worst-case disk α {:.3} below the floor {floor:.3}",
            a.worst.disk_alpha
        ))
    } else if a.margins.crossover_hz < cur.margins.crossover_hz && a.margins.disk_alpha < cur.margins.disk_alpha {
        Some("slower and less robust than the flown tune in the exact check".to_string())
    } else if a.flight.as_ref().is_some_and(|f| f.crashed) {
        Some("crashed the 6-DOF check".to_string())
    } else if let (Some(p), Some(f), false) = (&a.flight, &cur.flight, below_floor) {
        // Above the floor a proposal must track at least as well; below it, robustness first.
        let (ep, ef) = (p.doublets[0].rms_error_deg_s, f.doublets[0].rms_error_deg_s);
        (ep > 1.05 * ef).then(|| format!("6-DOF tracking error {ep:.0} deg/s RMS above the flown tune's {ef:.0}"))
    } else {
        match (os, os_limit) {
            (Some(o), Some(l)) if o > l => Some(format!("6-DOF overshoot {o:.0} % above {l:.0} %")),
            _ => None,
        }
    }
}
