//! `skyloop simulate SCENARIO.toml`: nonlinear closed-loop simulation → trajectory CSV, metrics JSON,
//! a trace plot; with --monte-carlo the scenario's [monte_carlo] study instead (optionally only the
//! runs `--seeds A..B`, written as CSV or Parquet with `--out FILE.csv` / `FILE.parquet`, so job arrays can split a campaign).

use crate::output;
use skyloop::simulation::{
    load_scenario, monte_carlo_runs, monte_carlo_to, parse_seed_range, simulate_to, write_runs_csv,
};
use std::path::PathBuf;

/// Arguments of `skyloop simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML; see examples/*.toml).
    scenario: PathBuf,
    /// Output directory for trajectory.csv, metrics.json and traces.svg (monte_carlo.json with
    /// --monte-carlo); with --monte-carlo, a path ending in .csv or .parquet gets one row of metrics per run instead.
    #[arg(long, default_value = "skyloop-sim-out")]
    out: PathBuf,
    /// Print the metrics as one JSON object on stdout.
    #[arg(long)]
    json: bool,
    /// Run the scenario's [monte_carlo] study (parallel, progress bar on stderr).
    #[arg(long)]
    monte_carlo: bool,
    /// With --monte-carlo: only runs A..B−1 of the study (run i uses noise seed monte_carlo.seed + i).
    #[arg(long, value_name = "A..B", requires = "monte_carlo")]
    seeds: Option<String>,
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
        let progress = |done: usize, total: usize| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        };
        let ext = |x: &str| a.out.extension().is_some_and(|e| e.eq_ignore_ascii_case(x));
        let (csv, parquet) = (ext("csv"), ext("parquet"));
        let (summary, path) = if csv || parquet || a.seeds.is_some() {
            let seeds = match &a.seeds {
                Some(t) => parse_seed_range(t)?,
                None => (0..scn.monte_carlo.as_ref().map_or(0, |m| m.runs)).collect(),
            };
            let (runs, summary) = monte_carlo_runs(&scn, &seeds, None, &progress)?;
            let path = if csv || parquet {
                a.out.clone()
            } else {
                a.out.join("monte_carlo.csv")
            };
            let base = scn.monte_carlo.as_ref().map_or(0, |m| m.seed);
            if parquet {
                skyloop::simulation::write_runs_parquet(&path, base, &seeds, &runs)?;
            } else {
                write_runs_csv(&path, base, &seeds, &runs)?;
            }
            (summary, path)
        } else {
            monte_carlo_to(&scn, &a.out, &progress)?
        };
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
    let m = run_once(&scn, &a.out)?;
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

/// One run with its cost stated up front and progress on stderr (a bar on a terminal, a line every
/// 10 % otherwise) when it takes more than a million physics steps.
fn run_once(scn: &skyloop::sim::Scenario, out: &std::path::Path) -> skyloop::Result<skyloop::sim::Metrics> {
    use std::io::IsTerminal;
    let steps = (scn.sim.duration_s * scn.sim.physics_hz).round() as u64;
    if steps <= 1_000_000 {
        return simulate_to(scn, out, &mut |_, _| {});
    }
    eprintln!(
        "simulating {} s at {} Hz: {:.1} M physics steps (a few seconds per million)",
        scn.sim.duration_s,
        scn.sim.physics_hz,
        steps as f64 / 1e6
    );
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = indicatif::ProgressBar::new(steps);
        b.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {percent:>3}% of the run, {eta} left")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    let mut last_tenth = 0;
    let m = simulate_to(scn, out, &mut |done, total| match &bar {
        Some(b) => b.set_position(done),
        None => {
            let tenth = done * 10 / total.max(1);
            if tenth > last_tenth {
                last_tenth = tenth;
                eprintln!("simulated {} %", tenth * 10);
            }
        }
    });
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    m
}
