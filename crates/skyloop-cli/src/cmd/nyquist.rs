//! `skyloop nyquist MODEL.. --out FILE`: Nyquist plot of SISO loop transfers.

use skyloop::plot::nyquist::{plot_nyquist, NyquistData};

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

/// Computes each loop's response on one grid and writes the plot.
pub fn run(a: Args) -> skyloop::Result<()> {
    if !(a.radius > 0.0 && a.radius.is_finite()) {
        return Err(format!("--radius must be positive, got {}", a.radius).into());
    }
    let models = a.plot.load()?;
    let w = a.plot.grid(&models)?;
    let mut data = Vec::new();
    for (label, sys) in &models {
        if sys.ny() != 1 || sys.nu() != 1 {
            return Err(format!(
                "{label}: a Nyquist plot needs a SISO loop, got {}×{}",
                sys.ny(),
                sys.nu()
            )
            .into());
        }
        let g = skyloop::lti::freqresp::freqresp(sys, &w).map_err(|e| format!("{label}: {e}"))?;
        data.push(NyquistData {
            label: label.clone(),
            re: g.iter().map(|m| m[(0, 0)].re).collect(),
            im: g.iter().map(|m| m[(0, 0)].im).collect(),
        });
    }
    plot_nyquist(&a.plot.out, &a.plot.title_or("Nyquist"), &data, Some(a.radius))?;
    eprintln!("wrote {}", a.plot.out.display());
    Ok(())
}
