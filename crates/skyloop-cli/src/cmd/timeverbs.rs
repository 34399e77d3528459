//! `skyloop lsim MODEL --input SPEC|FILE.csv [--dt T --tfinal T] [--out F.csv|.svg|.png|.html] [--json]`,
//! `skyloop impulse MODEL [--tfinal T] [--out ...] [--json]` and `skyloop d2c MODEL --method zoh|tustin`:
//! MATLAB's time-domain verbs and the inverse of c2d (thin: parse, call skyloop, print).

use super::plot_args::save;
use crate::output;
use skyloop::lti::discretize::{d2c, Method};
use skyloop::model::load_model;
use skyloop::plot::traces::{traces_figure, Trace, TracePanel};
use skyloop::timeverbs::{grid, impulse, lsim, read_inputs, signal, Simulation};

/// Arguments of `skyloop lsim`.
#[derive(clap::Args)]
pub struct LsimArgs {
    /// Transfer-function expression or LTI JSON path.
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// The input: step, ramp, sin:F[:A] (F in Hz), square:F[:A], pulse:W[:A] (W in s), the same for
    /// every input; or a CSV file (header, then time_s and one column per input, uniform times).
    #[arg(long)]
    input: String,
    /// Sample time, s (with a signal spec).
    #[arg(long)]
    dt: Option<f64>,
    /// Final time, s (with a signal spec).
    #[arg(long)]
    tfinal: Option<f64>,
    /// Write the response: .csv (time, inputs, outputs) or a plot (.svg, .png, .html).
    #[arg(long)]
    out: Option<std::path::PathBuf>,
    /// Print {"t_s", "u", "y"} as JSON.
    #[arg(long)]
    json: bool,
}

/// Arguments of `skyloop impulse`.
#[derive(clap::Args)]
pub struct ImpulseArgs {
    /// Transfer-function expression or LTI JSON path.
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// Final time, s (default: fitted to the slowest pole).
    #[arg(long)]
    tfinal: Option<f64>,
    /// Write the response: .csv or a plot (.svg, .png, .html).
    #[arg(long)]
    out: Option<std::path::PathBuf>,
    /// Print {"t_s", "y"} as JSON (y[k][output·inputs + input]).
    #[arg(long)]
    json: bool,
}

/// Arguments of `skyloop d2c`.
#[derive(clap::Args)]
pub struct D2cArgs {
    /// A discrete model (LTI JSON with dt > 0, or an expression in z with --dt).
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// zoh (matrix logarithm, the inverse of c2d zoh) or tustin.
    #[arg(long, default_value = "zoh")]
    method: String,
    /// Print LTI JSON instead of the transfer function.
    #[arg(long)]
    json: bool,
    /// Sample time, s, of an expression in z.
    #[arg(long)]
    dt: Option<f64>,
}

