//! `skyloop simulate SCENARIO.toml`: nonlinear closed-loop simulation → trajectory CSV, metrics JSON,
//! a trace plot; with --monte-carlo the scenario's [monte_carlo] study instead.

use crate::output;
use skyloop::simulation::{load_scenario, monte_carlo_to, simulate_to};
use std::path::PathBuf;

/// Arguments of `skyloop simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML; see examples/*.toml).
    scenario: PathBuf,
    /// Output directory for trajectory.csv, metrics.json and traces.svg.
    #[arg(long, default_value = "skyloop-sim-out")]
    out: PathBuf,
    /// Print the metrics as one JSON object on stdout.
    #[arg(long)]
    json: bool,
    /// Run the scenario's [monte_carlo] study (parallel, progress bar on stderr).
    #[arg(long)]
    monte_carlo: bool,
}

/// Runs the scenario (or its Monte Carlo study) and writes the results.
pub fn run(a: Args) -> skyloop::Result<()> {
    let scn = load_scenario(&a.scenario)?;
    if a.monte_carlo {
        if scn.monte_carlo.is_none() {
            return Err(skyloop::Error::Spec(format!(
                "{} has no [monte_carlo] section",
                a.scenario.display()
            )));
        }
        let bar = if a.json {
            indicatif::ProgressBar::hidden()
        } else {
            indicatif::ProgressBar::new(0)
        };
        let (summary, path) = monte_carlo_to(&scn, &a.out, &|done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        })?;
        bar.finish_and_clear();
        if a.json {
            return output::print_json(&summary);
        }
        println!(
            "{} runs, {} crashed, {} unsettled",
            summary.runs, summary.crashed, summary.unsettled
        );
        println!(
            "{:<22} {:>11} {:>11} {:>11} {:>11} {:>11}",
            "metric", "mean", "std", "min", "p95", "max"
        );
        let mut rows = vec![
            ("max_abs_error", summary.max_abs_error),
            ("rms_error", summary.rms_error),
            ("saturated_fraction", summary.saturated_fraction),
        ];
        if let Some(s) = summary.settling_time_s {
            rows.push(("settling_time_s", s));
        }
        for (n, s) in rows {
            println!(
                "{n:<22} {:>11.5} {:>11.5} {:>11.5} {:>11.5} {:>11.5}",
                s.mean, s.std, s.min, s.p95, s.max
            );
        }
        println!("wrote {}", path.display());
        return Ok(());
    }
    let m = simulate_to(&scn, &a.out)?;
    if a.json {
        return output::print_json(&m);
    }
    println!("max_abs_error    {:.6}", m.max_abs_error);
    println!("rms_error        {:.6}", m.rms_error);
    match m.settling_time_s {
        Some(t) => println!("settling_time_s  {t:.3}"),
        None => println!("settling_time_s  (not settled)"),
    }
    println!("saturated        {:.1} %", 100.0 * m.saturated_fraction);
    println!("crashed          {}", m.crashed);
    println!("wrote {}/trajectory.csv, trajectory.svg, metrics.json", a.out.display());
    Ok(())
}
