//! `skyloop tune`: gains a flight controller can load, tuned against margin goals with the
//! fixed-structure optimizer of skyloop-robust ([`skyloop_robust::structured::systune`]), mapped
//! to the firmware's own gains ([`crate::firmware`]), rounded as the firmware stores them, and
//! re-verified with the exact plant (delay and the loop's sample and hold kept) after rounding.
//!
//! Defaults a pilot can trust, added unless the user gives a goal of the same kind: a disk-margin
//! floor α ≥ 0.5 (±5.6 dB and ±28° simultaneously), and a noise limit: |C_fb(jω)| ≤ 10·Ku for
//! ω ≥ 3·ω_u, with Ku, ω_u the plant's ultimate gain and frequency (so gyro noise above the loop's
//! bandwidth is amplified at most ten times the gain that would make the loop oscillate).

use crate::error::{Error, Result};
use crate::firmware::betaflight::{self, Axis};
use crate::firmware::rate_gains::RateGains;
use crate::firmware::{self, ardupilot, inav, px4};
use serde_json::{json, Value};
use skyloop_lti::json::LtiJson;
use skyloop_lti::StateSpace;
use skyloop_robust::structured::blocks::{Block, DerivativeFilter, Structure};
use skyloop_robust::structured::goals::{Bound, Goal, Requirement};
use skyloop_robust::structured::systune::{
    evaluate, tune_loop, ultimate_point, GoalReport, LoopTuning, Objective, TuneOptions,
};
use skyloop_robust::structured::verify::LoopCheck;
use std::f64::consts::PI;

pub mod candidates;
pub mod deconv;
pub mod feedforward;
pub mod filter_tuning;
pub mod fir_step;
pub mod flight;
pub mod live;
pub mod log;
pub mod model_check;
pub mod noise;
pub mod report;
pub mod verdict;

pub use crate::firmware::Firmware;

/// The generic controller's structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GenericStructure {
    /// kp + ki/s.
    Pi,
    /// kp + ki/s + kd·s/(tf·s + 1) (tf tuned unless fixed).
    Pid,
    /// The same feedback with setpoint weights b and c (MATLAB's `pid2`):
    /// u = kp·(b·r − y) + ki/s·(r − y) + kd·s/(tf·s + 1)·(c·r − y); b and c fitted for tracking
    /// ([`feedforward::fit_setpoint_weights`]).
    Pid2,
}

impl GenericStructure {
    /// Parses "pi", "pid", "pidf" (MATLAB's name for the same filtered PID) or "pid2" (two
    /// degrees of freedom).
    ///
    /// # Errors
    /// Any other text.
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "pi" => Ok(GenericStructure::Pi),
            "pid" | "pidf" => Ok(GenericStructure::Pid),
            "pid2" => Ok(GenericStructure::Pid2),
            _ => Err(Error::Input(format!(
                "--structure must be pi, pid, pidf or pid2, got `{s}`"
            ))),
        }
    }
}

/// What to maximize once the goals hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Maximize {
    /// The integral gain ki (MIGO: best load-disturbance rejection).
    IntegralGain,
    /// The gain-crossover frequency.
    Crossover,
    /// A pilot's default from a log: the highest crossover at no loss of robustness against the
    /// flown tune (with --plant, as `Crossover`).
    Tracking,
}

impl Maximize {
    /// Parses "integral_gain", "crossover" or "tracking".
    ///
    /// # Errors
    /// Any other text.
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "integral_gain" => Ok(Maximize::IntegralGain),
            "crossover" => Ok(Maximize::Crossover),
            "tracking" => Ok(Maximize::Tracking),
            _ => Err(Error::Input(format!(
                "--maximize must be tracking, crossover or integral_gain, got `{s}`"
            ))),
        }
    }
}

/// A tuning request.
#[derive(Debug, Clone)]
pub struct TuneRequest {
    /// The plant, continuous SISO, in the firmware's units (Betaflight: PID sum → gyro deg/s;
    /// PX4: normalized torque → rad/s; generic: any), exact delays allowed.
    pub plant: StateSpace,
    /// Further plants the goals must hold for (e.g. the identified ±2σ models).
    pub extra_plants: Vec<StateSpace>,
    /// Firmware.
    pub firmware: Firmware,
    /// Axis (names of the gains).
    pub axis: Axis,
    /// Generic structure.
    pub structure: GenericStructure,
    /// Generic PID: a fixed derivative filter time constant, s (None: tuned).
    pub d_filter_tau_s: Option<f64>,
    /// Goals as the user wrote them (`ms<=1.4`, ...).
    pub goals: Vec<String>,
    /// What to maximize.
    pub maximize: Maximize,
    /// Betaflight filters and loop rate.
    pub betaflight: betaflight::Filters,
    /// INAV filters and loop rate.
    pub inav: inav::Filters,
    /// PX4 filters and loop rate.
    pub px4: px4::Filters,
    /// ArduPilot filters and loop rate.
    pub ardupilot: ardupilot::Filters,
    /// Optimizer starts.
    pub starts: usize,
    /// Betaflight: the flown F gain, kept when `tune_feedforward` is false (None: 120,
    /// Betaflight 4.4's default).
    pub betaflight_f: Option<u32>,
    /// INAV: the flown `mc_cd_<axis>`, kept when `tune_feedforward` is false (None: 0).
    pub inav_cd: Option<u32>,
    /// PX4: the flown MC_*RATE_FF, kept when `tune_feedforward` is false (None: 0).
    pub px4_ff: Option<f64>,
    /// ArduPilot: the ATC_RAT_*_FF to keep when `tune_feedforward` is false (None: 0).
    pub ardupilot_ff: Option<f64>,
    /// Fit the feedforward (Betaflight F, PX4 FF) to the tuned loop ([`feedforward`]); false
    /// keeps the flown value.
    pub tune_feedforward: bool,
}

