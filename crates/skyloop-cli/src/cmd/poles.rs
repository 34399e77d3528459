//! `skyloop poles MODEL`: eigenvalues of A.

/// Arguments of `skyloop poles`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression or path to an LTI JSON file.
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// Print `{"re":[..],"im":[..]}` instead of a table.
    #[arg(long)]
    json: bool,
}

/// Computes and prints the poles.
pub fn run(a: Args) -> skyloop::Result<()> {
    let sys = skyloop::model::load_model(&a.model)?;
    let p = skyloop::lti::poles_zeros::poles(&sys)?;
    super::roots_out::print_roots("poles", &p, sys.dt, a.json)
}
