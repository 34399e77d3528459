//! `skyloop c2d MODEL --dt T --method zoh|foh|tustin|matched [--prewarp-hz F]`: discretize a model.

use crate::output;
use skyloop::lti::discretize::{c2d, Method};

/// Arguments of `skyloop c2d`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression or path to an LTI JSON file (continuous time).
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// Sample time in seconds.
    #[arg(long)]
    dt: f64,
    /// Discretization method: zoh, foh, tustin or matched.
    #[arg(long, default_value = "zoh")]
    method: String,
    /// Tustin prewarp frequency in Hz (the responses agree exactly there).
    #[arg(long)]
    prewarp_hz: Option<f64>,
    /// Print LTI JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// Discretizes the model and prints it.
pub fn run(a: Args) -> skyloop::Result<()> {
    let sys = skyloop::model::load_model(&a.model)?;
    let mut method: Method = a.method.parse().map_err(|e| format!("{e}"))?;
    if let Some(f) = a.prewarp_hz {
        match method {
            Method::Tustin { .. } => {
                method = Method::Tustin {
                    prewarp_rad_s: Some(2.0 * std::f64::consts::PI * f),
                }
            }
            _ => return Err("--prewarp-hz applies to the tustin method only".into()),
        }
    }
    let d = c2d(&sys, a.dt, method)?;
    if a.json {
        return output::print_json(&skyloop::lti::json::LtiJson::from_ss(&d));
    }
    println!(
        "{} states, {} outputs, {} inputs, dt = {} s",
        d.nx(),
        d.ny(),
        d.nu(),
        d.dt
    );
    for (name, m) in [("A", &d.a), ("B", &d.b), ("C", &d.c), ("D", &d.d)] {
        println!("{name} =");
        print!("{}", output::matrix_table(m));
    }
    if d.has_delay() {
        println!(
            "input delay (s): {:?}\noutput delay (s): {:?}",
            d.input_delay, d.output_delay
        );
    }
    Ok(())
}