impl TuneRequest {
    /// A request with the defaults (generic PID, maximize ki, firmware default filters, 8 starts).
    pub fn new(plant: StateSpace, firmware: Firmware) -> Self {
        TuneRequest {
            plant,
            extra_plants: Vec::new(),
            firmware,
            axis: Axis::Roll,
            structure: GenericStructure::Pid,
            d_filter_tau_s: None,
            goals: Vec::new(),
            maximize: Maximize::IntegralGain,
            betaflight: betaflight::Filters::default(),
            inav: inav::Filters::default(),
            px4: px4::Filters::default(),
            ardupilot: ardupilot::Filters::default(),
            starts: 8,
            betaflight_f: None,
            inav_cd: None,
            px4_ff: None,
            ardupilot_ff: None,
            tune_feedforward: true,
        }
    }
}

/// The proposal.
#[derive(Debug, Clone)]
pub struct TuneOutcome {
    /// The firmware's gains (JSON object with the firmware's keys).
    pub gains: Value,
    /// C_fb(s), continuous, plant units, of the gains as printed (after rounding).
    pub feedback_controller: StateSpace,
    /// C_fb at the loop rate (firmware only).
    pub discrete_controller: Option<StateSpace>,
    /// The exact check of the nominal loop (with the hold delay for firmware).
    pub margins: LoopCheck,
    /// Every goal (user's and defaults), re-verified with the printed gains.
    pub goals: Vec<GoalReport>,
    /// CLI lines for the firmware (empty for generic).
    pub cli: Vec<String>,
    /// The defaults that were added, stated.
    pub defaults: Vec<String>,
    /// Notes (what is not tuned, units).
    pub notes: Vec<String>,
    /// The plant the loop was checked with (hold delay included).
    pub loop_plant: StateSpace,
    /// The default noise limit's frequency: |C_fb| is bounded above it, rad/s.
    pub noise_w_rad_s: f64,
    /// The feedforward fit (None: generic structure, or the flown feedforward kept).
    pub feedforward: Option<feedforward::FeedforwardFit>,
    /// The generic `pid2` structure's setpoint weights.
    pub setpoint_weights: Option<feedforward::SetpointWeights>,
    /// The delay the analysis adds to the plant's input besides its own (the loop's sample and
    /// hold: half a loop period), s: the margins are those of
    /// L = plant·e^(−extra_delay_s·s)·feedback_controller.
    pub extra_delay_s: f64,
}

/// Largest plant order `tune` accepts.
pub const MAX_PLANT_ORDER: usize = 60;

/// The default integral-corner band with `--maximize crossover`: ω_c/15 ≤ ki/kp ≤ ω_c/4.
///
/// Why the floor: maximizing the crossover alone can drive ki to 0 (integral action costs phase
/// at crossover), a tune no pilot loads (btfl_all: p 34, i 0, d 6). Betaflight's stock gains keep
/// their integral corner near ω_c/14 (the flown tune of btfl_all: ω_c/13.3).
/// Why the ceiling: on other plants the same objective raised ki until the corner sat at the
/// crossover (0.97·ω_c on e^(−0.004s)·60/(s(0.03s+1)) with ArduPilot's PID), and the step then
/// overshoots; ω_c/4 is Skogestad's SIMC integral time for integrating plants, τ_I = 4(τ_c + θ).
pub const DEFAULT_INTEGRAL_CORNER: (f64, f64) = (1.0 / 15.0, 0.25);

