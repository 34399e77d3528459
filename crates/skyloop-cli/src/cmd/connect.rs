//! `skyloop series|parallel|feedback A B [--sign -1] [--out F.json] [--json]` and
//! `skyloop loopsens P C [--out DIR] [--json]`: MATLAB's interconnection verbs on expressions and
//! LTI JSON files (thin: load, call skyloop::loops, print).

use crate::output;
use skyloop::loops::{closed, in_parallel, in_series, loopsens};
use skyloop::lti::StateSpace;
use skyloop::model::{expressions, load_model, Form};

/// Arguments of `series` and `parallel`.
#[derive(clap::Args)]
pub struct Args {
    /// First model (expression or LTI JSON path); for series, the one the input enters.
    #[arg(allow_hyphen_values = true)]
    a: String,
    /// Second model.
    #[arg(allow_hyphen_values = true)]
    b: String,
    /// Write the result as LTI JSON to this file.
    #[arg(long)]
    out: Option<std::path::PathBuf>,
    /// Print the result as LTI JSON.
    #[arg(long)]
    json: bool,
}

/// Arguments of `feedback`.
#[derive(clap::Args)]
pub struct FeedbackArgs {
    #[command(flatten)]
    models: Args,
    /// −1 for negative feedback (the default, y = A·(u − B·y)), +1 for positive.
    #[arg(long, default_value_t = -1.0, allow_hyphen_values = true)]
    sign: f64,
}

/// Arguments of `loopsens`.
#[derive(clap::Args)]
pub struct LoopsensArgs {
    /// The plant P (expression or LTI JSON path).
    #[arg(allow_hyphen_values = true)]
    plant: String,
    /// The controller C, acting on the error: u = C·(r − y).
    #[arg(allow_hyphen_values = true)]
    controller: String,
    /// Write S.json, T.json, CS.json and PS.json here (loops without delays).
    #[arg(long)]
    out: Option<std::path::PathBuf>,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

/// Which verb `run` performs.
pub enum Verb {
    /// `series`.
    Series,
    /// `parallel`.
    Parallel,
}

fn emit(sys: &StateSpace, out: &Option<std::path::PathBuf>, json: bool) -> skyloop::Result<()> {
    let lti = skyloop::lti::json::LtiJson::from_ss(sys);
    if let Some(path) = out {
        let text = serde_json::to_string_pretty(&lti).map_err(|e| skyloop::Error::Input(e.to_string()))?;
        std::fs::write(path, text + "\n").map_err(|e| skyloop::Error::write(path, e))?;
        eprintln!("wrote {}", path.display());
    }
    if json {
        return output::print_json(&lti);
    }
    println!("{} states, {} outputs, {} inputs", sys.nx(), sys.ny(), sys.nu());
    for (i, row) in expressions(sys, Form::Zpk)?.iter().enumerate() {
        for (j, e) in row.iter().enumerate() {
            if sys.ny() * sys.nu() == 1 {
                println!("{e}");
            } else {
                println!("({}, {}): {e}", i + 1, j + 1);
            }
        }
    }
    Ok(())
}

/// `series` or `parallel`.
pub fn run(verb: Verb, a: Args) -> skyloop::Result<()> {
    let (g1, g2) = (load_model(&a.a)?, load_model(&a.b)?);
    let r = match verb {
        Verb::Series => in_series(&g1, &g2)?,
        Verb::Parallel => in_parallel(&g1, &g2)?,
    };
    emit(&r, &a.out, a.json)
}

/// `feedback`.
pub fn run_feedback(a: FeedbackArgs) -> skyloop::Result<()> {
    if a.sign != 1.0 && a.sign != -1.0 {
        return Err(skyloop::Error::Input(format!("--sign must be -1 or 1, got {}", a.sign)));
    }
    let (g1, g2) = (load_model(&a.models.a)?, load_model(&a.models.b)?);
    emit(&closed(&g1, &g2, a.sign)?, &a.models.out, a.models.json)
}

/// `loopsens`.
pub fn run_loopsens(a: LoopsensArgs) -> skyloop::Result<()> {
    let (p, c) = (load_model(&a.plant)?, load_model(&a.controller)?);
    let (stable, sens) = loopsens(&p, &c)?;
    let hz = |w: f64| w / (2.0 * std::f64::consts::PI);
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).map_err(|e| skyloop::Error::create(dir, e))?;
        for s in &sens {
            if let Some(m) = &s.model {
                let path = dir.join(format!("{}.json", s.name));
                let text = serde_json::to_string_pretty(&skyloop::lti::json::LtiJson::from_ss(m))
                    .map_err(|e| skyloop::Error::Input(e.to_string()))?;
                std::fs::write(&path, text + "\n").map_err(|e| skyloop::Error::write(&path, e))?;
            }
        }
        eprintln!("wrote {}", dir.display());
    }
    if a.json {
        let num = |v: f64| {
            if v.is_finite() {
                serde_json::json!(v)
            } else {
                serde_json::Value::Null
            }
        };
        let v = serde_json::json!({
            "stable": stable,
            "sensitivities": sens.iter().map(|s| serde_json::json!({
                "name": s.name, "meaning": s.meaning,
                "peak": num(s.peak), "peak_db": num(20.0 * s.peak.log10()), "peak_hz": num(hz(s.peak_w_rad_s)),
            })).collect::<Vec<_>>(),
        });
        return output::print_json(&v);
    }
    println!(
        "closed loop {}",
        if stable {
            "stable"
        } else {
            "UNSTABLE (every peak is infinite)"
        }
    );
    for s in &sens {
        let at = if s.peak_w_rad_s.is_finite() {
            format!(" at {:.4} Hz", hz(s.peak_w_rad_s))
        } else {
            String::new()
        };
        println!(
            "{:<3} peak {:.4} ({:+.2} dB){at}   {}",
            s.name,
            s.peak,
            20.0 * s.peak.log10(),
            s.meaning
        );
    }
    if sens.iter().all(|s| s.model.is_none()) {
        println!("(a delay sits inside the loop: peaks from the exact frequency response; no models written)");
    }
    Ok(())
}
