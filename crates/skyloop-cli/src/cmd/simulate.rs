//! `skyloop simulate SCENARIO.toml`: nonlinear closed-loop simulation → trajectory CSV, metrics JSON,
//! a trace plot; with --monte-carlo the scenario's [monte_carlo] study instead.

use crate::output;
use skyloop_sim::{sim, Sample, Scenario};
use std::path::{Path, PathBuf};

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

/// Reads and parses a scenario file.
pub fn load(path: &Path) -> Result<Scenario, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    Scenario::from_toml(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Writes trajectory.csv and traces.svg for one run into `dir`, with file names prefixed by `stem`.
pub fn write_run(dir: &Path, stem: &str, title: &str, trace: &[Sample], nu: usize) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let csv = dir.join(format!("{stem}.csv"));
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(&csv).map_err(|e| format!("cannot write {}: {e}", csv.display()))?,
    );
    sim::write_csv(&mut f, trace, nu).map_err(|e| format!("cannot write {}: {e}", csv.display()))?;
    let t: Vec<f64> = trace.iter().map(|s| s.t).collect();
    let tr = |label: &str, f: &dyn Fn(&Sample) -> f64| skyloop_plot::traces::Trace {
        label: label.into(),
        t: t.clone(),
        y: trace.iter().map(f).collect(),
    };
    let panels = vec![
        skyloop_plot::traces::TracePanel {
            y_label: "tracked (ref dashed by name)".into(),
            traces: vec![
                tr("ref0", &|s| s.reference[0]),
                tr("tracked0", &|s| s.tracked[0]),
                tr("ref1", &|s| s.reference[1]),
                tr("tracked1", &|s| s.tracked[1]),
                tr("tracked2", &|s| s.tracked[2]),
            ],
            references: vec![],
        },
        skyloop_plot::traces::TracePanel {
            y_label: "body rates [rad/s]".into(),
            traces: vec![
                tr("p", &|s| s.rates[0]),
                tr("q", &|s| s.rates[1]),
                tr("r", &|s| s.rates[2]),
            ],
            references: vec![],
        },
        skyloop_plot::traces::TracePanel {
            y_label: "torque command [N·m]".into(),
            traces: vec![
                tr("Mx", &|s| s.torque[0]),
                tr("My", &|s| s.torque[1]),
                tr("Mz", &|s| s.torque[2]),
            ],
            references: vec![],
        },
    ];
    let svg = dir.join(format!("{stem}.svg"));
    skyloop_plot::traces::plot_traces(&svg, title, &panels).map_err(|e| format!("cannot plot {}: {e}", svg.display()))
}

/// Runs the scenario (or its Monte Carlo study) and writes the results.
pub fn run(a: Args) -> Result<(), String> {
    let scn = load(&a.scenario)?;
    std::fs::create_dir_all(&a.out).map_err(|e| format!("cannot create {}: {e}", a.out.display()))?;
    if a.monte_carlo {
        let mc = scn
            .monte_carlo
            .ok_or_else(|| format!("{} has no [monte_carlo] section", a.scenario.display()))?;
        let (runs, summary) = skyloop_sim::montecarlo::run(&scn, &mc, !a.json).map_err(|e| e.to_string())?;
        let path = a.out.join("monte_carlo.json");
        let body = serde_json::json!({ "summary": summary, "runs": runs });
        std::fs::write(&path, body.to_string()).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
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
    let (trace, m) = skyloop_sim::simulate(&scn).map_err(|e| e.to_string())?;
    let nu = scn
        .vehicle
        .resolve()
        .and_then(|v| v.build())
        .map_err(|e| e.to_string())?
        .nu();
    write_run(&a.out, "trajectory", &scn.name, &trace, nu)?;
    let mpath = a.out.join("metrics.json");
    let text = serde_json::to_string(&m).map_err(|e| format!("cannot encode JSON: {e}"))?;
    std::fs::write(&mpath, &text).map_err(|e| format!("cannot write {}: {e}", mpath.display()))?;
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