/// Parses one goal: `ms<=1.4`, `mt<=1.3`, `disk_margin>=0.6`, `gain_margin_db>=6`,
/// `phase_margin_deg>=45`, `crossover_hz>=20` (or `<=`), `integral_corner>=0.067` (ki/kp over
/// the crossover frequency).
///
/// # Errors
/// Unknown quantity, missing operator, a bound that is not a number or lies outside the
/// quantity's range (named).
pub fn parse_goal(text: &str) -> Result<Goal> {
    let t: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    let (name, op, val) = if let Some((a, b)) = t.split_once("<=") {
        (a, "<=", b)
    } else if let Some((a, b)) = t.split_once(">=") {
        (a, ">=", b)
    } else {
        return Err(Error::Input(format!(
            "goal `{text}`: expected QUANTITY<=VALUE or QUANTITY>=VALUE (e.g. ms<=1.4, disk_margin>=0.6)"
        )));
    };
    let v: f64 = val
        .parse()
        .map_err(|_| Error::Input(format!("goal `{text}`: `{val}` is not a number")))?;
    let req = match name {
        "ms" => Requirement::Ms,
        "mt" => Requirement::Mt,
        "disk_margin" => Requirement::DiskMargin,
        "gain_margin_db" => Requirement::GainMarginDb,
        "phase_margin_deg" => Requirement::PhaseMarginDeg,
        "crossover_hz" => Requirement::CrossoverHz,
        "integral_corner" => Requirement::IntegralCorner,
        _ => {
            return Err(Error::Input(format!(
                "goal `{text}`: unknown quantity `{name}`; allowed: ms, mt, disk_margin, gain_margin_db, phase_margin_deg, crossover_hz, integral_corner"
            )))
        }
    };
    let bound = if op == "<=" {
        Bound::AtMost(v)
    } else {
        Bound::AtLeast(v)
    };
    let g = Goal::hard(req, bound, text.trim());
    g.validate()?;
    Ok(g)
}

fn with_hold(g: &StateSpace, loop_hz: Option<f64>) -> Result<StateSpace> {
    let Some(hz) = loop_hz else { return Ok(g.clone()) };
    let t = firmware::hold_delay_s(hz)?;
    let mut out = g.clone();
    out.input_delay[0] += t;
    Ok(out)
}

