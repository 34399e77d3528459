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
    let sys = skyloop::model::load_model(&a.model)?;
    let freq_hz = match &a.hz {
        Some(t) => {
            let f = input::parse_list(t, "--hz")?;
            if let Some(x) = f.iter().find(|&&x| x < 0.0) {
                return Err(format!("--hz: frequencies must be >= 0, got {x}").into());
            }
            f
        }
        None if a.logspace_hz.is_some() => {
            let p = input::parse_list(a.logspace_hz.as_deref().unwrap_or_default(), "--logspace-hz")?;
            let ok = p.len() == 3 && p[0] > 0.0 && p[1] > p[0] && p[2] >= 2.0 && p[2].fract() == 0.0;
            if !ok {
                return Err("--logspace-hz needs LO,HI,N with 0 < LO < HI and an integer N >= 2".into());
            }
            // A million points already takes seconds to print; beyond it is a typo, not a plot.
            const MAX_POINTS: f64 = 1e6;
            if p[2] > MAX_POINTS {
                return Err(format!("--logspace-hz: N = {} exceeds the limit of {MAX_POINTS:e} points", p[2]).into());
            }
            skyloop::lti::freqresp::try_logspace(p[0].log10(), p[1].log10(), p[2] as usize)?
        }
        None => skyloop::lti::freqresp::default_grid(&sys, 50)?
            .into_iter()
            .map(|w| w / (2.0 * PI))
            .collect(),
    };
    let w: Vec<f64> = freq_hz.iter().map(|f| 2.0 * PI * f).collect();
    if let Some(n) = a.bench {
        let mut best = f64::INFINITY;
        for _ in 0..n.max(1) {
            let t = std::time::Instant::now();
            let g = skyloop::lti::freqresp::freqresp(&sys, &w)?;
            best = best.min(t.elapsed().as_secs_f64());
            std::hint::black_box(g);
        }
        eprintln!("bench_seconds {best:e}");
    }
    let g = skyloop::lti::freqresp::freqresp(&sys, &w)?;
    if a.json {
        return output::print_json(&Response {
            freq_hz: &freq_hz,
            re: Part { g: &g, f: |z| z.re },
            im: Part { g: &g, f: |z| z.im },
        });
    }
    println!(
        "{:>14} {:>8} {:>14} {:>14} {:>12} {:>12}",
        "freq_hz", "channel", "re", "im", "mag_db", "phase_deg"
    );
    for (k, m) in g.iter().enumerate() {
        for i in 0..m.nrows() {
            for j in 0..m.ncols() {
                let z = m[(i, j)];
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

/// The JSON of a response, serialized from the matrices as they are (no nested copies).
#[derive(serde::Serialize)]
struct Response<'a> {
    freq_hz: &'a [f64],
    re: Part<'a>,
    im: Part<'a>,
}

/// One part (real or imaginary) of every response matrix, as `[frequency][output][input]`.
struct Part<'a> {
    g: &'a [skyloop::lti::Mat<skyloop::lti::c64>],
    f: fn(&skyloop::lti::c64) -> f64,
}

impl serde::Serialize for Part<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeSeq;
        let mut freqs = s.serialize_seq(Some(self.g.len()))?;
        for m in self.g {
            let rows: Vec<Vec<f64>> = (0..m.nrows())
                .map(|i| (0..m.ncols()).map(|j| (self.f)(&m[(i, j)])).collect())
                .collect();
            freqs.serialize_element(&rows)?;
        }
        freqs.end()
    }
}
