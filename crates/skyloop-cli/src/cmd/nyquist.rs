//! `skyloop nyquist MODEL.. --out FILE`: Nyquist plot of SISO loop transfers.

use super::plot_args::PlotArgs;

/// Arguments of `skyloop nyquist`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    plot: PlotArgs,
    /// Show only |z| ≤ RADIUS around the origin (curves of loops with integrators run off to infinity).
    #[arg(long, default_value_t = 3.0)]
    radius: f64,
}

/// Builds the Nyquist figure and writes it.
pub fn run(a: Args) -> skyloop::Result<()> {
    let (models, w) = a.plot.load()?;
    a.plot.save(skyloop::figures::nyquist(&models, &w, Some(a.radius))?)
}
