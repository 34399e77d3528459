//! `skyloop tune --plant MODEL --firmware betaflight|px4|generic ...`: gains for the flight
//! controller, tuned against margin goals and re-verified (thin: parse, call skyloop::tune, print).

use crate::output::print_json;
use clap::Args as ClapArgs;
use skyloop::firmware::betaflight::Axis;
use skyloop::model::load_model;
use skyloop::tune::{report::write_outputs, tune as run_tune, Firmware, GenericStructure, Maximize, TuneRequest};

/// Arguments of `skyloop tune`.
#[derive(ClapArgs)]
pub struct Args {
    /// The rate-loop plant (expression or LTI JSON), in the firmware's units (Betaflight: PID sum → deg/s; PX4: normalized torque → rad/s).
    #[arg(long, allow_hyphen_values = true)]
    pub plant: String,
    /// betaflight, px4 or generic.
    #[arg(long)]
    pub firmware: String,
    /// generic only: pi, pid or pidf (pidf = pid: kp + ki/s + kd·s/(tf·s+1)).
    #[arg(long, default_value = "pid")]
    pub structure: String,
    /// generic pid: fix the derivative filter time constant tf (s) instead of tuning it.
    #[arg(long)]
    pub d_filter_tau: Option<f64>,
    /// A goal, repeatable: ms<=1.4, mt<=1.3, disk_margin>=0.6, gain_margin_db>=6, phase_margin_deg>=45, crossover_hz>=20.
    #[arg(long = "goal", allow_hyphen_values = true)]
    pub goals: Vec<String>,
    /// What to maximize once the goals hold: integral_gain (default) or crossover.
    #[arg(long, default_value = "integral_gain")]
    pub maximize: String,
    /// Axis the gains are for: roll, pitch or yaw.
    #[arg(long, default_value = "roll")]
    pub axis: String,
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
    let mut req = TuneRequest::new(load_model(&a.plant)?, Firmware::parse(&a.firmware)?);
    req.structure = GenericStructure::parse(&a.structure)?;
    req.d_filter_tau_s = a.d_filter_tau;
    req.goals = a.goals;
    req.maximize = Maximize::parse(&a.maximize)?;
    req.axis = Axis::parse(&a.axis)?;
    req.starts = a.starts;
    let out = run_tune(&req)?;
    if let Some(dir) = &a.out {
        write_outputs(&out, dir)?;
        eprintln!("wrote {}", dir.display());
    }
    if a.json {
        return print_json(&out.to_json());
    }
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
    Ok(())
}
