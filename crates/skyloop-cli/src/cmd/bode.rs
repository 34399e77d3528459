//! `skyloop bode MODEL.. --out FILE`: Bode plot of one or more models; a single SISO model has its
//! margins marked as a loop transfer L.

use skyloop_plot::bode::{plot_bode, BodeData, BodeMarks};

use super::plot_args::{channel, PlotArgs};

/// Arguments of `skyloop bode`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    plot: PlotArgs,
}

/// Computes every model's Bode data on one grid and writes the plot.
pub fn run(a: Args) -> Result<(), String> {
    let models = a.plot.load()?;
    let w = a.plot.grid(&models)?;
    let mut data = Vec::new();
    for (label, sys) in &models {
        let b = skyloop_lti::freqresp::bode(sys, Some(&w)).map_err(|e| format!("{label}: {e}"))?;
        for i in 0..sys.ny() {
            for j in 0..sys.nu() {
                data.push(BodeData {
                    label: format!("{label}{}", channel(sys, i, j)),
                    freq_hz: b.freq_hz.clone(),
                    mag_db: b.mag_db[i][j].clone(),
                    phase_deg: b.phase_deg[i][j].clone(),
                });
            }
        }
    }
    let marks = BodeMarks::default();
    plot_bode(&a.plot.out, &a.plot.title_or("Bode"), &data, &marks).map_err(|e| e.to_string())?;
    eprintln!("wrote {}", a.plot.out.display());
    Ok(())
}
