//! `skyloop bode MODEL.. --out FILE [--margins]`: Bode plot of one or more models; with `--margins`
//! the first model is taken as the loop transfer L and its crossover and margins are marked.

use skyloop::plot::bode::{plot_bode, BodeData, BodeMarks};

use super::plot_args::{channel, PlotArgs};

/// Arguments of `skyloop bode`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    plot: PlotArgs,
    /// Treat the first model as a SISO loop transfer L = P·C and mark its crossover and margins.
    #[arg(long)]
    margins: bool,
}

/// Computes every model's Bode data on one grid and writes the plot.
pub fn run(a: Args) -> skyloop::Result<()> {
    let models = a.plot.load()?;
    let w = a.plot.grid(&models)?;
    let mut data = Vec::new();
    for (label, sys) in &models {
        let b = skyloop::lti::freqresp::bode(sys, Some(&w)).map_err(|e| format!("{label}: {e}"))?;
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
    let marks = if a.margins {
        loop_marks(&models[0].0, &models[0].1)?
    } else {
        BodeMarks::default()
    };
    plot_bode(&a.plot.out, &a.plot.title_or("Bode"), &data, &marks)?;
    eprintln!("wrote {}", a.plot.out.display());
    Ok(())
}

/// Crossover, gain margin and phase margin of a SISO loop, in the units the plot uses (Hz, dB, deg).
fn loop_marks(label: &str, l: &skyloop::lti::StateSpace) -> skyloop::Result<BodeMarks> {
    if l.ny() != 1 || l.nu() != 1 {
        return Err(format!("--margins needs a SISO loop transfer, {label} is {}×{}", l.ny(), l.nu()).into());
    }
    let m = skyloop::lti::margins::margin(l).map_err(|e| format!("{label}: {e}"))?;
    let hz = |w: f64| w / (2.0 * std::f64::consts::PI);
    let finite = |v: f64, w: f64| (v.is_finite() && w.is_finite()).then_some((v, hz(w)));
    Ok(BodeMarks {
        crossover_hz: m.pm_w_rad_s.is_finite().then(|| hz(m.pm_w_rad_s)),
        gain_margin: finite(m.gm_db, m.gm_w_rad_s),
        phase_margin: finite(m.pm_deg, m.pm_w_rad_s),
    })
}
