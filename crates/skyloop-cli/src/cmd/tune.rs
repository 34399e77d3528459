//! `skyloop tune (LOG [--axis roll] | --plant MODEL --firmware betaflight|px4|...) ...`: gains
//! for the flight controller, tuned against margin goals and re-verified; from a log, the axis is
//! identified and the flown tune is compared (thin: parse, call skyloop::tune, print).

use crate::output::print_json;
use clap::Args as ClapArgs;
use skyloop::firmware::Axis;
use skyloop::identify::SegmentVerdict;
use skyloop::model::load_model;
use skyloop::tune::log::{tune_axes_from_log, LogTuneOutcome, LogTuneRequest};
use skyloop::tune::verdict::Refusal;
use skyloop::tune::{report::write_outputs, tune as run_tune, Firmware, GenericStructure, Maximize, TuneRequest};

/// Arguments of `skyloop tune`.
#[derive(ClapArgs)]
pub struct Args {
    /// A flight log (Betaflight or INAV blackbox, or PX4 ULog): identify --axis from it, read the flown gains and filters from its header, and compare.
    #[arg(conflicts_with = "plant", required_unless_present = "plant")]
    pub log: Option<std::path::PathBuf>,
    /// The rate-loop plant (expression or LTI JSON), in the firmware's units (Betaflight, INAV: PID sum → deg/s; PX4: normalized torque → rad/s).
    #[arg(long, allow_hyphen_values = true)]
    pub plant: Option<String>,
    /// betaflight, inav, px4, ardupilot (ATC_RAT_* of ArduCopter/QuadPlane) or generic; with LOG the default is the firmware that wrote it (a different one is refused, except generic).
    #[arg(long)]
    pub firmware: Option<String>,
    /// generic only: pi, pid or pidf (pidf = pid: kp + ki/s + kd·s/(tf·s+1)), or pid2 (the same with setpoint weights b, c fitted for tracking: u = kp(b·r−y) + ki/s(r−y) + kd·s/(tf·s+1)(c·r−y)).
    #[arg(long, default_value = "pid")]
    pub structure: String,
    /// generic pid: fix the derivative filter time constant tf (s) instead of tuning it.
    #[arg(long)]
    pub d_filter_tau: Option<f64>,
    /// A goal, repeatable: ms<=1.4, mt<=1.3, disk_margin>=0.6, gain_margin_db>=6, phase_margin_deg>=45, crossover_hz>=20, integral_corner>=0.067 or <=0.25 (ki/kp over the crossover frequency; 1/15..1/4 by default with --maximize crossover).
    #[arg(long = "goal", allow_hyphen_values = true)]
    pub goals: Vec<String>,
    /// What to maximize once the goals hold: tracking (from a LOG, the default: the highest crossover at no loss of robustness against the flown tune), crossover (robustness may fall to the floor), or integral_gain (the default with --plant).
    #[arg(long)]
    pub maximize: Option<String>,
    /// Axis the gains are for: roll, pitch or yaw (with --plant: roll by default; with LOG: all three unless given).
    #[arg(long)]
    pub axis: Option<String>,
    /// With LOG: largest predicted motor-noise power of the proposal relative to the flown tune's (1..=10).
    #[arg(long, default_value_t = 1.25)]
    pub noise_budget: f64,
    /// With LOG: blackbox session (counted from 1); default: the longest.
    #[arg(long)]
    pub session: Option<usize>,
    /// With LOG: lowest frequency of the identification, Hz (as `identify --fmin-hz`).
    #[arg(long)]
    pub fmin_hz: Option<f64>,
    /// With LOG: highest frequency of the identification, Hz (as `identify --fmax-hz`).
    #[arg(long)]
    pub fmax_hz: Option<f64>,
    /// With LOG: the goals hold for K, tau, Td at ± this many standard errors (0..=5; 0: nominal only).
    #[arg(long, default_value_t = 2.0)]
    pub sigma: f64,
    /// Keep the feedforward (Betaflight F, PX4 FF) as flown (from a log) or at the firmware's default, instead of fitting it to the tuned loop.
    #[arg(long)]
    pub keep_feedforward: bool,
    /// With LOG: tune the gyro lowpass (×0.8–1.5, de-embedded from the identified plant) and the
    /// D-term lowpass cutoffs (×0.8–1.75) beside P, I, D, for Betaflight, INAV, PX4 and ArduPilot
    /// (never below 1.5× the crossover, never raised above the log's Nyquist frequency, no noise
    /// band over the budget), printing the firmware's lines for them.
    #[arg(long)]
    pub tune_filters: bool,
    /// Optimizer starts (1..=64).
    #[arg(long, default_value_t = 8)]
    pub starts: usize,
    /// Write cli.txt, tune.json, the controller, plots and report.html here.
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
    /// Print the JSON (gains, feedback_controller, margins, goals, cli).
    #[arg(long)]
    pub json: bool,
}

