//! `skyloop reproduce NAME`: re-derives a paper's printed claims and checks them
//! ([`skyloop::papers`]); prints the account and the claim count.

use std::path::PathBuf;

/// Arguments of `skyloop reproduce`.
#[derive(clap::Args)]
pub struct Args {
    /// Which paper: quadrotor-ssi, ducted-fan, bicopter.
    name: String,
    /// Output directory for CSV traces and plots.
    #[arg(long, default_value = "skyloop-reproduce-out")]
    out: PathBuf,
    /// Coarser frequency grids and fewer iterations (for CI).
    #[arg(long)]
    quick: bool,
}

/// Runs the reproduction and prints its account, ending with the count of claims reproduced.
pub fn run(a: Args) -> skyloop::Result<()> {
    let r = skyloop::papers::reproduce(&a.name, &a.out, a.quick)?;
    for line in r.lines() {
        println!("{line}");
    }
    Ok(())
}
