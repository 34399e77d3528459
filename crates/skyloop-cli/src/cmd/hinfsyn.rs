//! `skyloop hinfsyn PLANT --nmeas NY --ncon NU`: H∞ output-feedback synthesis (MATLAB conventions).

use crate::output::{matrix_table, print_json};
use clap::Args as ClapArgs;
use skyloop::lti::json::LtiJson;
use skyloop::model::load_model;
use skyloop::robust::hinfsyn::{hinfsyn_with, HinfOptions};
use skyloop::synthesis::diagnose::{explain, Synthesis};

/// Arguments of `skyloop hinfsyn`.
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
    /// Lower end of the γ search range.
    #[arg(long, default_value_t = 0.0)]
    pub gamma_min: f64,
    /// Upper end of the γ search range (default: found by doubling).
    #[arg(long)]
    pub gamma_max: Option<f64>,
    /// Relative tolerance of the γ bisection.
    #[arg(long, default_value_t = 1e-4)]
    pub tol: f64,
    /// Print {"gamma":..,"closed_loop_norm":..,"controller":LTI JSON} on stdout.
    #[arg(long)]
    pub json: bool,
    /// Write the controller K (u = K·y) as LTI JSON to this file.
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
    /// Repeat the synthesis N times and print the fastest wall time on stderr (for bench/compare.py).
    #[arg(long)]
    pub bench: Option<usize>,
}

/// Runs the synthesis and prints γ and the controller u = K·y.
pub fn run(a: Args) -> skyloop::Result<()> {
    let p = load_model(&a.plant)?;
    let opts = HinfOptions {
        gamma_range: (a.gamma_min, a.gamma_max.unwrap_or(f64::INFINITY)),
        rel_tol: a.tol,
    };
    let synthesize = || {
        hinfsyn_with(&p, a.nmeas, a.ncon, &opts).map_err(|e| {
            explain(
                "hinfsyn",
                &e,
                &[("the generalized plant P", &p)],
                Synthesis::Generalized,
            )
        })
    };
    crate::output::bench(a.bench, synthesize)?;
    let sol = synthesize()?;
    if let Some(path) = &a.out {
        std::fs::write(path, skyloop::lti::json::to_json_string(&sol.controller))
            .map_err(|e| skyloop::Error::write(path, e))?;
        eprintln!("wrote {}", path.display());
    }
    if a.json {
        return print_json(&serde_json::json!({
            "gamma": sol.gamma,
            "gamma_lower": sol.gamma_lower,
            "closed_loop_norm": sol.closed_loop_norm,
            "controller": LtiJson::from_ss(&sol.controller),
        }));
    }
    println!("gamma            {:.6}", sol.gamma);
    println!("closed-loop norm {:.6}", sol.closed_loop_norm);
    let k = &sol.controller;
    println!(
        "controller u = K*y: {} states, {} outputs, {} inputs",
        k.nx(),
        k.ny(),
        k.nu()
    );
    for (name, m) in [("A", &k.a), ("B", &k.b), ("C", &k.c), ("D", &k.d)] {
        println!("{name} =\n{}", matrix_table(m));
    }
    Ok(())
}