/// Runs the tuning and prints the proposal.
pub fn run(a: Args) -> skyloop::Result<()> {
    if let Some(log) = &a.log {
        return run_log(log.clone(), &a);
    }
    for (flag, given) in [
        ("--session", a.session.is_some()),
        ("--fmin-hz", a.fmin_hz.is_some()),
        ("--fmax-hz", a.fmax_hz.is_some()),
        ("--tune-filters", a.tune_filters),
    ] {
        if given {
            return Err(skyloop::Error::Input(format!(
                "{flag} needs a LOG (it has no meaning with --plant)"
            )));
        }
    }
    let plant = a.plant.as_deref().unwrap_or_default();
    let firmware = a.firmware.as_deref().ok_or_else(|| {
        skyloop::Error::Input(
            "--firmware is needed with --plant: betaflight, inav, px4, ardupilot or generic (with a LOG it is read from the log)".into(),
        )
    })?;
    let mut req = TuneRequest::new(load_model(plant)?, Firmware::parse(firmware)?);
    req.structure = GenericStructure::parse(&a.structure)?;
    req.d_filter_tau_s = a.d_filter_tau;
    req.goals = a.goals.clone();
    req.maximize = Maximize::parse(a.maximize.as_deref().unwrap_or("integral_gain"))?;
    req.axis = Axis::parse(a.axis.as_deref().unwrap_or("roll"))?;
    req.starts = a.starts;
    req.tune_feedforward = !a.keep_feedforward;
    let out = run_tune(&req)?;
    if let Some(dir) = &a.out {
        write_outputs(&out, dir)?;
        eprintln!("wrote {}", dir.display());
    }
    if a.json {
        return print_json(&out.to_json());
    }
    print_outcome(&out);
    Ok(())
}

fn print_outcome(out: &skyloop::tune::TuneOutcome) {
    println!("gains    {}", out.gains);
    let m = &out.margins;
    println!(
        "margins  disk alpha {:.4}  GM {:.2} dB  PM {:.2} deg at {:.3} Hz  Ms {:.3}  (exact delay, re-verified)",
        m.disk_alpha, m.gain_margin_db, m.phase_margin_deg, m.crossover_hz, m.ms
    );
    for g in &out.goals {
        println!(
            "goal     {:<40} {:>12.5}  {}",
            g.label,
            g.value,
            if g.met { "met" } else { "NOT MET" }
        );
    }
    for d in &out.defaults {
        println!("default  {d}");
    }
    for n in &out.notes {
        println!("note     {n}");
    }
    for l in &out.cli {
        println!("{l}");
    }
}

