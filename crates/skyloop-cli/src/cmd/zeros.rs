//! `skyloop zeros MODEL`: transmission zeros (system pencil).

/// Arguments of `skyloop zeros`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression or path to an LTI JSON file.
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// Print `{"re":[..],"im":[..]}` instead of a table.
    #[arg(long)]
    json: bool,
}

/// Computes and prints the transmission zeros.
pub fn run(a: Args) -> skyloop::Result<()> {
    let sys = skyloop::model::load_model(&a.model)?;
    let z = skyloop::lti::poles_zeros::zeros(&sys)?;
    super::roots_out::print_roots("zeros", &z, sys.dt, a.json)
}
