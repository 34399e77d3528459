//! `skyloop reduce MODEL --order K --method balanced|spa`: balanced model reduction.

use crate::output;
use skyloop::lti::json::LtiJson;
use skyloop::lti::reduce::{balred, Method};

/// Arguments of `skyloop reduce`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression or path to an LTI JSON file.
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// Number of states of the reduced model (unstable poles are always kept and count here).
    #[arg(long)]
    order: usize,
    /// balanced (truncation, square-root) or spa (singular perturbation, DC gain matched).
    #[arg(long, default_value = "balanced")]
    method: String,
    /// Print {"hankel_singular_values", "error_bound", "model"} as JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Also plot the Hankel singular values (kept and discarded) to this `.svg` or `.png` file.
    #[arg(long)]
    plot: Option<std::path::PathBuf>,
}

#[derive(serde::Serialize)]
struct ReduceJson {
    hankel_singular_values: Vec<f64>,
    error_bound: f64,
    n_unstable: usize,
    model: LtiJson,
}

/// Reduces the model and prints the Hankel singular values, the error bound and the reduced model.
pub fn run(a: Args) -> skyloop::Result<()> {
    let method: Method = a.method.parse().map_err(|e| format!("--method: {e}"))?;
    let sys = skyloop::model::load_model(&a.model)?;
    let red = balred(&sys, a.order, method)?;
    if let Some(path) = &a.plot {
        let kept = a.order.saturating_sub(red.n_unstable);
        let title = format!("Hankel singular values (stable part, {} unstable kept)", red.n_unstable);
        skyloop::plot::hsv::plot_hsv(path, &title, &red.hsv, Some(kept))?;
        eprintln!("wrote {}", path.display());
    }
    if a.json {
        return output::print_json(&ReduceJson {
            hankel_singular_values: red.hsv.clone(),
            error_bound: red.error_bound,
            n_unstable: red.n_unstable,
            model: LtiJson::from_ss(&red.sys),
        });
    }
    println!(
        "{} -> {} states ({} unstable kept), method {:?}",
        sys.nx(),
        red.sys.nx(),
        red.n_unstable,
        method
    );
    println!("Hankel singular values of the stable part:");
    for (i, s) in red.hsv.iter().enumerate() {
        println!("  {:>3}  {:.6e}", i + 1, s);
    }
    println!("error bound (2 x sum of discarded): {:.6e}", red.error_bound);
    for (name, m) in [
        ("A", &red.sys.a),
        ("B", &red.sys.b),
        ("C", &red.sys.c),
        ("D", &red.sys.d),
    ] {
        println!("{name} =");
        print!("{}", output::matrix_table(m));
    }
    Ok(())
}