fn run_log(log: std::path::PathBuf, a: &Args) -> skyloop::Result<()> {
    if a.plant.is_some() {
        return Err(skyloop::Error::Input("give LOG or --plant, not both".into()));
    }
    let axes: Vec<Axis> = match &a.axis {
        Some(x) => vec![Axis::parse(x)?],
        None => vec![Axis::Roll, Axis::Pitch, Axis::Yaw],
    };
    let firmware = a.firmware.as_deref().map(Firmware::parse).transpose()?;
    let mut req = LogTuneRequest::new(log.clone(), axes[0], firmware);
    req.session = a.session;
    req.fmin_hz = a.fmin_hz;
    req.fmax_hz = a.fmax_hz;
    req.sigma = a.sigma;
    req.structure = GenericStructure::parse(&a.structure)?;
    req.d_filter_tau_s = a.d_filter_tau;
    req.goals = a.goals.clone();
    if let Some(m) = &a.maximize {
        req.maximize = Maximize::parse(m)?;
    }
    req.starts = a.starts;
    req.tune_feedforward = !a.keep_feedforward;
    req.noise_budget = a.noise_budget;
    req.tune_filters = a.tune_filters;
    req.progress = Some(show_stage);
    // The log is read once; an unreadable one (or a --firmware it does not match) fails before any
    // axis starts.
    let tuned = tune_axes_from_log(&req, &axes)?;
    finish_progress();
    let outs: Vec<Result<LogTuneOutcome, Refusal>> = axes
        .iter()
        .zip(tuned.outcomes)
        .map(|(&axis, r)| r.map_err(|e| Refusal::new(axis, tuned.firmware, &e)))
        .collect();
    // One axis given: its refusal is the command's (exit 2), with what to fly.
    if axes.len() == 1 {
        if let Some(Err(r)) = outs.first() {
            return Err(skyloop::Error::Input(match &r.what_to_fly {
                Some(w) => format!("{}\nwhat to fly: {w}", r.reason),
                None => r.reason.clone(),
            }));
        }
    }
    eprintln!(
        "[{}] report …",
        if axes.len() == 1 { axes[0].name() } else { "all axes" }
    );
    if let Some(dir) = &a.out {
        for o in outs.iter().flatten() {
            let sub = if axes.len() == 1 {
                dir.clone()
            } else {
                dir.join(o.axis.name())
            };
            skyloop::tune::report::write_log_outputs(o, &sub)?;
        }
        eprintln!("wrote {}", dir.display());
    }
    if a.json {
        print_log_json(&outs)?;
    } else {
        print_log_text(&outs, axes.len() > 1);
    }
    // Every axis refused: the answers are printed, and the status says no gains came of it.
    if outs.iter().all(|o| o.is_err()) {
        return Err(skyloop::Error::Input(format!(
            "{}: no axis could be tuned (each axis's reason and what to fly are above)",
            log.display()
        )));
    }
    Ok(())
}

fn print_log_json(outs: &[Result<LogTuneOutcome, Refusal>]) -> skyloop::Result<()> {
    if let [Ok(o)] = outs {
        return print_json(&o.to_json());
    }
    let mut m = serde_json::Map::new();
    for o in outs {
        match o {
            Ok(o) => m.insert(o.axis.name().into(), o.to_json()),
            Err(r) => m.insert(r.axis.name().into(), r.to_json()),
        };
    }
    print_json(&serde_json::json!({"axes": m, "cli": all_cli(outs)}))
}

fn print_log_text(outs: &[Result<LogTuneOutcome, Refusal>], several: bool) {
    for o in outs {
        match o {
            Ok(o) => println!("verdict  {}", o.verdict.text),
            Err(r) => {
                println!("verdict  {}", r.verdict().text);
                if let Some(w) = &r.what_to_fly {
                    println!("         what to fly: {w}");
                }
            }
        }
    }
    for o in outs.iter().flatten() {
        println!();
        println!("== {} ==", o.axis.name());
        print_log_outcome(o);
    }
    if several {
        println!();
        println!("== the lines to paste (every axis with a proposal) ==");
        for l in all_cli(outs) {
            println!("{l}");
        }
    }
}

/// The flight's stretches, used or not and why: one line each, the longest unused ones when there
/// are many (the JSON's `segments` has every one).
fn print_segments(tl: &[SegmentVerdict]) {
    const MAX_LINES: usize = 12;
    let (used, total) = SegmentVerdict::used_of_total_s(tl);
    println!("segments {used:.1} s of {total:.1} s used ({} stretches)", tl.len());
    let shown = SegmentVerdict::headline(tl, MAX_LINES);
    for s in &shown {
        println!(
            "segment  {:>8.2} – {:>8.2} s  {}  {}",
            s.start_s,
            s.end_s,
            if s.used { "used    " } else { "not used" },
            s.reason
        );
    }
    if shown.len() < tl.len() {
        println!(
            "segment  … {} shorter unused stretches (all in the JSON's segments)",
            tl.len() - shown.len()
        );
    }
}

