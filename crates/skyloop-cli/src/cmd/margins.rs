//! `skyloop margins MODEL [--json]`: gain, phase, delay and disk margins of a SISO loop L = P·C,
//! exact with delays, and closed-loop stability.

use crate::output;
use skyloop::lti::margins::{allmargin, diskmargin, margin_from};
use std::f64::consts::PI;

/// Arguments of `skyloop margins`.
#[derive(clap::Args)]
pub struct Args {
    /// Loop transfer L (expression or LTI JSON path); the loop is closed as u = −y (L = P·C).
    #[arg(
        allow_hyphen_values = true,
        required_unless_present = "plant",
        conflicts_with = "plant"
    )]
    model: Option<String>,
    /// A plant P: with --controller, the loop is L = P·C (MATLAB margin(P*C)).
    #[arg(long, requires = "controller", allow_hyphen_values = true)]
    plant: Option<String>,
    /// The controller C of --plant.
    #[arg(long, requires = "plant", allow_hyphen_values = true)]
    controller: Option<String>,
    /// Sample time, s: the loop expression is a discrete transfer function in z.
    #[arg(long)]
    dt: Option<f64>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

fn hz(w: f64) -> f64 {
    w / (2.0 * PI)
}

/// Computes every margin and prints them.
pub fn run(a: Args) -> skyloop::Result<()> {
    let sys = match (&a.model, &a.plant, &a.controller) {
        (Some(m), _, _) => skyloop::model::load_model_dt(m, a.dt)?,
        (None, Some(p), Some(c)) => skyloop::loops::open_loop(p, c)?,
        _ => return Err("give a loop MODEL, or --plant and --controller".into()),
    };
    let all = allmargin(&sys)?;
    let m = margin_from(&all);
    let dm = diskmargin(&sys)?;
    if a.json {
        return output::print_json(&skyloop::json_out::margins_to_json(&all, &m, &dm));
    }
    let opt = |x: f64, unit: &str| {
        if x.is_finite() {
            format!("{x:.4} {unit}")
        } else if x < 0.0 {
            "-inf".to_string()
        } else {
            "inf".to_string()
        }
    };
    let at = |w: f64| {
        if w.is_finite() {
            format!(" at {:.4} Hz", hz(w))
        } else {
            String::new()
        }
    };
    println!("closed loop        {}", if all.stable { "stable" } else { "UNSTABLE" });
    println!("gain margin        {}{}", opt(m.gm_db, "dB"), at(m.gm_w_rad_s));
    println!("phase margin       {}{}", opt(m.pm_deg, "deg"), at(m.pm_w_rad_s));
    if all.stable {
        println!("delay margin       {}", opt(m.delay_margin_s, "s"));
    } else {
        println!("delay margin       0 s (the closed loop is already unstable)");
    }
    println!(
        "disk margin        alpha {:.4}, gain [{}, {}], phase ±{:.2} deg{}",
        dm.alpha,
        opt(dm.gain_db[0], "dB"),
        opt(dm.gain_db[1], "dB"),
        dm.phase_deg,
        at(dm.w_rad_s)
    );
    println!("gain crossovers ({}):", all.phase_margins.len());
    for p in &all.phase_margins {
        // A crossover's delay margin is the delay that brings a stable loop to the edge; an
        // unstable loop has none to give (printing (PM + 360°)/ω beside "0" misled).
        let dm = if all.stable {
            format!("delay margin {:.6} s", p.delay_margin_s)
        } else {
            "delay margin — (loop unstable)".into()
        };
        println!("  {:>12.6} Hz   PM {:>9.3} deg   {dm}", hz(p.w_rad_s), p.pm_deg);
    }
    if let Some((lo, hi)) = all.unit_gain_band_rad_s {
        println!(
            "|L| = 1 on the whole band {:.4e} .. {:.4e} Hz (an all-pass loop: no isolated gain crossover)",
            hz(lo),
            hz(hi)
        );
    }
    println!("phase crossovers ({}):", all.gain_margins.len());
    for g in &all.gain_margins {
        println!("  {:>12.6} Hz   GM {:>9.3} dB", hz(g.w_rad_s), g.gm_db);
    }
    println!(
        "(searched {:.4e} .. {:.4e} Hz)",
        hz(all.w_range_rad_s.0),
        hz(all.w_range_rad_s.1)
    );
    Ok(())
}