/// Tunes (see the module documentation).
///
/// # Errors
/// Bad plants or goals (named), gains outside the firmware's range, or no stabilizing gains.
///
/// # Examples
/// ```
/// use skyloop::tune::{tune, Firmware, TuneRequest};
/// let plant = skyloop::lti::expr::parse_model("exp(-0.1*s)/(s+1)^2")?;
/// let mut req = TuneRequest::new(plant, Firmware::Generic);
/// req.goals = vec!["ms<=1.6".into()];
/// req.starts = 2;
/// let out = tune(&req)?;
/// assert!(out.goals.iter().all(|g| g.met));
/// assert!(out.gains["ki"].as_f64().unwrap() > 0.0);
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn tune(req: &TuneRequest) -> Result<TuneOutcome> {
    for (i, p) in std::iter::once(&req.plant).chain(&req.extra_plants).enumerate() {
        p.validate()?;
        if p.nx() > MAX_PLANT_ORDER {
            return Err(Error::Input(format!(
                "plant {i}: order {} is above the {MAX_PLANT_ORDER} states tune handles (its optimizer evaluates the loop thousands of times); reduce it first (skyloop reduce MODEL --order K)",
                p.nx()
            )));
        }
        if p.ny() != 1 || p.nu() != 1 || p.dt != 0.0 {
            return Err(Error::Input(format!(
                "plant {i}: tune needs a continuous SISO model, got {}x{} with dt = {}",
                p.ny(),
                p.nu(),
                p.dt
            )));
        }
    }
    if !(1..=64).contains(&req.starts) {
        return Err(Error::Input(format!("--starts must be in 1..=64, got {}", req.starts)));
    }
    let loop_hz = match req.firmware {
        Firmware::Betaflight => Some(req.betaflight.loop_hz),
        Firmware::Inav => Some(req.inav.loop_hz),
        Firmware::Px4 => Some(req.px4.loop_hz),
        Firmware::Ardupilot => Some(req.ardupilot.loop_hz),
        Firmware::Generic => None,
    };
    let plants: Vec<StateSpace> = std::iter::once(&req.plant)
        .chain(&req.extra_plants)
        .map(|p| with_hold(p, loop_hz))
        .collect::<Result<_>>()?;
    let block = match req.firmware {
        Firmware::Betaflight => betaflight::block(&req.betaflight)?,
        Firmware::Inav => inav::block(&req.inav)?,
        Firmware::Px4 => px4::block(&req.px4)?,
        Firmware::Ardupilot => ardupilot::block(&req.ardupilot)?,
        Firmware::Generic => match (req.structure, req.d_filter_tau_s) {
            (GenericStructure::Pi, _) => Block::Pi,
            (GenericStructure::Pid | GenericStructure::Pid2, None) => Block::Pid(DerivativeFilter::Tuned),
            (GenericStructure::Pid | GenericStructure::Pid2, Some(tau)) => {
                if !(tau.is_finite() && tau > 0.0) {
                    return Err(Error::Input(format!(
                        "--d-filter-tau must be a positive number of seconds, got {tau}"
                    )));
                }
                Block::Pid(DerivativeFilter::Fixed(StateSpace::from_rows(
                    &[vec![-1.0 / tau]],
                    &[vec![1.0 / tau]],
                    &[vec![1.0]],
                    &[vec![0.0]],
                    0.0,
                )?))
            }
        },
    };
    let (mut goals, mut defaults) = goals_with_floor(&req.goals)?;
    if req.maximize != Maximize::IntegralGain && !goals.iter().any(|g| g.req == Requirement::IntegralCorner) {
        let (lo, hi) = DEFAULT_INTEGRAL_CORNER;
        goals.push(Goal::hard(
            Requirement::IntegralCorner,
            Bound::AtLeast(lo),
            format!("integral_corner>={lo:.4} (default with --maximize crossover)"),
        ));
        goals.push(Goal::hard(
            Requirement::IntegralCorner,
            Bound::AtMost(hi),
            format!("integral_corner<={hi} (default with --maximize crossover)"),
        ));
        defaults.push(format!(
            "{lo:.4} <= integral_corner <= {hi}: ki/kp between 1/15 of the crossover frequency (about Betaflight's stock ratio; maximizing the crossover alone can drop I to 0) and 1/4 of it (SIMC's most aggressive integral time; a higher corner makes the step overshoot)"
        ));
    }
    let (wu, ku) = ultimate_point(&plants[0])?;
    let wn = 3.0 * wu;
    let nmax = 10.0 * ku;
    goals.push(Goal::hard(
        Requirement::ControllerGainAbove { w_rad_s: wn },
        Bound::AtMost(nmax),
        format!("noise_gain<={nmax:.4e} above {:.4} Hz (default limit)", wn / (2.0 * PI)),
    ));
    defaults.push(format!(
        "noise limit: |C_fb| <= 10*Ku = {nmax:.4e} above 3*f_u = {:.4} Hz (Ku, f_u: the plant's ultimate gain and frequency)",
        wn / (2.0 * PI)
    ));
    let prob = LoopTuning {
        plants: plants.clone(),
        structure: Structure::new(block),
        goals,
        objective: match req.maximize {
            Maximize::IntegralGain => Objective::MaximizeIntegralGain,
            Maximize::Crossover | Maximize::Tracking => Objective::MaximizeCrossover,
        },
        options: TuneOptions {
            starts: req.starts,
            ..Default::default()
        },
    };
    let mut tuned = tune_loop(&prob)?;
    // Firmware gains are rounded; when no rounding of the optimum meets the hard goals, re-tune
    // with the violated bounds tightened by twice the violation (at most three times).
    if req.firmware == Firmware::Betaflight {
        for _ in 0..3 {
            let (_, theta) = betaflight_rounding(&prob, &tuned.params, req)?;
            let (goals, loops) = evaluate(&prob, &theta)?;
            let worst = goals
                .iter()
                .filter(|g| g.hard)
                .map(|g| g.normalized)
                .fold(f64::NEG_INFINITY, f64::max);
            if worst <= 1.0 + 1e-6 && loops.iter().all(|l| l.stable) {
                break;
            }
            let d = 2.0 * (worst - 1.0).max(1e-3);
            let mut tight = prob.clone();
            for (g, r) in tight.goals.iter_mut().zip(&goals) {
                if r.hard && r.normalized > 1.0 - d {
                    g.bound = match g.bound {
                        Bound::AtMost(b) => Bound::AtMost(b / (1.0 + d)),
                        Bound::AtLeast(b) => Bound::AtLeast(b * (1.0 + d)),
                    };
                }
            }
            match tune_loop(&tight) {
                Ok(t) => tuned = t,
                Err(_) => break,
            }
        }
    }
    let th = &tuned.params;
    let mut notes = Vec::new();
    let mut ff_fit = None;
    let mut weights = None;
    // Map to the firmware's gains, round as the firmware stores them, and re-verify those.
    let (gains, theta, cli, discrete) = match req.firmware {
        Firmware::Generic => {
            let mut g = json!({"kp": th[0], "ki": th[1]});
            if th.len() > 2 {
                g["kd"] = json!(th[2]);
                g["tf"] = json!(if th.len() > 3 {
                    th[3].exp()
                } else {
                    req.d_filter_tau_s.unwrap_or(0.0)
                });
            } else {
                g["kd"] = json!(0.0);
                g["tf"] = json!(0.0);
            }
            if req.structure == GenericStructure::Pid2 {
                let (ipath, ppath, dpath) = pid2_paths(&g)?;
                let c = prob.structure.realize(th)?;
                match feedforward::fit_setpoint_weights(&plants[0], &c, &ipath, &ppath, &dpath) {
                    Ok(w) => {
                        g["b"] = json!(w.b);
                        g["c"] = json!(w.c);
                        notes.push(format!(
                            "setpoint weights b = {:.2}, c = {:.2}: fitted to the tuned loop (least squared tracking error of a 25 ms ramp, adding no overshoot beyond {} % or the I-only path's own): predicted overshoot {:.1} % against {:.1} % for b = c = 1, squared error {:.0} % of theirs",
                            w.b,
                            w.c,
                            feedforward::OVERSHOOT_MAX_PCT,
                            w.overshoot_pct,
                            w.overshoot_one_dof_pct,
                            100.0 * w.ise_ratio_one_dof
                        ));
                        weights = Some(w);
                    }
                    Err(e) => {
                        g["b"] = json!(1.0);
                        g["c"] = json!(1.0);
                        notes.push(format!(
                            "setpoint weights not fitted ({e}): b = c = 1, the one-degree-of-freedom PID"
                        ));
                    }
                }
            }
            (g, th.clone(), Vec::new(), None)
        }
        Firmware::Betaflight => {
            let (mut bg, theta) = betaflight_rounding(&prob, th, req)?;
            let c = betaflight::feedback_controller(&bg, req.axis, &req.betaflight)?;
            let unit = betaflight::FTERM_SCALE / 100.0;
            let fit = fit_feedforward(
                req,
                &plants[0],
                &c,
                || {
                    Ok((
                        betaflight::reference_path(
                            &betaflight::Gains { f: 0, ..bg },
                            req.axis,
                            req.betaflight.loop_hz,
                        )?,
                        betaflight::feedforward_unit(req.betaflight.loop_hz)?,
                    ))
                },
                f64::from(betaflight::F_GAIN_MAX) * unit,
                &mut notes,
            )?;
            if let Some(fit) = fit {
                bg.f = (fit.gain / unit).round().clamp(0.0, f64::from(betaflight::F_GAIN_MAX)) as u32;
                notes.push(feedforward_note(&format!("f_{} = {}", req.axis.name(), bg.f), &fit));
                ff_fit = Some(fit);
            } else {
                bg.f = req.betaflight_f.unwrap_or(120);
                notes.push(format!(
                    "f_{} = {} is not tuned ({}){}",
                    req.axis.name(),
                    bg.f,
                    keep_reason(req),
                    if req.betaflight_f.is_some() {
                        "; kept as flown"
                    } else {
                        "; Betaflight 4.4's default, keep yours"
                    }
                ));
            }
            notes.push("plant units: input Betaflight's PID sum, output gyro deg/s".into());
            (
                serde_json::to_value(bg)?,
                theta,
                betaflight::cli_lines(&bg, req.axis),
                Some(firmware::discrete(&c, req.betaflight.loop_hz)?),
            )
        }
        Firmware::Inav => {
            let mut ig = inav::from_continuous(th[0], th[1], th[2], req.inav_cd.unwrap_or(0), req.axis)?;
            let c = inav::feedback_controller(&ig, &req.inav)?;
            let unit = 1.0 / inav::CD_MULTIPLIER;
            let fit = fit_feedforward(
                req,
                &plants[0],
                &c,
                || {
                    Ok((
                        inav::reference_path(&inav::Gains { cd: 0, ..ig }, &req.inav)?,
                        inav::feedforward_unit(&req.inav)?,
                    ))
                },
                f64::from(inav::GAIN_MAX) * unit,
                &mut notes,
            )?;
            if let Some(fit) = fit {
                ig.cd = (fit.gain / unit).round().clamp(0.0, f64::from(inav::GAIN_MAX)) as u32;
                notes.push(feedforward_note(
                    &format!("mc_cd_{} = {}", req.axis.name(), ig.cd),
                    &fit,
                ));
                ff_fit = Some(fit);
            } else {
                notes.push(format!(
                    "mc_cd_{} = {} is not tuned ({}){}",
                    req.axis.name(),
                    ig.cd,
                    keep_reason(req),
                    if req.inav_cd.is_some() { "; kept as flown" } else { "" }
                ));
            }
            notes.push("plant units: input INAV's PID sum, output gyro deg/s".into());
            let (kp, ki, kd, _) = inav::continuous(&ig);
            (
                serde_json::to_value(ig)?,
                vec![kp, ki, kd],
                inav::cli_lines(&ig, req.axis),
                Some(firmware::discrete(&c, req.inav.loop_hz)?),
            )
        }
        Firmware::Ardupilot => {
            let mut ag = ardupilot::Gains {
                p: round6(th[0]),
                i: round6(th[1]),
                d: round6(th[2]),
                ff: req.ardupilot_ff.unwrap_or(0.0),
            };
            let c = ardupilot::feedback_controller(&ag, &req.ardupilot)?;
            let fit = fit_feedforward(
                req,
                &plants[0],
                &c,
                || {
                    Ok((
                        ardupilot::reference_path(&ardupilot::Gains { ff: 0.0, ..ag }, &req.ardupilot)?,
                        ardupilot::feedforward_unit(&req.ardupilot)?,
                    ))
                },
                ardupilot::GAIN_RANGES[3].1,
                &mut notes,
            )?;
            if let Some(fit) = fit {
                ag.ff = round6(fit.gain);
                notes.push(feedforward_note(&format!("FF = {}", ag.ff), &fit));
                ff_fit = Some(fit);
            } else {
                notes.push(format!("FF = {} is not tuned ({})", ag.ff, keep_reason(req)));
            }
            notes.extend(ardupilot::range_notes(&ag, req.axis));
            notes.push(
                "plant units: input the mixer's normalized command, output rad/s; IMAX and SMAX not modelled".into(),
            );
            let mut g = serde_json::Map::new();
            for (n, v) in ardupilot::param_names(req.axis).iter().zip([ag.p, ag.i, ag.d, ag.ff]) {
                g.insert(n.clone(), json!(v));
            }
            (
                Value::Object(g),
                vec![ag.p, ag.i, ag.d],
                ardupilot::cli_lines(&ag, req.axis),
                Some(firmware::discrete(&c, req.ardupilot.loop_hz)?),
            )
        }
        Firmware::Px4 => {
            let mut pg = px4::Gains {
                k: 1.0,
                p: round6(th[0]),
                i: round6(th[1]),
                d: round6(th[2]),
                ff: req.px4_ff.unwrap_or(0.0),
            };
            let c = px4::feedback_controller(&pg, &req.px4)?;
            let fit = fit_feedforward(
                req,
                &plants[0],
                &c,
                || {
                    Ok((
                        px4::reference_path(&px4::Gains { ff: 0.0, ..pg })?,
                        firmware::static_gain(1.0)?,
                    ))
                },
                PX4_FF_MAX,
                &mut notes,
            )?;
            if let Some(fit) = fit {
                pg.ff = round6(fit.gain);
                notes.push("MC_*RATE_K = 1 (parallel form)".into());
                notes.push(feedforward_note(&format!("FF = {}", pg.ff), &fit));
                ff_fit = Some(fit);
            } else {
                notes.push(format!(
                    "MC_*RATE_K = 1 (parallel form); FF = {} is not tuned ({})",
                    pg.ff,
                    keep_reason(req)
                ));
            }
            notes.push("plant units: input normalized torque, output rad/s".into());
            let (kp, ki, kd) = px4::continuous(&pg);
            let names = px4::param_names(req.axis);
            let mut g = serde_json::Map::new();
            for (n, v) in names.iter().zip([pg.k, pg.p, pg.i, pg.d, pg.ff]) {
                g.insert(n.clone(), json!(v));
            }
            (
                Value::Object(g),
                vec![kp, ki, kd],
                px4::cli_lines(&pg, req.axis),
                Some(firmware::discrete(&c, req.px4.loop_hz)?),
            )
        }
    };
    let (goal_reports, loops) = evaluate(&prob, &theta)?;
    no_feedback_is_no_tune(&gains, &loops[0], &req.goals)?;
    let feedback_controller = prob.structure.realize(&theta)?;
    Ok(TuneOutcome {
        gains,
        feedback_controller,
        discrete_controller: discrete,
        margins: loops[0],
        goals: goal_reports,
        cli,
        defaults,
        notes,
        loop_plant: plants[0].clone(),
        noise_w_rad_s: wn,
        feedforward: ff_fit,
        setpoint_weights: weights,
        extra_delay_s: match loop_hz {
            Some(hz) => firmware::hold_delay_s(hz)?,
            None => 0.0,
        },
    })
}

