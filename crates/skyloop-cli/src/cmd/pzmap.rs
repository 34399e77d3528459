//! `skyloop pzmap MODEL.. --out FILE`: pole–zero map; `skyloop rlocus L --out FILE`: root locus of a
//! SISO loop under a swept gain.

use super::plot_args::{save, ModelArgs};

/// Arguments of `skyloop pzmap`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    models: ModelArgs,
    /// Output file; `.svg`, `.png` or `.html`.
    #[arg(long)]
    out: std::path::PathBuf,
    /// Plot title.
    #[arg(long)]
    title: Option<String>,
}

/// Builds the pole–zero map and writes it.
pub fn run(a: Args) -> skyloop::Result<()> {
    let models = a.models.load()?;
    if models.iter().any(|m| m.sys.has_delay()) {
        eprintln!("note: delays do not move poles or zeros; they are not drawn");
    }
    save(skyloop::figures::pzmap(&models)?, a.title.as_deref(), &a.out)
}

/// Arguments of `skyloop rlocus`.
#[derive(clap::Args)]
pub struct RlocusArgs {
    /// The SISO loop transfer L (rational: apply `skyloop pade` to a delayed loop first).
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// Output file; `.svg`, `.png` or `.html`.
    #[arg(long)]
    out: std::path::PathBuf,
    /// Gain range MIN,MAX of the sweep (default: six decades either side of the gain giving |L| = 1
    /// mid-band).
    #[arg(long, value_delimiter = ',', num_args = 2)]
    gains: Option<Vec<f64>>,
    /// Legend name of the loop.
    #[arg(long)]
    label: Option<String>,
    /// Plot title.
    #[arg(long)]
    title: Option<String>,
}

/// Sweeps the gain, builds the root locus and writes it.
pub fn run_rlocus(a: RlocusArgs) -> skyloop::Result<()> {
    let label = a
        .label
        .clone()
        .unwrap_or_else(|| skyloop::figures::short_label(&a.model));
    let l = skyloop::figures::Labeled::new(label, skyloop::model::load_model(&a.model)?);
    let gains = a.gains.as_ref().map(|g| (g[0], g[1]));
    save(skyloop::figures::rlocus(&l, gains)?, a.title.as_deref(), &a.out)
}
