//! `skyloop reproduce NAME`: re-derives a paper's printed claims and checks them. One line per paper in
//! `run`; each paper's code lives in `reproduce/<name>.rs`.

mod bicopter;
mod quadrotor_ssi;

use std::path::PathBuf;

/// Arguments of `skyloop reproduce`.
#[derive(clap::Args)]
pub struct Args {
    /// Which paper: quadrotor-ssi, bicopter.
    name: String,
    /// Output directory for CSV traces and plots.
    #[arg(long, default_value = "skyloop-reproduce-out")]
    out: PathBuf,
}

/// Dispatches on the paper name.
pub fn run(a: Args) -> Result<(), String> {
    match a.name.as_str() {
        "quadrotor-ssi" => quadrotor_ssi::run(&a.out),
        "bicopter" => bicopter::run(&a.out),
        other => Err(format!(
            "unknown reproduction '{other}' (known: quadrotor-ssi, bicopter)"
        )),
    }
}