/// Gains that leave the loop without a gain crossover (P = I = D = 0 after rounding, or so small
/// that |L| < 1 everywhere) are no controller: the plant flies open loop, whatever the margins say.
///
/// # Errors
/// Always in that case, naming the gains and the goals that drove them there.
fn no_feedback_is_no_tune(gains: &Value, m: &LoopCheck, goals: &[String]) -> Result<()> {
    if m.crossover_hz.is_finite() && m.crossover_hz > 0.0 {
        return Ok(());
    }
    Err(Error::Failed(format!(
        "no controller meets the goals: the best gains found, {gains}, leave the loop without a gain crossover (no feedback at all: the plant would fly open loop, so the margins printed for it would mean nothing); relax the goals{}",
        if goals.is_empty() {
            String::new()
        } else {
            format!(" ({})", goals.join(", "))
        }
    )))
}

/// The user's goals parsed, with the default disk-margin floor α ≥ 0.5 added unless a disk-margin
/// goal is given; returns the goals and the defaults stated.
///
/// # Errors
/// A goal that does not parse (named).
fn goals_with_floor(texts: &[String]) -> Result<(Vec<Goal>, Vec<String>)> {
    let mut goals: Vec<Goal> = texts.iter().map(|g| parse_goal(g)).collect::<Result<_>>()?;
    let mut defaults = Vec::new();
    if !goals.iter().any(|g| g.req == Requirement::DiskMargin) {
        goals.push(Goal::hard(
            Requirement::DiskMargin,
            Bound::AtLeast(0.5),
            "disk_margin>=0.5 (default floor)",
        ));
        defaults.push("disk_margin>=0.5: the loop tolerates ±5.6 dB and ±28° at once".to_string());
    }
    Ok((goals, defaults))
}

