//! `skyloop noise LOG [--axis roll] [--filters SPEC] [--out DIR] [--json]`: the noise picture of a
//! flight (thin: parse, call skyloop::noise, print).

use crate::cmd::tune::spinner;
use crate::output::print_json;
use clap::Args as ClapArgs;
use skyloop::firmware::Axis;
use skyloop::noise::{analyze, NoiseRequest};

/// Arguments of `skyloop noise`.
#[derive(ClapArgs)]
pub struct Args {
    /// A flight log (Betaflight or INAV blackbox, PX4 ULog).
    pub log: std::path::PathBuf,
    /// roll, pitch or yaw (default: all three).
    #[arg(long)]
    pub axis: Option<String>,
    /// Blackbox session (counted from 1); default: the longest.
    #[arg(long)]
    pub session: Option<usize>,
    /// A changed filter chain applied to the logged signals, e.g. "gyro_lpf1=pt1:150,dterm_lpf1=pt2:90,dyn_notch=2x:150-600" (stages: rpm, dyn_notch, gyro_notch1, gyro_notch2, gyro_lpf1, gyro_lpf2, dterm_notch, dterm_lpf1, dterm_lpf2; values: pt1|pt2|pt3|biquad:HZ or :MIN-MAX, notch:CENTER/CUTOFF, Nx:MIN-MAX[@qQ], Nh[@qQ], off).
    #[arg(long)]
    pub filters: Option<String>,
    /// Write noise.json, noise.txt, the figures (PNG) and report.html here.
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
    /// Print the JSON (per axis: spectra, peaks, gyro_chain, spectrograms).
    #[arg(long)]
    pub json: bool,
}

fn show(stage: &str) {
    match spinner() {
        Some(b) => b.set_message(format!("noise: {stage}")),
        None => eprintln!("[noise] {stage} …"),
    }
}

/// Runs the analysis and prints it.
pub fn run(a: Args) -> skyloop::Result<()> {
    let axes = match &a.axis {
        Some(x) => vec![Axis::parse(x)?],
        None => Vec::new(),
    };
    let req = NoiseRequest {
        path: &a.log,
        session: a.session,
        axes,
        filters: a.filters.as_deref(),
        progress: Some(show),
    };
    let out = analyze(&req);
    if let Some(b) = spinner() {
        b.finish_and_clear();
    }
    let out = out?;
    if let Some(dir) = &a.out {
        skyloop::noise::figures::write_outputs(&out, dir)?;
        eprintln!("wrote {}", dir.display());
    }
    if a.json {
        return print_json(&out.to_json());
    }
    print!("{}", out.to_text());
    Ok(())
}
