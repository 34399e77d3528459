//! `skyloop tune`: gains a flight controller can load, tuned against margin goals with the
//! fixed-structure optimizer of skyloop-robust ([`skyloop_robust::structured::systune`]), mapped
//! to the firmware's own gains ([`crate::firmware`]), rounded as the firmware stores them, and
//! re-verified with the exact plant (delay and the loop's sample and hold kept) after rounding.
//!
//! Defaults a pilot can trust, added unless the user gives a goal of the same kind: a disk-margin
//! floor α ≥ 0.5 (±4.4 dB and ±28.1° simultaneously), and a noise limit: |C_fb(jω)| ≤ 10·Ku for
//! ω ≥ 3·ω_u, with Ku, ω_u the plant's ultimate gain and frequency (so gyro noise above the loop's
//! bandwidth is amplified at most ten times the gain that would make the loop oscillate).

use crate::error::{Error, Result};
use crate::firmware;
use crate::firmware::rate_gains::RateGains;
use crate::firmware::Axis;
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
    /// The firmware's controller as a log states it: filters, loop rate, feedforward and, for a
    /// plant identified from a log, the plant's units (its P, I, D are what the tuner replaces).
    /// None: the firmware's defaults ([`RateGains::template`]). Must be of `firmware`.
    pub controller: Option<RateGains>,
    /// Whether `controller`'s feedforward is the flown one (kept as flown when not tuned) rather
    /// than the firmware's default.
    pub feedforward_flown: bool,
    /// Optimizer starts.
    pub starts: usize,
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
            controller: None,
            feedforward_flown: false,
            starts: 8,
            tune_feedforward: true,
        }
    }

    /// The firmware's controller the optimizer fills in: `controller`, or the firmware's
    /// defaults; None for the generic structure.
    ///
    /// # Errors
    /// A `controller` of another firmware than `firmware`.
    pub fn template(&self) -> Result<Option<RateGains>> {
        match &self.controller {
            Some(c) if self.firmware == c.firmware() => Ok(Some(c.clone())),
            Some(c) => Err(Error::Input(format!(
                "the controller given is {}'s, the request's firmware {}",
                c.firmware().name(),
                self.firmware.name()
            ))),
            None => Ok(RateGains::template(self.firmware, self.axis)),
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
    /// The firmware's gains as printed (None for the generic structure).
    pub firmware_gains: Option<RateGains>,
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
    validate(req)?;
    let template = req.template()?;
    let loop_hz = template.as_ref().map(RateGains::loop_hz);
    let plants: Vec<StateSpace> = std::iter::once(&req.plant)
        .chain(&req.extra_plants)
        .map(|p| with_hold(p, loop_hz))
        .collect::<Result<_>>()?;
    let block = match &template {
        Some(t) => t.block()?,
        None => generic_block(req)?,
    };
    let (prob, defaults, wn) = problem(req, plants.clone(), block)?;
    let tuned = optimize(&prob, template.as_ref(), req)?;
    let th = &tuned.params;
    let mut notes = Vec::new();
    let mut ff_fit = None;
    let mut weights = None;
    // Map to the firmware's gains, round as the firmware stores them, and re-verify those.
    let (gains, theta, cli, discrete, firmware_gains) = match &template {
        None => {
            let (g, w) = generic_gains(req, &prob, th, &mut notes)?;
            weights = w;
            (g, th.clone(), Vec::new(), None, None)
        }
        Some(t) => {
            let (g, fit) = firmware_gains(req, &prob, t, th, &mut notes)?;
            ff_fit = fit;
            let c = g.feedback_controller()?;
            (
                g.to_json(),
                g.continuous().to_vec(),
                g.cli(),
                Some(firmware::discrete(&c, g.loop_hz())?),
                Some(g),
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
        firmware_gains,
        extra_delay_s: match loop_hz {
            Some(hz) => firmware::hold_delay_s(hz)?,
            None => 0.0,
        },
    })
}

/// The request's plants and starts checked.
fn validate(req: &TuneRequest) -> Result<()> {
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
    check_starts(req.starts)
}

/// `--starts` within 1..=64 (model and log tuning alike).
pub(crate) fn check_starts(starts: usize) -> Result<()> {
    if !(1..=64).contains(&starts) {
        return Err(Error::Input(format!("--starts must be in 1..=64, got {starts}")));
    }
    Ok(())
}

/// The generic structure's tunable block: PI, or PID with its derivative filter tuned or fixed.
fn generic_block(req: &TuneRequest) -> Result<Block> {
    Ok(match (req.structure, req.d_filter_tau_s) {
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
    })
}

/// The tuning problem: the goals with their defaults (disk floor, integral corner with
/// `--maximize crossover`, noise limit) and the objective; returns it with the defaults stated
/// and the noise limit's frequency, rad/s.
fn problem(req: &TuneRequest, plants: Vec<StateSpace>, block: Block) -> Result<(LoopTuning, Vec<String>, f64)> {
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
        plants,
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
    Ok((prob, defaults, wn))
}

/// The optimum; for a firmware of coarse resolution (Betaflight), re-tuned while no rounding of
/// it meets the hard goals.
fn optimize(
    prob: &LoopTuning,
    template: Option<&RateGains>,
    req: &TuneRequest,
) -> Result<skyloop_robust::structured::systune::TunedLoop> {
    let mut tuned = tune_loop(prob)?;
    // Firmware gains are rounded; when no rounding of the optimum meets the hard goals, re-tune
    // with the violated bounds tightened by twice the violation (at most three times).
    let Some(t) = template.filter(|t| t.coarse_resolution()) else {
        return Ok(tuned);
    };
    for _ in 0..3 {
        let (_, theta) = rounded(prob, t, &tuned.params, req.maximize)?;
        let (goals, loops) = evaluate(prob, &theta)?;
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
    Ok(tuned)
}

/// The generic gains `{kp, ki, kd, tf}` of the optimum `th` (with `pid2`: the setpoint weights
/// `b`, `c` fitted).
fn generic_gains(
    req: &TuneRequest,
    prob: &LoopTuning,
    th: &[f64],
    notes: &mut Vec<String>,
) -> Result<(Value, Option<feedforward::SetpointWeights>)> {
    let plants = &prob.plants;
    let mut weights = None;
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
    Ok((g, weights))
}

/// The firmware's gains nearest the optimum `th` that meet the goals best, with the feedforward
/// fitted to them (or kept), and the notes on what was kept and the plant's units.
fn firmware_gains(
    req: &TuneRequest,
    prob: &LoopTuning,
    template: &RateGains,
    th: &[f64],
    notes: &mut Vec<String>,
) -> Result<(RateGains, Option<feedforward::FeedforwardFit>)> {
    let (mut g, _) = rounded(prob, template, th, req.maximize)?;
    let c = g.feedback_controller()?;
    let fit = fit_feedforward(
        req,
        &prob.plants[0],
        &c,
        || g.feedforward_paths(),
        g.feedforward_max(),
        notes,
    )?;
    if let Some(fit) = &fit {
        g = g.with_feedforward(fit.gain);
        notes.push(feedforward_note(&g.feedforward_label(), fit));
    } else {
        notes.push(format!(
            "{} is not tuned ({}){}",
            g.feedforward_label(),
            keep_reason(req),
            if req.feedforward_flown {
                "; kept as flown"
            } else {
                g.default_feedforward_note()
            }
        ));
    }
    notes.extend(g.tuning_notes());
    Ok((g, fit))
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
        defaults.push(format!(
            "disk_margin>=0.5: the loop tolerates {}",
            verdict::disk_tolerance(0.5)
        ));
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
        firmware_gains: Some(g.clone()),
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

/// The rounding of the optimum `th` to the firmware's resolution ([`RateGains::roundings`]) that
/// meets the hard goals with the best objective, and its continuous gains.
fn rounded(prob: &LoopTuning, template: &RateGains, th: &[f64], maximize: Maximize) -> Result<(RateGains, Vec<f64>)> {
    let cands = template
        .roundings(th)?
        .into_iter()
        .map(|g| {
            let c = g.continuous().to_vec();
            (g, c)
        })
        .collect();
    best_rounding(prob, cands, maximize)
}

/// The candidate gain set that meets every hard goal (exact check) with the best objective, or
/// the one that violates the worst goal least.
fn best_rounding<G>(prob: &LoopTuning, cands: Vec<(G, Vec<f64>)>, maximize: Maximize) -> Result<(G, Vec<f64>)> {
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
