//! `skyloop step MODEL.. --out FILE [--closed-loop] [--tfinal S] [--json]`: unit-step responses,
//! plotted overlaid; with `--closed-loop` each SISO model is a loop transfer L and the response is
//! that of T = L/(1 + L), with a loop delay kept exact (a delay-line simulation,
//! `skyloop::sim::delayed_loop`).

use serde::Serialize;
use skyloop::lti::StateSpace;
use skyloop::plot::traces::{plot_step, Trace};

use super::plot_args::{channel, label};
use crate::output;

/// Arguments of `skyloop step`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expressions or paths to LTI JSON files; each becomes one curve per channel.
    #[arg(required = true)]
    models: Vec<String>,
    /// Output plot file, `.svg` or `.png` (optional with --json).
    #[arg(long)]
    out: Option<std::path::PathBuf>,
    /// Close a unit negative-feedback loop around each model first (the model is L = P·C).
    #[arg(long)]
    closed_loop: bool,
    /// Final time, s (default: from the slowest pole of all models).
    #[arg(long)]
    tfinal: Option<f64>,
    /// Print `{"models":[{"label","t_s","y":[output][input][k]}]}` instead of a summary.
    #[arg(long)]
    json: bool,
    /// Plot title.
    #[arg(long, default_value = "Step response")]
    title: String,
}

#[derive(Serialize)]
struct StepJson {
    label: String,
    t_s: Vec<f64>,
    y: Vec<Vec<Vec<f64>>>,
}

/// Simulates every model on a shared final time and writes the plot and/or JSON.
pub fn run(a: Args) -> skyloop::Result<()> {
    if a.out.is_none() && !a.json {
        return Err("nothing to do: give --out FILE.svg|.png and/or --json".into());
    }
    // (label, model whose step is shown, the delayed loop transfer when the loop is closed around a delay).
    let mut models: Vec<(String, StateSpace, Option<StateSpace>)> = Vec::new();
    for m in &a.models {
        let mut sys = skyloop::model::load_model(m)?;
        let mut delayed = None;
        if a.closed_loop {
            if sys.ny() != 1 || sys.nu() != 1 {
                return Err(format!(
                    "--closed-loop needs a SISO loop transfer, {m} is {}×{}",
                    sys.ny(),
                    sys.nu()
                )
                .into());
            }
            let unity = StateSpace::gain(skyloop::lti::Mat::identity(1, 1), sys.dt)?;
            if sys.has_delay() && sys.is_continuous() {
                // The response is simulated with the exact delay (a delay line); the Padé closed loop
                // only sets the time scale of the automatic grid.
                let rational = sys.try_pade(3)?;
                let cl =
                    skyloop::lti::interconnect::feedback(&rational, &unity, -1.0).map_err(|e| format!("{m}: {e}"))?;
                delayed = Some(std::mem::replace(&mut sys, cl));
            } else {
                sys = skyloop::lti::interconnect::feedback(&sys, &unity, -1.0).map_err(|e| format!("{m}: {e}"))?;
            }
        }
        models.push((m.clone(), sys, delayed));
    }
    // One final time for all, so the curves share the axis: the longest of the automatic ones.
    let tfinal = match a.tfinal {
        Some(t) => t,
        None => {
            let mut t: f64 = 0.0;
            for (m, sys, _) in &models {
                let g = skyloop::lti::timeresp::auto_grid(sys, None).map_err(|e| format!("{m}: {e}"))?;
                t = t.max(g[g.len() - 1]);
            }
            t
        }
    };
    let mut results = Vec::new();
    let mut traces = Vec::new();
    for (m, sys, delayed) in &models {
        let grid = skyloop::lti::timeresp::auto_grid(sys, Some(tfinal)).map_err(|e| format!("{m}: {e}"))?;
        let r = match delayed {
            Some(l) => skyloop::lti::timeresp::TimeResponse {
                y: vec![vec![
                    skyloop::sim::delayed_loop::closed_loop_step(l, &grid).map_err(|e| format!("{m}: {e}"))?
                ]],
                t_s: grid,
            },
            None => skyloop::lti::timeresp::step(sys, Some(&grid)).map_err(|e| format!("{m}: {e}"))?,
        };
        for (i, row) in r.y.iter().enumerate() {
            for (j, y) in row.iter().enumerate() {
                traces.push(Trace {
                    label: format!("{}{}", label(m), channel(sys, i, j)),
                    t: r.t_s.clone(),
                    y: y.clone(),
                });
            }
        }
        results.push(StepJson {
            label: m.clone(),
            t_s: r.t_s,
            y: r.y,
        });
    }
    if let Some(out) = &a.out {
        plot_step(out, &a.title, &traces)?;
        eprintln!("wrote {}", out.display());
    }
    if a.json {
        return output::print_json(&serde_json::json!({ "models": results }));
    }
    for tr in &traces {
        let last = tr.y.last().copied().unwrap_or(f64::NAN);
        let peak = tr.y.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        println!(
            "{:<50} final {last:>10.4}  peak {peak:>10.4}  (t = 0 .. {tfinal:.3} s)",
            tr.label
        );
    }
    Ok(())
}
