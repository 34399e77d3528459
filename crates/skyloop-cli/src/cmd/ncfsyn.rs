//! `skyloop ncfsyn P [--w1 W1] [--w2 W2] [--out C.json]`: Glover–McFarlane H∞ loop shaping (the plant
//! may also be given as `--plant P`).

use crate::output::print_json;
use clap::Args as ClapArgs;
use skyloop::model::load_model;
use skyloop::robust::ncfsyn::{ncfsyn, NcfOptions};

/// Arguments of `skyloop ncfsyn`.
#[derive(ClapArgs)]
pub struct Args {
    /// Plant P (LTI JSON file or expression such as "0.09*exp(-0.03*s)/(s*(0.03*s+1))").
    #[arg(
        allow_hyphen_values = true,
        required_unless_present = "plant",
        conflicts_with = "plant"
    )]
    pub model: Option<String>,
    /// The plant, as a flag (same as the positional MODEL).
    #[arg(long)]
    pub plant: Option<String>,
    /// Input-side weight W1 (shaped plant W2·P·W1).
    #[arg(long)]
    pub w1: Option<String>,
    /// Output-side weight W2.
    #[arg(long)]
    pub w2: Option<String>,
    /// Order of the Padé approximants replacing delays.
    #[arg(long, default_value_t = 3)]
    pub pade: usize,
    /// Controller built for γ = factor·γ_min (> 1).
    #[arg(long, default_value_t = 1.1)]
    pub factor: f64,
    /// Print {"gamma_min":..,"gamma":..,"controller":LTI JSON} on stdout.
    #[arg(long)]
    pub json: bool,
    /// Write the controller C (u = C·(r − y)) as LTI JSON to this file.
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
}

/// Runs the loop-shaping design; the controller is C = −W1·K∞·W2 for u = C·(r − y).
pub fn run(a: Args) -> skyloop::Result<()> {
    let plant = a.model.as_deref().or(a.plant.as_deref()).unwrap_or_default();
    let p = load_model(plant)?;
    let w1 = a.w1.as_deref().map(load_model).transpose()?;
    let w2 = a.w2.as_deref().map(load_model).transpose()?;
    let opts = NcfOptions {
        factor: a.factor,
        pade_order: a.pade,
    };
    let sol = ncfsyn(&p, w1.as_ref(), w2.as_ref(), &opts).map_err(|e| why_not(&e, &p, w1.as_ref(), w2.as_ref()))?;
    if let Some(path) = &a.out {
        std::fs::write(path, skyloop::lti::json::to_json_string(&sol.controller))
            .map_err(|e| skyloop::Error::write(path, e))?;
        eprintln!("wrote {}", path.display());
    }
    if a.json {
        return print_json(&skyloop::json_out::ncfsyn_json(&sol));
    }
    println!(
        "gamma_min {:.6}  (NCF margin 1/gamma_min = {:.4})",
        sol.gamma_min,
        1.0 / sol.gamma_min
    );
    println!("gamma     {:.6}  (achieved 4-block norm of the shaped loop)", sol.gamma);
    println!(
        "controller C = -W1*Kinf*W2 for u = C(r - y): {} states",
        sol.controller.nx()
    );
    Ok(())
}

/// The failure said about the models: the shaped plant W2·P·W1 first (delays left out), then P and
/// each weight.
fn why_not(
    e: &skyloop::robust::RobustError,
    p: &skyloop::lti::StateSpace,
    w1: Option<&skyloop::lti::StateSpace>,
    w2: Option<&skyloop::lti::StateSpace>,
) -> String {
    use skyloop::lti::interconnect::series;
    use skyloop::synthesis::diagnose::{explain, Synthesis};
    let mut rational = p.clone();
    rational.input_delay.iter_mut().for_each(|d| *d = 0.0);
    rational.output_delay.iter_mut().for_each(|d| *d = 0.0);
    let shaped = w1
        .map_or(Ok(rational.clone()), |w| series(w, &rational))
        .and_then(|g| w2.map_or(Ok(g.clone()), |w| series(&g, w)));
    let mut models: Vec<(&str, &skyloop::lti::StateSpace)> = vec![("the plant P", p)];
    if let Some(w) = w1 {
        models.push(("the weight W1", w));
    }
    if let Some(w) = w2 {
        models.push(("the weight W2", w));
    }
    if let Ok(g) = &shaped {
        models.insert(0, ("the shaped plant W2·P·W1", g));
    }
    explain("ncfsyn", e, &models, Synthesis::LoopShaping)
}
