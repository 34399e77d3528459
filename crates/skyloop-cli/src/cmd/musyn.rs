//! `skyloop musyn SPEC.toml [--json] [--out DIR]`: μ-synthesis by DK-iteration of the spec
//! ([`skyloop::spec::musyn`]; e.g. `examples/musyn-distillation.toml`).

use crate::output::print_json;
use clap::Args as ClapArgs;
use skyloop::spec::musyn::MusynSpec;
use skyloop::synthesis::{musyn_from_spec, musyn_summary, write_musyn_outputs};
use std::path::PathBuf;

/// Arguments of `skyloop musyn`.
#[derive(ClapArgs)]
pub struct Args {
    /// The synthesis spec (TOML): plant, blocks, nmeas, ncon, [options].
    pub spec: PathBuf,
    /// Print {"mu_peak":..,"iterations":[..],"controller":LTI JSON,..} on stdout instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Directory for controller.json (the best controller, LTI JSON) and musyn.json (the summary).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs the DK-iteration and reports it.
pub fn run(a: Args) -> skyloop::Result<()> {
    let spec = MusynSpec::from_file(&a.spec)?;
    let sol = musyn_from_spec(&spec)?;
    if let Some(dir) = &a.out {
        write_musyn_outputs(&sol, dir)?;
    }
    if a.json {
        return print_json(&musyn_summary(&sol, true));
    }
    if let Some(n) = &spec.name {
        println!("{n}");
    }
    println!(
        "{:>4} {:>10} {:>10} {:>10} {:>12} {:>10} {:>8} {:>8}",
        "iter", "gamma", "mu_peak", "mu_lower", "peak_rad_s", "mu_rs", "K_order", "P_order"
    );
    for (k, it) in sol.iterations.iter().enumerate() {
        println!(
            "{:>4} {:>10.5} {:>10.5} {:>10.5} {:>12.5} {:>10.5} {:>8} {:>8}{}",
            k + 1,
            it.gamma,
            it.mu_peak,
            it.mu_lower_peak,
            it.mu_peak_w_rad_s,
            it.mu_rs_peak,
            it.controller_order,
            it.scaled_plant_order,
            if k == sol.best { "  <- best" } else { "" }
        );
    }
    println!("stopped: {}", sol.stop_reason);
    println!(
        "best: iteration {}, peak mu {:.5}, controller with {} states{}",
        sol.best + 1,
        sol.mu_peak,
        sol.controller.nx(),
        a.out
            .as_ref()
            .map(|d| format!(" written to {}", d.join("controller.json").display()))
            .unwrap_or_default()
    );
    Ok(())
}