/// The spinner a terminal sees (None when stderr is not one: then each stage is a line).
pub(crate) fn spinner() -> Option<&'static indicatif::ProgressBar> {
    use std::io::IsTerminal;
    static BAR: std::sync::OnceLock<Option<indicatif::ProgressBar>> = std::sync::OnceLock::new();
    BAR.get_or_init(|| {
        std::io::stderr().is_terminal().then(|| {
            let b = indicatif::ProgressBar::new_spinner();
            b.enable_steady_tick(std::time::Duration::from_millis(120));
            b
        })
    })
    .as_ref()
}

/// Shows a stage of a log tune on stderr.
fn show_stage(axis: Axis, stage: &str) {
    match spinner() {
        Some(b) => b.set_message(format!("{}: {stage}", axis.name())),
        None => eprintln!("[{}] {stage} …", axis.name()),
    }
}

/// Clears the spinner before the results are printed.
fn finish_progress() {
    if let Some(b) = spinner() {
        b.finish_and_clear();
    }
}

/// The pasteable lines of every axis with a proposal, one `save` at the end.
fn all_cli(outs: &[Result<LogTuneOutcome, Refusal>]) -> Vec<String> {
    let mut lines: Vec<String> = outs
        .iter()
        .flatten()
        .filter(|o| o.verdict.kind == skyloop::tune::verdict::VerdictKind::Propose)
        .flat_map(|o| o.proposed.cli.iter().filter(|l| *l != "save").cloned())
        .collect();
    if lines.iter().any(|l| l.starts_with("set ")) {
        lines.push("save".into());
    }
    lines
}

