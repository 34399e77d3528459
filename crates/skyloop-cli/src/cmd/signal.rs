//! `skyloop signal chirp|prbs|multisine [options] --rate HZ --out FILE.csv`: excitation signals as
//! CSV (`time_s,value`).

use std::path::PathBuf;

use skyloop::sysid::signal::{self, ChirpSpec, MultisineSpec, PrbsSpec, Signal, Sweep};

/// Arguments of `skyloop signal`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    kind: Kind,
}

/// Options every signal takes.
#[derive(clap::Args)]
struct Common {
    /// Sample rate, Hz.
    #[arg(long)]
    rate: f64,
    /// Output CSV file (columns time_s,value).
    #[arg(long)]
    out: PathBuf,
}

#[derive(clap::Subcommand)]
enum Kind {
    /// Swept sine from --f0-hz to --f1-hz.
    Chirp {
        /// Start frequency, Hz.
        #[arg(long)]
        f0_hz: f64,
        /// End frequency, Hz.
        #[arg(long)]
        f1_hz: f64,
        /// Duration, s.
        #[arg(long)]
        duration_s: f64,
        /// Amplitude at the start.
        #[arg(long, default_value_t = 1.0)]
        amplitude: f64,
        /// Amplitude at the end (linear in time in between); default: constant.
        #[arg(long)]
        amplitude_end: Option<f64>,
        /// Raised-cosine fade-in/out at each end, s.
        #[arg(long, default_value_t = 0.0)]
        fade_s: f64,
        /// Sweep law: exp (equal time per octave) or linear.
        #[arg(long, default_value = "exp")]
        sweep: String,
        #[command(flatten)]
        common: Common,
    },
    /// Maximum-length pseudo-random binary sequence.
    Prbs {
        /// Register length n (2..=20): period 2^n − 1 bits.
        #[arg(long, default_value_t = 10)]
        order: u32,
        /// Samples per bit.
        #[arg(long, default_value_t = 1)]
        samples_per_bit: usize,
        /// Number of periods.
        #[arg(long, default_value_t = 1)]
        periods: usize,
        /// Level ±amplitude.
        #[arg(long, default_value_t = 1.0)]
        amplitude: f64,
        #[command(flatten)]
        common: Common,
    },
    /// Schroeder-phased multisine (flat spectrum, low crest factor).
    Multisine {
        /// Lowest frequency, Hz.
        #[arg(long)]
        fmin_hz: f64,
        /// Highest frequency, Hz.
        #[arg(long)]
        fmax_hz: f64,
        /// Period, s (frequency resolution 1/period).
        #[arg(long)]
        period_s: f64,
        /// Number of periods.
        #[arg(long, default_value_t = 1)]
        periods: usize,
        /// Peak amplitude.
        #[arg(long, default_value_t = 1.0)]
        amplitude: f64,
        #[command(flatten)]
        common: Common,
    },
}

/// Generates the signal and writes it.
pub fn run(a: Args) -> skyloop::Result<()> {
    let (sig, common): (Signal, Common) = match a.kind {
        Kind::Chirp {
            f0_hz,
            f1_hz,
            duration_s,
            amplitude,
            amplitude_end,
            fade_s,
            sweep,
            common,
        } => {
            let sweep = match sweep.as_str() {
                "exp" | "exponential" | "log" => Sweep::Exponential,
                "linear" | "lin" => Sweep::Linear,
                other => return Err(format!("unknown sweep '{other}' (exp or linear)").into()),
            };
            let spec = ChirpSpec {
                f0_hz,
                f1_hz,
                duration_s,
                amplitude,
                amplitude_end,
                fade_s,
                sweep,
            };
            (signal::chirp(&spec, common.rate)?, common)
        }
        Kind::Prbs {
            order,
            samples_per_bit,
            periods,
            amplitude,
            common,
        } => {
            let spec = PrbsSpec {
                order,
                samples_per_bit,
                periods,
                amplitude,
            };
            (signal::prbs(&spec, common.rate)?, common)
        }
        Kind::Multisine {
            fmin_hz,
            fmax_hz,
            period_s,
            periods,
            amplitude,
            common,
        } => {
            let spec = MultisineSpec {
                f_min_hz: fmin_hz,
                f_max_hz: fmax_hz,
                period_s,
                periods,
                amplitude,
            };
            (signal::multisine(&spec, common.rate)?, common)
        }
    };
    let mut f =
        std::fs::File::create(&common.out).map_err(|e| format!("cannot create {}: {e}", common.out.display()))?;
    let t = sig.time_s();
    signal::write_csv(&mut f, &["time_s", "value"], &[&t, &sig.values])?;
    eprintln!(
        "wrote {} ({} samples at {} Hz, crest factor {:.2})",
        common.out.display(),
        sig.values.len(),
        sig.rate_hz,
        sig.crest_factor()
    );
    Ok(())
}
