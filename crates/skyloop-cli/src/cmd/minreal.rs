//! `skyloop minreal MODEL`: removes uncontrollable and unobservable states.

use crate::output;
use skyloop::lti::json::LtiJson;
use skyloop::lti::minreal::minreal;

/// Arguments of `skyloop minreal`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression or path to an LTI JSON file.
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// Relative rank tolerance of the staircase reduction (default √ε, as MATLAB).
    #[arg(long)]
    tol: Option<f64>,
    /// Print the minimal model as LTI JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// Computes the minimal realization and prints it.
pub fn run(a: Args) -> skyloop::Result<()> {
    let sys = skyloop::model::load_model(&a.model)?;
    let m = minreal(&sys, a.tol)?;
    if a.json {
        return output::print_json(&LtiJson::from_ss(&m));
    }
    println!("{} -> {} states", sys.nx(), m.nx());
    for (name, x) in [("A", &m.a), ("B", &m.b), ("C", &m.c), ("D", &m.d)] {
        println!("{name} =");
        print!("{}", output::matrix_table(x));
    }
    Ok(())
}
