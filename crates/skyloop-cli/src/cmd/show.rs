//! `skyloop show MODEL`: what a model is, as a table or LTI JSON.

use crate::output;

/// Arguments of `skyloop show`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression or path to an LTI JSON file.
    model: String,
    /// Print LTI JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// Loads the model and prints it.
pub fn run(a: Args) -> skyloop::Result<()> {
    let sys = skyloop::model::load_model(&a.model)?;
    if a.json {
        output::print_json(&skyloop::lti::json::LtiJson::from_ss(&sys))
    } else {
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
        for (name, m) in [("A", &sys.a), ("B", &sys.b), ("C", &sys.c), ("D", &sys.d)] {
            println!("{name} =");
            print!("{}", output::matrix_table(m));
        }
        Ok(())
    }
}
