//! `skyloop sigma MODEL.. --out FILE`: singular values of the frequency response (MATLAB `sigma`).

use super::plot_args::PlotArgs;

/// Arguments of `skyloop sigma`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    plot: PlotArgs,
}

/// Builds the singular-value figure and writes it.
pub fn run(a: Args) -> skyloop::Result<()> {
    let (models, w) = a.plot.load()?;
    a.plot.save(skyloop::figures::sigma(&models, &w)?)
}
