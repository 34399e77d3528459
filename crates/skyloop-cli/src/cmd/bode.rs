//! `skyloop bode MODEL.. --out FILE [--margins]`: Bode plot of one or more models (MIMO models as
//! an input–output grid); with `--margins` the first model is the loop transfer L and its
//! crossover and margins are marked.

use super::plot_args::PlotArgs;

/// Arguments of `skyloop bode`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    plot: PlotArgs,
    /// Treat the first model as a SISO loop transfer L = P·C and mark its crossover and margins.
    #[arg(long)]
    margins: bool,
}

/// Builds the Bode figure and writes it.
pub fn run(a: Args) -> skyloop::Result<()> {
    let (models, w) = a.plot.load()?;
    a.plot.save(skyloop::figures::bode(&models, &w, a.margins)?)
}
