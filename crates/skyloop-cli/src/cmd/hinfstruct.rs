//! `skyloop hinfstruct PLANT --nmeas NY --ncon NU --order K`: fixed-order H∞ synthesis by
//! nonsmooth optimization (MATLAB conventions, as hinfsyn).

use crate::output::{matrix_table, print_json};
use clap::Args as ClapArgs;
use skyloop::lti::json::LtiJson;
use skyloop::model::load_model;
use skyloop::robust::structured::hinfstruct::{hinfstruct, HinfstructOptions};

/// Arguments of `skyloop hinfstruct`.
#[derive(ClapArgs)]
pub struct Args {
    /// Generalized plant P (LTI JSON file or expression); last NY outputs are measurements, last NU inputs controls.
    #[arg(allow_hyphen_values = true)]
    pub plant: String,
    /// Number of measured outputs y (the last ones of P).
    #[arg(long)]
    pub nmeas: usize,
    /// Number of control inputs u (the last ones of P).
    #[arg(long)]
    pub ncon: usize,
    /// Controller order (number of states), 0..=50; the plant's order gives hinfsyn's full-order problem.
    #[arg(long)]
    pub order: usize,
    /// Number of starts (run in parallel), 1..=1000.
    #[arg(long, default_value_t = 8)]
    pub starts: usize,
    /// Seed of the random starts.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print {"gamma":..,"controller":LTI JSON} on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs the synthesis and prints γ and the controller u = K·y.
pub fn run(a: Args) -> skyloop::Result<()> {
    let p = load_model(&a.plant)?;
    let opts = HinfstructOptions {
        starts: a.starts,
        seed: a.seed,
        ..Default::default()
    };
    let sol = hinfstruct(&p, a.nmeas, a.ncon, a.order, &opts)?;
    // H∞ optimality allows an unstable controller (the closed loop is stable); flying one is risky:
    // whenever the loop opens (arming, saturation, a sensor fault) it diverges on its own.
    let unstable: Vec<String> = skyloop::lti::poles_zeros::poles(&sol.controller)?
        .iter()
        .filter(|z| !skyloop::lti::stabsep::is_stable_pole(**z, sol.controller.dt))
        .map(|z| format!("{:.4}{:+.4}j", z.re, z.im))
        .collect();
    let warnings: Vec<String> = if unstable.is_empty() {
        Vec::new()
    } else {
        vec![format!(
            "the controller itself is unstable (poles {}): the closed loop is stable, but whenever the loop opens (arming, actuator saturation) the controller diverges; more --starts or another --order may find a stable one, unless the plant needs an unstable controller (an odd number of real unstable poles between two real right-half-plane zeros or beyond)",
            unstable.join(", ")
        )]
    };
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    if a.json {
        return print_json(&serde_json::json!({
            "gamma": sol.gamma,
            "controller": LtiJson::from_ss(&sol.controller),
            "stabilized_starts": sol.stabilized_starts,
            "starts_run": sol.starts_run,
            "added_starts": sol.added_starts,
            "warnings": warnings,
        }));
    }
    println!(
        "gamma {:.6}  (closed loop re-verified; {} of {} starts stabilized: the {} requested{})",
        sol.gamma,
        sol.stabilized_starts,
        sol.starts_run,
        a.starts,
        if sol.added_starts > 0 {
            format!(" and {} from central H-inf controllers", sol.added_starts)
        } else {
            String::new()
        }
    );
    let k = &sol.controller;
    for (name, m) in [("A", &k.a), ("B", &k.b), ("C", &k.c), ("D", &k.d)] {
        println!("{name} =\n{}", matrix_table(m));
    }
    Ok(())
}