/// The outcome of given firmware gains (no optimization): C_fb and its discrete form, the exact
/// check of the nominal loop `held[0]` (hold included), the user's `goals` and the default disk floor
/// evaluated over every plant of `held`, and the pilot's lines.
///
/// # Errors
/// Bad goals (named) or gains whose loop cannot be evaluated.
pub fn outcome_for_gains(
    g: &RateGains,
    held: &[StateSpace],
    goals: &[String],
    notes: Vec<String>,
) -> Result<TuneOutcome> {
    let (gl, defaults) = goals_with_floor(goals)?;
    let prob = LoopTuning {
        plants: held.to_vec(),
        structure: Structure::new(g.block()?),
        goals: gl,
        objective: Objective::MaximizeCrossover,
        options: TuneOptions::default(),
    };
    let theta = g.continuous().to_vec();
    let (goal_reports, loops) = evaluate(&prob, &theta)?;
    let c = prob.structure.realize(&theta)?;
    Ok(TuneOutcome {
        gains: g.to_json(),
        discrete_controller: Some(firmware::discrete(&c, g.loop_hz())?),
        feedback_controller: c,
        margins: loops[0],
        goals: goal_reports,
        cli: g.cli(),
        defaults,
        notes,
        loop_plant: held[0].clone(),
        noise_w_rad_s: 0.0,
        feedforward: None,
        setpoint_weights: None,
        extra_delay_s: firmware::hold_delay_s(g.loop_hz())?,
    })
}

