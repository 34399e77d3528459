//! `skyloop poles MODEL`: eigenvalues of A.

use crate::input;

/// Arguments of `skyloop poles`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression or path to an LTI JSON file.
    model: String,
    /// Print `{"re":[..],"im":[..]}` instead of a table.
    #[arg(long)]
    json: bool,
}

/// Computes and prints the poles.
pub fn run(a: Args) -> Result<(), String> {
    let sys = input::load_model(&a.model)?;
    let p = skyloop_lti::analysis::poles(&sys).map_err(|e| e.to_string())?;
    super::roots_out::print_roots("poles", &p, sys.dt, a.json)
}
