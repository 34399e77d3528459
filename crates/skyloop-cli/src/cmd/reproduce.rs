//! `skyloop reproduce NAME`: re-derives a paper's printed claims and checks them. One line per paper in
//! `run`; each paper's code lives in `reproduce/<name>.rs`.

mod bicopter;
mod ducted_fan;
mod quadrotor_ssi;

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

/// Dispatches on the paper name.
pub fn run(a: Args) -> Result<(), String> {
    match a.name.as_str() {
        "quadrotor-ssi" => quadrotor_ssi::run(&a.out),
        "ducted-fan" => ducted_fan::run(&a.out, a.quick),
        "bicopter" => bicopter::run(&a.out),
        other => Err(format!(
            "unknown reproduction '{other}' (known: quadrotor-ssi, ducted-fan, bicopter)"
        )),
    }
}

/// Printed paper claims, each marked ok or FAIL as it is checked; the run fails if any claim failed.
#[derive(Default)]
pub(crate) struct Claims {
    failed: Vec<String>,
}

impl Claims {
    /// Prints the claim with its verdict and remembers it if it failed.
    pub(crate) fn check(&mut self, ok: bool, what: String) {
        println!("  [{}] {what}", if ok { "ok" } else { "FAIL" });
        if !ok {
            self.failed.push(what);
        }
    }

    /// Ok when every claim held, else an error listing the failed ones.
    pub(crate) fn finish(self) -> Result<(), String> {
        if self.failed.is_empty() {
            println!("all claims reproduced");
            Ok(())
        } else {
            Err(format!(
                "{} claim(s) not reproduced: {}",
                self.failed.len(),
                self.failed.join("; ")
            ))
        }
    }
}
