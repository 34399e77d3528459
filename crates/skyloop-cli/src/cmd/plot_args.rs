//! Arguments shared by the plotting subcommands (`bode`, `sigma`, `nichols`, `nyquist`, `pzmap`,
//! `rlocus`, `step`): models with their legend names, an output file, a frequency range.

use skyloop::figures::{short_label, Labeled};
use skyloop::plot::figure::Figure;

/// Models and their legend names.
#[derive(clap::Args)]
pub struct ModelArgs {
    /// Transfer-function expressions or paths to LTI JSON files; each becomes one curve.
    #[arg(required_unless_present = "plant")]
    pub models: Vec<String>,
    /// A plant P: with --controller, the loop L = P·C is the first curve (MATLAB bode(P*C)).
    #[arg(long, requires = "controller", allow_hyphen_values = true)]
    pub plant: Option<String>,
    /// The controller C of --plant (u = C·(r − y)).
    #[arg(long, requires = "plant", allow_hyphen_values = true)]
    pub controller: Option<String>,
    /// Sample time, s: the expressions are discrete transfer functions in z.
    #[arg(long)]
    pub dt: Option<f64>,
    /// Legend name of each model, in order (repeat the flag); default: the text of the model.
    #[arg(long = "label")]
    pub labels: Vec<String>,
}

impl ModelArgs {
    /// Loads every model with its legend name.
    pub fn load(&self) -> skyloop::Result<Vec<Labeled>> {
        let mut names: Vec<String> = Vec::new();
        let mut models: Vec<skyloop::lti::StateSpace> = Vec::new();
        if let (Some(p), Some(c)) = (&self.plant, &self.controller) {
            names.push("L = P·C".into());
            models.push(skyloop::loops::open_loop(p, c)?);
        }
        for m in &self.models {
            names.push(short_label(m));
            models.push(skyloop::model::load_model_dt(m, self.dt)?);
        }
        if self.labels.len() > models.len() {
            return Err(format!("--label given {} times for {} models", self.labels.len(), models.len()).into());
        }
        Ok(models
            .into_iter()
            .zip(names)
            .enumerate()
            .map(|(k, (m, name))| Labeled::new(self.labels.get(k).cloned().unwrap_or(name), m))
            .collect())
    }
}

/// What every frequency-plot subcommand takes: models, an output file and a frequency range.
#[derive(clap::Args)]
pub struct PlotArgs {
    #[command(flatten)]
    pub models: ModelArgs,
    /// Output file; `.svg`, `.png` or `.html` (interactive: zoom, hover values).
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
    /// The models and one log-spaced grid (rad/s) covering them, or the user's range.
    pub fn load(&self) -> skyloop::Result<(Vec<Labeled>, Vec<f64>)> {
        let models = self.models.load()?;
        let w = skyloop::figures::frequency_grid(&models, self.hz_min, self.hz_max, self.points)?;
        Ok((models, w))
    }

    /// Writes the figure under the user's title (if any) and says where.
    pub fn save(&self, fig: Figure) -> skyloop::Result<()> {
        save(fig, self.title.as_deref(), &self.out)
    }
}

/// Writes a figure (`.svg`, `.png`, or `.html` for the interactive page), retitled when asked.
pub fn save(mut fig: Figure, title: Option<&str>, out: &std::path::Path) -> skyloop::Result<()> {
    if let Some(t) = title {
        fig.title = t.to_string();
    }
    skyloop::figures::save(&fig, out)?;
    eprintln!("wrote {}", out.display());
    Ok(())
}
