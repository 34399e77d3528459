//! `skyloop step MODEL.. --out FILE [--closed-loop] [--tfinal S] [--json]`: unit-step responses,
//! plotted overlaid with MATLAB's `stepinfo` marks (rise, settling, overshoot, undershoot, peak);
//! with `--closed-loop` each SISO model is a loop transfer L and the response is that of
//! T = L/(1 + L), a loop delay kept exact (a delay-line simulation).

use super::plot_args::{save, ModelArgs};
use crate::output;

/// Arguments of `skyloop step`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    models: ModelArgs,
    /// Output plot file, `.svg`, `.png` or `.html` (optional with --json).
    #[arg(long)]
    out: Option<std::path::PathBuf>,
    /// Close a unit negative-feedback loop around each model first (the model is L = P·C).
    #[arg(long)]
    closed_loop: bool,
    /// Final time, s (default: 1.5× the latest 2 % settling time, or about seven time constants of
    /// the slowest pole when a response does not settle).
    #[arg(long)]
    tfinal: Option<f64>,
    /// Print `{"models":[{"label","t_s","y":[output][input][k],"info":[output][input]}]}` instead
    /// of a summary.
    #[arg(long)]
    json: bool,
    /// Plot title.
    #[arg(long)]
    title: Option<String>,
}

/// Simulates every model on a shared window and writes the plot and/or JSON.
pub fn run(a: Args) -> skyloop::Result<()> {
    if a.out.is_none() && !a.json {
        return Err("nothing to do: give --out FILE.svg|.png|.html and/or --json".into());
    }
    if let Some(t) = a.tfinal {
        if !(t > 0.0 && t.is_finite()) {
            return Err(format!("--tfinal must be a positive finite time in s, got {t}").into());
        }
    }
    let models = a.models.load()?;
    let (fig, runs) = skyloop::figures::step(&models, a.closed_loop, a.tfinal)?;
    if let Some(out) = &a.out {
        save(fig, a.title.as_deref(), out)?;
    }
    if a.json {
        return output::print_json(&serde_json::json!({ "models": runs }));
    }
    let opt = |v: Option<f64>, unit: &str| v.map_or("—".to_string(), |v| format!("{v:.4} {unit}"));
    println!(
        "{:<40} {:>10} {:>12} {:>12} {:>11} {:>11}",
        "model", "final", "rise (s)", "settle (s)", "overshoot", "undershoot"
    );
    for r in &runs {
        for (i, row) in r.info.iter().enumerate() {
            for (j, s) in row.iter().enumerate() {
                let name = if r.info.len() * row.len() > 1 {
                    format!("{} [out {} ← in {}]", r.label, i + 1, j + 1)
                } else {
                    r.label.clone()
                };
                println!(
                    "{name:<40} {:>10} {:>12} {:>12} {:>11} {:>11}",
                    if s.final_value.is_finite() {
                        format!("{:.4}", s.final_value)
                    } else {
                        "none".into()
                    },
                    opt(s.rise_time_s, ""),
                    opt(s.settling_time_s, ""),
                    opt(s.overshoot_pct, "%"),
                    opt(s.undershoot_pct, "%"),
                );
            }
        }
    }
    println!(
        "(t = 0 .. {:.4} s; rise 10–90 %, settling within 2 %)",
        runs[0].t_s.last().copied().unwrap_or(0.0)
    );
    Ok(())
}
