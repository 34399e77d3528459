//! `skyloop pade MODEL --order N [--json]`: every delay replaced by its order-N Padé approximant
//! (continuous time; a discrete model's delays become shift-register states), as MATLAB's `pade`.

use crate::output;

/// Arguments of `skyloop pade`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression with delays (`exp(-T*s)`) or path to an LTI JSON file.
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// Order of each Padé approximant (1 to 20).
    #[arg(long, default_value_t = 3)]
    order: usize,
    /// Print the rational model's LTI JSON instead of a summary.
    #[arg(long)]
    json: bool,
}

/// Replaces the delays and prints the result.
pub fn run(a: Args) -> skyloop::Result<()> {
    let sys = skyloop::model::load_model(&a.model)?;
    let r = sys
        .try_pade(a.order)
        .map_err(|e| skyloop::Error::Input(format!("--order {}: {e}", a.order)))?;
    if a.json {
        return output::print_json(&skyloop::lti::json::LtiJson::from_ss(&r));
    }
    println!(
        "{} states ({} from the delays), {} outputs, {} inputs",
        r.nx(),
        r.nx() - sys.nx(),
        r.ny(),
        r.nu()
    );
    for row in skyloop::model::expressions(&r, skyloop::model::Form::Zpk)? {
        for text in row {
            println!("{text}");
        }
    }
    Ok(())
}
