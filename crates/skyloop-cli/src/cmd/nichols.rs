//! `skyloop nichols MODEL.. --out FILE`: Nichols chart of SISO loop transfers with M-circles.

use super::plot_args::PlotArgs;

/// Arguments of `skyloop nichols`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    plot: PlotArgs,
}

/// Builds the Nichols chart and writes it.
pub fn run(a: Args) -> skyloop::Result<()> {
    let (models, w) = a.plot.load()?;
    a.plot.save(skyloop::figures::nichols(&models, &w)?)
}
