//! `skyloop zeros MODEL`: transmission zeros (system pencil).

use crate::input;

/// Arguments of `skyloop zeros`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression or path to an LTI JSON file.
    model: String,
    /// Print `{"re":[..],"im":[..]}` instead of a table.
    #[arg(long)]
    json: bool,
}

/// Computes and prints the transmission zeros.
pub fn run(a: Args) -> Result<(), String> {
    let sys = input::load_model(&a.model)?;
    let z = skyloop_lti::analysis::zeros(&sys).map_err(|e| e.to_string())?;
    super::roots_out::print_roots("zeros", &z, sys.dt, a.json)
}