/// The I, P and D paths ki/s, kp and kd·s/(tf·s + 1) of generic gains (`kp`, `ki`, `kd`, `tf`).
fn pid2_paths(g: &Value) -> Result<(StateSpace, StateSpace, StateSpace)> {
    let num = |k: &str| g[k].as_f64().unwrap_or(0.0);
    let (kp, ki, kd, tf) = (num("kp"), num("ki"), num("kd"), num("tf"));
    let ipath = StateSpace::from_rows(&[vec![0.0]], &[vec![1.0]], &[vec![ki]], &[vec![0.0]], 0.0)?;
    let ppath = firmware::static_gain(kp)?;
    let dpath = if tf > 0.0 {
        // kd·s/(tf·s + 1) = kd/tf − (kd/tf²)/(s + 1/tf).
        StateSpace::from_rows(
            &[vec![-1.0 / tf]],
            &[vec![1.0]],
            &[vec![-kd / (tf * tf)]],
            &[vec![kd / tf]],
            0.0,
        )?
    } else {
        firmware::static_gain(0.0)?
    };
    Ok((ipath, ppath, dpath))
}

/// C_r(s) = ki/s + b·kp + c·kd·s/(tf·s + 1) of generic `pid2` gains (keys `kp`, `ki`, `kd`,
/// `tf`, `b`, `c`); without `b` and `c`, the one-degree-of-freedom C_r = C_fb's PID.
///
/// # Errors
/// Gains that do not form a model.
pub fn generic_reference_path(g: &Value) -> Result<StateSpace> {
    let (i, mut p, mut d) = pid2_paths(g)?;
    let (b, c) = (g["b"].as_f64().unwrap_or(1.0), g["c"].as_f64().unwrap_or(1.0));
    p.d = &p.d * b;
    d.c = &d.c * c;
    d.d = &d.d * c;
    Ok(skyloop_lti::interconnect::parallel(
        &skyloop_lti::interconnect::parallel(&i, &p)?,
        &d,
    )?)
}

use crate::firmware::round6;

/// Largest PX4 rate feedforward the fit may propose, normalized torque per rad/s (a sanity bound:
/// full torque for a 1 rad/s setpoint).
const PX4_FF_MAX: f64 = 1.0;

/// The feedforward fitted to the loop `c` around `plant` (see [`feedforward::fit`]), or None:
/// when `--keep-feedforward` asks so, or with a note when it cannot be fitted (e.g. the Padé
/// model of a loop the exact check found stable is not); the feedback gains stand either way.
/// `paths` gives the reference path without feedforward and the feedforward's unit path.
fn fit_feedforward(
    req: &TuneRequest,
    plant: &StateSpace,
    c: &StateSpace,
    paths: impl FnOnce() -> Result<(StateSpace, StateSpace)>,
    max_gain: f64,
    notes: &mut Vec<String>,
) -> Result<Option<feedforward::FeedforwardFit>> {
    if !req.tune_feedforward {
        return Ok(None);
    }
    let (c_r0, c_f) = paths()?;
    Ok(feedforward::fit(plant, c, &c_r0, &c_f, max_gain)
        .map_err(|e| notes.push(format!("the feedforward could not be fitted: {e}")))
        .ok())
}

/// Why a feedforward was kept.
fn keep_reason(req: &TuneRequest) -> &'static str {
    if req.tune_feedforward {
        "not fitted, see above"
    } else {
        "--keep-feedforward"
    }
}

/// The note that states how the feedforward was chosen.
fn feedforward_note(what: &str, fit: &feedforward::FeedforwardFit) -> String {
    format!(
        "{what}: fitted to the tuned loop (least squared tracking error of a 25 ms stick ramp, adding no overshoot beyond {} % or the loop's own; set by {}): predicted overshoot {:.1} % ({:.1} % without feedforward), squared error {:.0} % of no feedforward's",
        feedforward::OVERSHOOT_MAX_PCT,
        fit.limited_by,
        fit.overshoot_pct,
        fit.overshoot_without_pct,
        100.0 * fit.ise_ratio
    )
}

