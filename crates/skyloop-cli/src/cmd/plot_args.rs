//! Arguments and helpers shared by the plotting subcommands (`bode`, `nyquist`, `step`).

use skyloop::lti::StateSpace;

/// What every plotting subcommand takes: models, an output file and a frequency range.
#[derive(clap::Args)]
pub struct PlotArgs {
    /// Transfer-function expressions or paths to LTI JSON files; each becomes one curve.
    #[arg(required = true)]
    pub models: Vec<String>,
    /// Output file; `.svg` or `.png`.
    #[arg(long)]
    pub out: std::path::PathBuf,
    /// Plot title (defaults to the subcommand's name).
    #[arg(long)]
    pub title: Option<String>,
    /// Lowest frequency, Hz (defaults to two decades below the slowest dynamics).
    #[arg(long)]
    pub hz_min: Option<f64>,
    /// Highest frequency, Hz (defaults to two decades above the fastest dynamics).
    #[arg(long)]
    pub hz_max: Option<f64>,
    /// Number of log-spaced frequencies.
    #[arg(long, default_value_t = 1000)]
    pub points: usize,
}

impl PlotArgs {
    /// Loads every model, labelled by the text the user gave for it.
    pub fn load(&self) -> skyloop::Result<Vec<(String, StateSpace)>> {
        self.models
            .iter()
            .map(|m| Ok((label(m), skyloop::model::load_model(m)?)))
            .collect()
    }

    /// One log-spaced grid (rad/s) covering every model, or the user's range.
    pub fn grid(&self, models: &[(String, StateSpace)]) -> skyloop::Result<Vec<f64>> {
        if self.points < 2 {
            return Err("--points must be at least 2".into());
        }
        let two_pi = 2.0 * std::f64::consts::PI;
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for (_, m) in models {
            let g = skyloop::lti::freqresp::default_grid(m, 2)?;
            lo = lo.min(g[0]);
            hi = hi.max(g[g.len() - 1]);
        }
        if let Some(f) = self.hz_min {
            lo = f * two_pi;
        }
        if let Some(f) = self.hz_max {
            hi = f * two_pi;
        }
        if !(lo > 0.0 && hi > lo && hi.is_finite()) {
            return Err(format!(
                "frequency range must satisfy 0 < hz-min < hz-max, got {} .. {} Hz",
                lo / two_pi,
                hi / two_pi
            )
            .into());
        }
        Ok(skyloop::lti::freqresp::logspace(lo.log10(), hi.log10(), self.points))
    }

    /// The title, or `default` when none was given.
    pub fn title_or(&self, default: &str) -> String {
        self.title.clone().unwrap_or_else(|| default.to_string())
    }
}

/// A legend label for a model argument: the expression itself, its middle elided when long (products
/// of models often share a long prefix, so both ends are kept).
pub fn label(arg: &str) -> String {
    let chars: Vec<char> = arg.chars().collect();
    if chars.len() > 48 {
        let head: String = chars[..22].iter().collect();
        let tail: String = chars[chars.len() - 22..].iter().collect();
        format!("{head}…{tail}")
    } else {
        arg.to_string()
    }
}

/// Channel suffix for MIMO curves (empty for SISO).
pub fn channel(sys: &StateSpace, i: usize, j: usize) -> String {
    if sys.ny() * sys.nu() > 1 {
        format!(" [out {} ← in {}]", i + 1, j + 1)
    } else {
        String::new()
    }
}