fn write(sim: &Simulation, out: &Option<std::path::PathBuf>, json: bool, title: &str) -> skyloop::Result<()> {
    if let Some(path) = out {
        if path.extension().and_then(|e| e.to_str()) == Some("csv") {
            let mut s = String::from("time_s");
            let nu = sim.u.first().map_or(0, Vec::len);
            let ny = sim.y.first().map_or(0, Vec::len);
            (0..nu).for_each(|j| s += &format!(",u{}", j + 1));
            (0..ny).for_each(|i| s += &format!(",y{}", i + 1));
            s.push('\n');
            for (k, t) in sim.t_s.iter().enumerate() {
                s += &format!("{t}");
                sim.u
                    .get(k)
                    .into_iter()
                    .flatten()
                    .chain(&sim.y[k])
                    .for_each(|v| s += &format!(",{v}"));
                s.push('\n');
            }
            std::fs::write(path, s).map_err(|e| skyloop::Error::write(path, e))?;
            eprintln!("wrote {}", path.display());
        } else {
            let ny = sim.y.first().map_or(0, Vec::len);
            let trace = |label: String, v: Vec<f64>| Trace {
                label,
                t: sim.t_s.clone(),
                y: v,
            };
            let mut panels = vec![TracePanel {
                y_label: "output".into(),
                traces: (0..ny)
                    .map(|i| trace(format!("y{}", i + 1), sim.y.iter().map(|r| r[i]).collect()))
                    .collect(),
                references: Vec::new(),
            }];
            if let Some(nu) = sim.u.first().map(Vec::len).filter(|n| *n > 0) {
                panels.push(TracePanel {
                    y_label: "input".into(),
                    traces: (0..nu)
                        .map(|j| trace(format!("u{}", j + 1), sim.u.iter().map(|r| r[j]).collect()))
                        .collect(),
                    references: Vec::new(),
                });
            }
            save(traces_figure(title, &panels), None, path)?;
        }
    }
    if json {
        return output::print_json(sim);
    }
    if out.is_none() {
        let last = sim.y.last().cloned().unwrap_or_default();
        let peak = sim.y.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
        println!(
            "{} samples to t = {} s; final y = {last:?}; largest |y| = {peak:?}",
            sim.t_s.len(),
            sim.t_s.last().unwrap_or(&0.0)
        );
    }
    Ok(())
}

/// `lsim`.
pub fn run_lsim(a: LsimArgs) -> skyloop::Result<()> {
    let sys = load_model(&a.model)?;
    let path = std::path::Path::new(&a.input);
    let (t, u) = if path.is_file() {
        if a.dt.is_some() || a.tfinal.is_some() {
            return Err("--dt and --tfinal come from the CSV file's times; give them only with a signal spec".into());
        }
        read_inputs(path, sys.nu())?
    } else {
        let f = signal(&a.input)?;
        let dt = a.dt.ok_or("--dt is needed with a signal spec")?;
        skyloop::timeverbs::check_sampling(&a.input, dt)?;
        let t = grid(dt, a.tfinal.ok_or("--tfinal is needed with a signal spec")?)?;
        let u = t.iter().map(|&x| vec![f(x); sys.nu()]).collect();
        (t, u)
    };
    write(&lsim(&sys, &t, u)?, &a.out, a.json, "Linear simulation (lsim)")
}

/// `impulse`.
pub fn run_impulse(a: ImpulseArgs) -> skyloop::Result<()> {
    let sys = load_model(&a.model)?;
    let t = match a.tfinal {
        Some(tf) => {
            let g = skyloop::lti::timeresp::auto_grid(&sys, Some(tf))?;
            if g.len() > skyloop::timeverbs::MAX_SAMPLES {
                return Err(format!(
                    "--tfinal {tf} s needs {} samples; at most {}",
                    g.len(),
                    skyloop::timeverbs::MAX_SAMPLES
                )
                .into());
            }
            Some(g)
        }
        None => None,
    };
    write(&impulse(&sys, t.as_deref())?, &a.out, a.json, "Impulse response")
}

/// `d2c`.
pub fn run_d2c(a: D2cArgs) -> skyloop::Result<()> {
    let sys = skyloop::model::load_model_dt(&a.model, a.dt)?;
    if sys.is_continuous() {
        return Err(format!(
            "{}: the model is continuous; d2c needs a discrete one (dt > 0)",
            a.model
        )
        .into());
    }
    let method: Method = match a.method.as_str() {
        "zoh" | "tustin" => a.method.parse().map_err(|e| format!("{e}"))?,
        m => return Err(format!("--method {m}: d2c takes zoh or tustin").into()),
    };
    let c = d2c(&sys, method)?;
    if a.json {
        return output::print_json(&skyloop::lti::json::LtiJson::from_ss(&c));
    }
    println!("{} states, {} outputs, {} inputs, continuous", c.nx(), c.ny(), c.nu());
    for row in skyloop::model::expressions(&c, skyloop::model::Form::Zpk)? {
        println!("{}", row.join("  "));
    }
    Ok(())
}
