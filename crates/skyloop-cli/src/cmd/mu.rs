//! `skyloop mu MODEL --blocks SPEC [--hz F1,F2,..] [--json]`: structured singular value bounds of a
//! model's frequency response against a block structure.

use crate::{input, output};
use skyloop::robust::mu::{mu_system, robust_stability, MuOptions};
use skyloop::robust::uncertainty::BlockStructure;

/// Arguments of `skyloop mu`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression or path to an LTI JSON file (the M of det(I − MΔ)).
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// Block structure, e.g. `c1x1,c1x1,f2x2,r1,c3r` (cMxN/fMxN full, cNr repeated complex scalar, rN real).
    #[arg(long)]
    blocks: String,
    /// Frequencies in Hz (increasing, comma separated); default: 200 points over the model's dynamics.
    #[arg(long)]
    hz: Option<String>,
    /// Print {"upper":[..],"lower":[..],"freq_hz":[..],"peak":{..}} instead of a table.
    #[arg(long)]
    json: bool,
}

/// The JSON answer.
#[derive(serde::Serialize)]
struct Answer {
    upper: Vec<f64>,
    lower: Vec<f64>,
    freq_hz: Vec<f64>,
    peak: Peak,
}

#[derive(serde::Serialize)]
struct Peak {
    upper: f64,
    lower: f64,
    freq_hz: f64,
    /// Robust stability margin bounds: stable for σ̄(Δ) < margin_lower, a Δ of size margin_upper destabilizes.
    margin_lower: f64,
    margin_upper: Option<f64>,
    margin_freq_hz: f64,
}

/// Computes the bounds and prints them.
pub fn run(a: Args) -> skyloop::Result<()> {
    let blocks = BlockStructure::parse(&a.blocks).map_err(|e| format!("--blocks: {e}"))?;
    let sys = skyloop::model::load_model(&a.model)?;
    let hz = match &a.hz {
        Some(t) => input::parse_list(t, "--hz")?,
        None => skyloop::lti::freqresp::default_grid(&sys, 200)?
            .iter()
            .map(|w| w / std::f64::consts::TAU)
            .collect(),
    };
    let w: Vec<f64> = hz.iter().map(|f| f * std::f64::consts::TAU).collect();
    let sw = mu_system(&sys, &w, &blocks, &MuOptions::default())?;
    let rs = robust_stability(&sw);
    let to_hz = |w: f64| w / std::f64::consts::TAU;
    if a.json {
        return output::print_json(&Answer {
            upper: sw.upper.clone(),
            lower: sw.lower.clone(),
            freq_hz: hz,
            peak: Peak {
                upper: sw.peak.upper,
                lower: sw.peak.lower,
                freq_hz: to_hz(sw.peak.w_rad_s),
                margin_lower: rs.lower,
                margin_upper: rs.upper.is_finite().then_some(rs.upper),
                margin_freq_hz: to_hz(rs.w_rad_s),
            },
        });
    }
    println!("{:>14} {:>12} {:>12}", "freq_hz", "mu_upper", "mu_lower");
    for k in 0..hz.len() {
        println!("{:>14.6} {:>12.6} {:>12.6}", hz[k], sw.upper[k], sw.lower[k]);
    }
    println!(
        "peak mu in [{:.6}, {:.6}] at {:.6} Hz; robust stability margin in [{:.6}, {:.6}]",
        sw.peak.lower,
        sw.peak.upper,
        to_hz(sw.peak.w_rad_s),
        rs.lower,
        rs.upper
    );
    Ok(())
}