/// Betaflight stores integers: of the 8 floor/ceil roundings of (P, I, D), and the floors with I
/// lowered by 1 to 10 units, the one that meets every hard goal with the best objective (rounding
/// can cost a margin).
fn betaflight_rounding(prob: &LoopTuning, th: &[f64], req: &TuneRequest) -> Result<(betaflight::Gains, Vec<f64>)> {
    let yaw = if req.axis == Axis::Yaw { 2.5 } else { 1.0 };
    let scales = [
        betaflight::PTERM_SCALE,
        betaflight::ITERM_SCALE * yaw,
        betaflight::DTERM_SCALE,
    ];
    // The optimum in firmware units (P, I, D), and one candidate from whole units.
    let units: Vec<f64> = (0..3).map(|j| th[j] / scales[j]).collect();
    let candidate = |u: [f64; 3]| -> Result<(betaflight::Gains, Vec<f64>)> {
        let bg = betaflight::from_continuous(
            u[0] * scales[0],
            u[1] * scales[1],
            u[2] * scales[2],
            req.betaflight_f.unwrap_or(120),
            req.axis,
        )?;
        let (kp, ki, kd, _) = betaflight::continuous(&bg, req.axis);
        Ok((bg, vec![kp, ki, kd]))
    };
    let mut cands = Vec::new();
    for mask in 0..8u32 {
        let pick = |j: usize| {
            (if mask & (1 << j) == 0 {
                units[j].floor()
            } else {
                units[j].ceil()
            })
            .max(0.0)
        };
        cands.push(candidate([pick(0), pick(1), pick(2)])?);
    }
    // When every rounding of the optimum misses an active goal by a hair (one unit of I moves
    // the margins by more than the tightening re-tune can foresee), I lowered by up to 10 units
    // steps back into the feasible set at the smallest cost to the objective.
    let floors = units.iter().map(|u| u.floor().max(0.0)).collect::<Vec<_>>();
    for back in 1..=10u32 {
        let i = floors[1] - f64::from(back);
        if i < 0.0 {
            break;
        }
        cands.push(candidate([floors[0], i, floors[2]])?);
    }
    best_rounding(prob, cands, req.maximize)
}

/// The candidate gain set that meets every hard goal (exact check) with the best objective, or
/// the one that violates the worst goal least.
fn best_rounding<G: Copy>(prob: &LoopTuning, cands: Vec<(G, Vec<f64>)>, maximize: Maximize) -> Result<(G, Vec<f64>)> {
    let mut best: Option<(bool, f64, G, Vec<f64>)> = None;
    for (g, th) in cands {
        let (goals, loops) = evaluate(prob, &th)?;
        let ok = loops.iter().all(|l| l.stable) && goals.iter().all(|r| !r.hard || r.met);
        let score = if ok {
            match maximize {
                Maximize::IntegralGain => -th[1],
                Maximize::Crossover | Maximize::Tracking => {
                    -loops.iter().map(|l| l.crossover_hz).fold(f64::INFINITY, f64::min)
                }
            }
        } else {
            goals
                .iter()
                .filter(|r| r.hard)
                .map(|r| r.normalized)
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let better = match &best {
            None => true,
            Some((bok, bs, _, _)) => (ok && !bok) || (ok == *bok && score < *bs),
        };
        if better {
            best = Some((ok, score, g, th));
        }
    }
    best.map(|(_, _, g, th)| (g, th))
        .ok_or_else(|| Error::Failed("no rounded gains to check".into()))
}

impl TuneOutcome {
    /// The JSON a script reads: `gains`, `feedback_controller`, `margins`, `goals`, `cli`,
    /// `defaults`, `notes`.
    pub fn to_json(&self) -> Value {
        let m = &self.margins;
        json!({
            "gains": self.gains,
            "feedback_controller": LtiJson::from_ss(&self.feedback_controller),
            "discrete_controller": self.discrete_controller.as_ref().map(LtiJson::from_ss),
            "margins": margins_json(m),
            "goals": self.goals.iter().map(|g| json!({
                "goal": g.label, "value": g.value, "met": g.met, "active": g.active,
            })).collect::<Vec<_>>(),
            "cli": self.cli,
            "loop": {
                "extra_delay_s": self.extra_delay_s,
                "definition": "L = plant * exp(-extra_delay_s*s) * feedback_controller: the loop the margins are computed for (extra_delay_s: the loop's sample and hold, half a loop period)",
            },
            "defaults": self.defaults,
            "notes": self.notes,
            "feedforward": self.feedforward.map(|f| json!({
                "gain": f.gain,
                "ise_optimal": f.ise_optimal,
                "overshoot_pct": f.overshoot_pct,
                "ise_ratio": f.ise_ratio,
                "overshoot_without_pct": f.overshoot_without_pct,
                "limited_by": f.limited_by,
            })),
            "setpoint_weights": self.setpoint_weights.map(|w| json!({
                "b": w.b,
                "c": w.c,
                "overshoot_pct": w.overshoot_pct,
                "overshoot_one_dof_pct": w.overshoot_one_dof_pct,
                "ise_ratio_one_dof": w.ise_ratio_one_dof,
            })),
        })
    }
}

/// The re-verified margins of a tuned loop as the `margins` object of `tune --json`.
pub(crate) fn margins_json(m: &LoopCheck) -> serde_json::Value {
    json!({
        "disk_alpha": m.disk_alpha,
        "gain_margin_db": m.gain_margin_db,
        "phase_margin_deg": m.phase_margin_deg,
        "crossover_hz": m.crossover_hz,
        "ms": m.ms,
        "mt": m.mt,
        "stable": m.stable,
    })
}