fn print_log_outcome(out: &LogTuneOutcome) {
    print_segments(&out.identification.timeline);
    for (k, (v, s)) in &out.params {
        println!("plant    {k} = {v:.6} ± {s:.6}");
    }
    for f in &out.filters {
        println!("filter   {f}");
    }
    let row = |name: &str, f: &dyn Fn(&skyloop::tune::log::TuneAnalysis) -> String| {
        println!(
            "{name:<28} {:>22} {:>22}",
            out.current.as_ref().map(f).unwrap_or_else(|| "-".into()),
            f(&out.proposed_analysis)
        );
    };
    println!("{:<28} {:>22} {:>22} {:>9}", "", "flown", "proposed", "change");
    let gain_rows = |g: &serde_json::Value| -> Vec<(String, f64)> {
        g.as_object()
            .map(|m| m.iter().filter_map(|(k, v)| Some((k.clone(), v.as_f64()?))).collect())
            .unwrap_or_default()
    };
    let flown_rows = out.current.as_ref().map(|c| gain_rows(&c.gains)).unwrap_or_default();
    for (k, v) in gain_rows(&out.proposed_analysis.gains) {
        let f = flown_rows.iter().find(|(n, _)| *n == k).map(|x| x.1);
        println!(
            "{:<28} {:>22} {:>22} {:>9}",
            format!("gain {k}"),
            f.map(|x| x.to_string()).unwrap_or_else(|| "-".into()),
            v,
            f.map(|x| skyloop::tune::verdict::pct(v, x)).unwrap_or_default()
        );
    }
    row("disk margin alpha", &|t| format!("{:.3}", t.margins.disk_alpha));
    row("  worst over uncertainty", &|t| format!("{:.3}", t.worst.disk_alpha));
    row("gain margin [dB]", &|t| format!("{:.2}", t.margins.gain_margin_db));
    row("phase margin [deg]", &|t| format!("{:.1}", t.margins.phase_margin_deg));
    row("crossover [Hz]", &|t| format!("{:.2}", t.margins.crossover_hz));
    row("Ms", &|t| format!("{:.3}", t.margins.ms));
    row("  worst over uncertainty", &|t| format!("{:.3}", t.worst.ms));
    row("noise gain |C_fb| max", &|t| format!("{:.4}", t.noise_gain));
    row("step rise time [ms]", &|t| {
        t.rise_time_s
            .map(|x| format!("{:.1}", 1e3 * x))
            .unwrap_or_else(|| "-".into())
    });
    row("step overshoot [%]", &|t| {
        t.overshoot_pct.map(|x| format!("{x:.1}")).unwrap_or_else(|| "-".into())
    });
    for (i, label) in ["6-DOF 200 deg/s overshoot %", "6-DOF 500 deg/s overshoot %"]
        .iter()
        .enumerate()
    {
        row(label, &|t| {
            t.flight
                .as_ref()
                .map(|f| {
                    format!(
                        "{:.1}{}",
                        f.doublets[i].overshoot_pct,
                        if f.crashed { " CRASH" } else { "" }
                    )
                })
                .unwrap_or_else(|| "-".into())
        });
    }
    row("6-DOF RMS error 200 [deg/s]", &|t| {
        t.flight
            .as_ref()
            .map(|f| format!("{:.1}", f.doublets[0].rms_error_deg_s))
            .unwrap_or_else(|| "-".into())
    });
    if let Some(n) = &out.noise {
        println!(
            "motor noise (predicted from the log's gyro spectrum, {:.0}–{:.0} Hz): proposed/flown power {:.2}{}",
            n.band_hz.0,
            n.band_hz.1,
            n.ratio(),
            n.dterm_check
                .map(|c| format!("; check on the flown tune: logged D-term power / predicted {c:.2}"))
                .unwrap_or_default()
        );
        for (b, f, p) in &n.bands {
            println!(
                "  {:>6.0}–{:<6.0} Hz  flown {f:.4e}  proposed {p:.4e}  ratio {:.2}",
                b.0,
                b.1,
                p / f.max(f64::MIN_POSITIVE)
            );
        }
    }
    if !out.front.is_empty() {
        println!("trade-off front (bounded change; screened on the frequency grid):");
        for (g, sc, r) in &out.front {
            println!(
                "  {g}  crossover {:.1} Hz  disk α {:.2} (worst {:.2})  noise ×{r:.2}",
                sc.crossover_hz, sc.alpha, sc.alpha_worst
            );
        }
    }
    match (&out.measured_step, out.model_step_rms) {
        (Some(m), Some(r)) => println!(
            "model check: predicted step of the current tune vs the step deconvolved from the log ({} of {} windows): RMS difference {r:.3}; {:.0} % of the deconvolved impulse response at negative lag",
            m.windows, m.windows_total, 100.0 * m.acausal_fraction
        ),
        (Some(m), None) => println!("measured step from {} windows (no current tune to compare)", m.windows),
        (None, _) => println!(
            "no measured step: {}",
            out.measured_step_error.as_deref().unwrap_or("unknown")
        ),
    }
    if let Some(c) = &out.closed_loop {
        println!(
            "model check: closed loop setpoint → gyro of the flown tune, {:.1}–{:.1} Hz: measured peak {:.1} dB at {:.1} Hz, predicted {:.1} dB at {:.1} Hz, RMS difference {:.1} dB",
            c.freq_hz.first().copied().unwrap_or(0.0),
            c.freq_hz.last().copied().unwrap_or(0.0),
            c.measured_peak.0,
            c.measured_peak.1,
            c.predicted_peak.0,
            c.predicted_peak.1,
            c.rms_db
        );
    }
    if let Some(c) = &out.crossover_check {
        let (m, mf, me) = c.measured_peak();
        let (p, pf) = c.predicted_peak();
        println!(
            "model check: at the flown crossover ({:.1} Hz; {} measured points, {:.1}–{:.1} Hz): |S| of the flown loop on the measured plant peaks at {m:.1} ± {me:.1} dB ({mf:.1} Hz), on the model at {p:.1} dB ({pf:.1} Hz): {}",
            c.crossover_hz,
            c.freq_hz.len(),
            c.freq_hz.first().copied().unwrap_or(0.0),
            c.freq_hz.last().copied().unwrap_or(0.0),
            if c.disagrees() { "they DISAGREE: the model is wrong where the margins are decided" } else { "they agree" }
        );
    }
    if let (Some(m), Some(r)) = (&out.causal_step, out.causal_step_rms) {
        println!(
            "model check: predicted step of the current tune vs the causal FIR step from the log: RMS difference {r:.3}; the future setpoint explains {:.0} % of its residual",
            100.0 * m.acausal_fraction
        );
    }
    for c in &out.filter_changes {
        println!(
            "filter change  {} {} → {} Hz: {}",
            c.name, c.flown_hz, c.proposed_hz, c.reason
        );
    }
    for n in &out.notes {
        println!("note     {n}");
    }
    for w in out.identification.warnings.iter().chain(&out.warnings) {
        println!("warning  {w}");
    }
    print_outcome(&out.proposed);
}
