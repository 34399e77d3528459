//! `skyloop freqresp MODEL --hz 0.1,1,10 [--json]`: complex frequency response, exact with delays.

use crate::{input, output};
use std::f64::consts::PI;

/// Arguments of `skyloop freqresp`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression or path to an LTI JSON file.
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// Comma-separated frequencies in Hz (default: 50 log-spaced points over the model's dynamics).
    #[arg(long)]
    hz: Option<String>,
    /// Log-spaced grid `LO,HI,N`: N frequencies from LO to HI Hz (instead of --hz).
    #[arg(long, conflicts_with = "hz")]
    logspace_hz: Option<String>,
    /// Print `{"freq_hz":[..],"re":[[[..]]],"im":[[[..]]]}` indexed [frequency][output][input].
    #[arg(long)]
    json: bool,
    /// Repeat the computation N times and print the fastest wall time on stderr (for bench/compare.py).
    #[arg(long, value_name = "N")]
    bench: Option<usize>,
}

/// Evaluates the model at the requested frequencies and prints them.
pub fn run(a: Args) -> skyloop::Result<()> {
    use skyloop::response;
    let sys = skyloop::model::load_model(&a.model)?;
    let freq_hz = match (&a.hz, &a.logspace_hz) {
        (Some(t), _) => {
            let f = input::parse_list(t, "--hz")?;
            response::check_frequencies_hz(&f, "--hz")?;
            f
        }
        (None, Some(t)) => response::parse_logspace_hz(&input::parse_list(t, "--logspace-hz")?, "--logspace-hz")?,
        (None, None) => response::default_grid_hz(&sys, 50)?,
    };
    let w: Vec<f64> = freq_hz.iter().map(|f| 2.0 * PI * f).collect();
    output::bench(a.bench, || skyloop::lti::freqresp::freqresp_flat(&sys, &w))?;
    let g = skyloop::lti::freqresp::freqresp_flat(&sys, &w)?;
    let (ny, nu) = (sys.ny(), sys.nu());
    if a.json {
        return output::print_json(&response::ResponseJson::new(&freq_hz, &g, ny, nu));
    }
    println!(
        "{:>14} {:>8} {:>14} {:>14} {:>12} {:>12}",
        "freq_hz", "channel", "re", "im", "mag_db", "phase_deg"
    );
    for (k, m) in g.chunks_exact((ny * nu).max(1)).enumerate() {
        for i in 0..ny {
            for j in 0..nu {
                let z = m[i * nu + j];
                println!(
                    "{:>14.6e} {:>8} {:>14.6e} {:>14.6e} {:>12.4} {:>12.4}",
                    freq_hz[k],
                    format!("{}<-{}", i + 1, j + 1),
                    z.re,
                    z.im,
                    20.0 * z.norm().log10(),
                    z.arg().to_degrees()
                );
            }
        }
    }
    Ok(())
}
