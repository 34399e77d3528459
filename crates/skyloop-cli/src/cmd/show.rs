//! `skyloop show MODEL [--form ss|tf|zpk]`: what a model is (dimensions, delays, and its matrices or
//! its entries as transfer-function expressions), or its LTI JSON.

use crate::output;
use skyloop::model::{expressions, Form};

/// Arguments of `skyloop show`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression or path to an LTI JSON file.
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// ss (matrices), tf (polynomials) or zpk (gain, zeros and poles as real factors).
    #[arg(long, default_value = "ss")]
    form: String,
    /// Print LTI JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Sample time, s: the expression is a discrete transfer function in z (delays as z^-k).
    #[arg(long)]
    dt: Option<f64>,
}

/// Loads the model and prints it.
pub fn run(a: Args) -> skyloop::Result<()> {
    let sys = skyloop::model::load_model_dt(&a.model, a.dt)?;
    if a.json {
        return output::print_json(&skyloop::lti::json::LtiJson::from_ss(&sys));
    }
    let form = match a.form.as_str() {
        "ss" => None,
        "tf" => Some(Form::Tf),
        "zpk" => Some(Form::Zpk),
        other => {
            return Err(skyloop::Error::Input(format!(
                "--form '{other}' is not one of ss, tf, zpk"
            )))
        }
    };
    println!(
        "{} states, {} outputs, {} inputs, {}",
        sys.nx(),
        sys.ny(),
        sys.nu(),
        if sys.is_continuous() {
            "continuous".to_string()
        } else {
            format!("dt = {} s", sys.dt)
        }
    );
    let listed = |d: &[f64]| d.iter().map(|t| format!("{t}")).collect::<Vec<_>>().join(", ");
    if sys.input_delay.iter().any(|&t| t > 0.0) {
        println!("input delay [s]  = [{}]", listed(&sys.input_delay));
    }
    if sys.output_delay.iter().any(|&t| t > 0.0) {
        println!("output delay [s] = [{}]", listed(&sys.output_delay));
    }
    match form {
        None => {
            for (name, m) in [("A", &sys.a), ("B", &sys.b), ("C", &sys.c), ("D", &sys.d)] {
                println!("{name} =");
                print!("{}", output::matrix_table(m));
            }
        }
        Some(f) => {
            let e = expressions(&sys, f)?;
            for (i, row) in e.iter().enumerate() {
                for (j, text) in row.iter().enumerate() {
                    if sys.ny() == 1 && sys.nu() == 1 {
                        println!("{text}");
                    } else {
                        println!("G[{}][{}] = {text}", i + 1, j + 1);
                    }
                }
            }
        }
    }
    Ok(())
}
