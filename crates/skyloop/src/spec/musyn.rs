//! The μ-synthesis spec (TOML): the generalized plant (`plant = "file.json"` relative to the spec, an
//! expression, or an inline `[plant]` table with LTI JSON fields a, b, c, d), its uncertainty block
//! structure, `nmeas`, `ncon` and optional `[options]` (see `examples/musyn-distillation.toml`).
//! Plant convention: the Δ channels first, then exogenous inputs / performance outputs, then the
//! `ncon` controls / `nmeas` measurements ([`skyloop_robust::musyn`]).

/// Most frequencies of a μ-synthesis grid (`n_freq`, or the length of `w_rad_s`).
pub const MAX_N_FREQ: usize = 2_000;

/// Most DK-iterations (`max_iter`): each is a γ-bisection and a D-fit at every frequency, seconds to
/// minutes; MATLAB's musyn stops at 10 by default.
pub const MAX_ITER: usize = 100;

/// Highest order of a fitted D-scale (`d_order`): the fit's unknowns grow with it, and beyond a few
/// states per block the fitted scales only add states to the controller (MATLAB's default is up to 5).
pub const MAX_D_ORDER: usize = 10;

use crate::error::{Error, Result};
use serde::Deserialize;
use skyloop_lti::json::LtiJson;
use skyloop_lti::StateSpace;
use skyloop_robust::hinfsyn::HinfOptions;
use skyloop_robust::musyn::MusynOptions;
use skyloop_robust::uncertainty::BlockStructure;
use std::path::{Path, PathBuf};

/// A μ-synthesis problem, as read from TOML.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MusynSpec {
    /// Free text shown above the iteration table.
    #[serde(default)]
    pub name: Option<String>,
    /// The generalized plant.
    pub plant: PlantSpec,
    /// Block structure of Δ, e.g. "c1x1,c1x1,f2x2".
    pub blocks: String,
    /// Number of measurements (the last outputs of the plant).
    pub nmeas: usize,
    /// Number of controls (the last inputs of the plant).
    pub ncon: usize,
    /// DK-iteration options.
    #[serde(default)]
    pub options: OptionsSpec,
    /// Directory that a relative plant path is read from (the spec file's directory).
    #[serde(skip)]
    pub base_dir: PathBuf,
}

/// `plant`: a name (path relative to the spec, or an expression) or an inline LTI JSON table.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum PlantSpec {
    /// Path (relative to the spec) or expression.
    Named(String),
    /// Inline LTI JSON fields.
    Inline(LtiJson),
}

/// `[options]`.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct OptionsSpec {
    /// Most DK-iterations.
    pub max_iter: Option<usize>,
    /// Order of each fitted D-scale.
    pub d_order: Option<usize>,
    /// Relative μ improvement below which the iteration stops.
    pub tol: Option<f64>,
    /// Explicit grid (rad/s).
    pub w_rad_s: Option<Vec<f64>>,
    /// Log grid from `w_min_rad_s` to `w_max_rad_s` with `n_freq` points (all three needed).
    pub w_min_rad_s: Option<f64>,
    /// Upper end of the log grid, rad/s.
    pub w_max_rad_s: Option<f64>,
    /// Points of the log grid.
    pub n_freq: Option<usize>,
    /// Reduce each K-step's controller to this order.
    pub reduce_order: Option<usize>,
    /// Relative tolerance of each K-step's γ bisection.
    pub hinf_tol: Option<f64>,
}

impl MusynSpec {
    /// Reads a spec file; a relative plant path is then read from the file's directory.
    ///
    /// # Errors
    /// An unreadable file, or TOML that does not fit the spec (the message names the key).
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = skyloop_lti::json::read_text_file(path).map_err(|e| Error::read(path, e))?;
        Self::from_toml_str(&text, path.parent().unwrap_or(Path::new(".")))
            .map_err(|e| Error::Spec(format!("{}: {e}", path.display())))
    }

    /// Parses a spec; relative plant paths are read from `base_dir`.
    ///
    /// # Errors
    /// TOML that does not fit the spec (the message names the key).
    pub fn from_toml_str(text: &str, base_dir: &Path) -> Result<Self> {
        let mut spec: MusynSpec = toml::from_str(text).map_err(|e| Error::Spec(e.to_string()))?;
        spec.base_dir = base_dir.to_path_buf();
        Ok(spec)
    }

    /// The generalized plant.
    ///
    /// # Errors
    /// A plant that cannot be read or parsed.
    pub fn plant(&self) -> Result<StateSpace> {
        match &self.plant {
            PlantSpec::Inline(j) => j.to_ss().map_err(|e| Error::Spec(format!("[plant]: {e}"))),
            PlantSpec::Named(name) => crate::model::load_model_in(&self.base_dir, name),
        }
    }

    /// The block structure of Δ.
    ///
    /// # Errors
    /// A `blocks` string that does not parse.
    pub fn structure(&self) -> Result<BlockStructure> {
        BlockStructure::parse(&self.blocks).map_err(|e| Error::Spec(format!("blocks: {e}")))
    }

    /// The DK-iteration options, defaults where the spec is silent.
    ///
    /// # Errors
    /// A frequency grid given half-way or out of range.
    pub fn options(&self) -> Result<MusynOptions> {
        let o = &self.options;
        let mut opts = MusynOptions::default();
        if let Some(v) = o.max_iter {
            if !(1..=MAX_ITER).contains(&v) {
                return Err(Error::Spec(format!(
                    "options: max_iter = {v} must be in 1..={MAX_ITER}"
                )));
            }
            opts.max_iter = v;
        }
        if let Some(v) = o.d_order {
            if v > MAX_D_ORDER {
                return Err(Error::Spec(format!(
                    "options: d_order = {v} must be in 0..={MAX_D_ORDER}"
                )));
            }
            opts.d_order = v;
        }
        if let Some(v) = o.tol {
            opts.tol = v;
        }
        if let Some(v) = o.hinf_tol {
            opts.hinf = HinfOptions {
                rel_tol: v,
                ..HinfOptions::default()
            };
        }
        opts.reduce_order = o.reduce_order;
        match (&o.w_rad_s, o.w_min_rad_s, o.w_max_rad_s, o.n_freq) {
            (Some(w), None, None, None) => {
                if w.len() > MAX_N_FREQ {
                    return Err(Error::Spec(format!(
                        "options: w_rad_s has {} frequencies, at most {MAX_N_FREQ}",
                        w.len()
                    )));
                }
                opts.w_rad_s = w.clone()
            }
            (None, Some(lo), Some(hi), Some(n)) => {
                // D-scales are fitted at every frequency of every DK iteration: 100 000 points took
                // minutes; MATLAB's musyn uses about a hundred.
                if !(lo > 0.0 && hi > lo && hi.is_finite() && (2..=MAX_N_FREQ).contains(&n)) {
                    return Err(Error::Spec(format!(
                        "options: need 0 < w_min_rad_s < w_max_rad_s and n_freq in 2..={MAX_N_FREQ}, got {lo}, {hi}, {n}"
                    )));
                }
                opts.w_rad_s = skyloop_lti::freqresp::logspace(lo.log10(), hi.log10(), n);
            }
            (None, None, None, None) => {}
            _ => {
                return Err(Error::Spec(
                    "options: give either w_rad_s = [..] or all of w_min_rad_s, w_max_rad_s, n_freq".into(),
                ))
            }
        }
        Ok(opts)
    }
}
