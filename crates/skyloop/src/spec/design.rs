//! The design specification (one TOML file per design): plant, synthesis method and weights, gain
//! boost, controller reduction, discretization. Unknown keys are errors, and every value error names
//! its key, so a typo cannot silently fall back to a default.

use serde::Deserialize;
use skyloop_lti::error::Result;
use skyloop_lti::{LtiError, StateSpace};
use std::path::{Path, PathBuf};

/// A whole design, as read from TOML.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignSpec {
    /// Title shown in reports.
    #[serde(default)]
    pub name: String,
    /// The plant to control.
    pub plant: PlantSpec,
    /// How the controller is obtained.
    pub synthesis: SynthesisSpec,
    /// Optional gain boost of the synthesized controller.
    pub boost: Option<BoostSpec>,
    /// Optional order reduction of the (boosted) controller.
    pub reduction: Option<ReductionSpec>,
    /// Optional discretization of the final continuous controller.
    pub discretize: Option<DiscretizeSpec>,
    /// Options of the analysis summary.
    #[serde(default)]
    pub analysis: AnalysisSpec,
    /// Directory that relative model paths are read from (the spec file's directory).
    #[serde(skip)]
    pub base_dir: PathBuf,
}

/// `[plant]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlantSpec {
    /// Transfer-function expression (delays as `exp(-T*s)`) or a path to an LTI JSON file.
    pub model: String,
    /// Order of the Padé approximants that replace delays for synthesis and γ (margins stay exact).
    #[serde(default = "default_pade")]
    pub pade_order: usize,
}

fn default_pade() -> usize {
    3
}

/// The synthesis method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SynthesisMethod {
    /// Glover–McFarlane loop shaping with shaping weights `w1` (input side) and `w2` (output side).
    Ncfsyn,
    /// Mixed sensitivity (hinfsyn on augw) with weights `ws` (on S), `wks` (on K·S), `wt` (on T).
    Mixsyn,
    /// A given controller `controller` (for u = C·(r − y)), only boosted/reduced/discretized/analysed.
    Given,
}

/// `[synthesis]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SynthesisSpec {
    /// ncfsyn, mixsyn or given.
    pub method: SynthesisMethod,
    /// ncfsyn: input-side shaping weight W1 (expression or LTI JSON path).
    pub w1: Option<String>,
    /// ncfsyn: output-side shaping weight W2.
    pub w2: Option<String>,
    /// ncfsyn: build K∞ for γ = factor·γ_min (> 1, MATLAB's default 1.1).
    pub factor: Option<f64>,
    /// mixsyn: weight on the sensitivity S.
    pub ws: Option<String>,
    /// mixsyn: weight on K·S.
    pub wks: Option<String>,
    /// mixsyn: weight on the complementary sensitivity T.
    pub wt: Option<String>,
    /// given: the controller C for u = C·(r − y).
    pub controller: Option<String>,
}

/// `[boost]`: exactly one of the two keys.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoostSpec {
    /// Scale the controller so that the final loop (reduced when reduction runs, which commutes
    /// with a scalar gain) has |L(j2πf)| = 1 at this frequency, Hz.
    pub crossover_hz: Option<f64>,
    /// Scale the controller by this gain.
    pub gain: Option<f64>,
}

/// `[reduction]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReductionSpec {
    /// Number of states of the reduced controller (unstable poles, integrators included, are kept).
    pub order: usize,
    /// "balanced" (truncation, MATLAB balred 'Truncate') or "spa" (DC matched, 'MatchDC'). SPA leaves
    /// a feedthrough, so with a strictly proper W2 the shaped K = W1⁻¹·C·W2⁻¹ is improper and the
    /// reported γ after reduction grows with the grid's upper frequency (it is infinite).
    #[serde(default = "default_reduction_method")]
    pub method: String,
}

fn default_reduction_method() -> String {
    "balanced".into()
}

/// `[discretize]`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiscretizeSpec {
    /// Controller sample rate, Hz (Tustin, as the bicopter paper's Step 5).
    pub rate_hz: f64,
    /// Optional Tustin prewarp frequency, Hz.
    pub prewarp_hz: Option<f64>,
}

/// `[analysis]`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnalysisSpec {
    /// Upper end (Hz) of the band where the discrete controller is compared with the continuous one.
    #[serde(default = "default_compare_hz")]
    pub compare_up_to_hz: f64,
    /// The reduced controller is compared with the full one over [f_c/band, f_c·band], f_c the crossover.
    #[serde(default = "default_band")]
    pub crossover_band: f64,
}

fn default_compare_hz() -> f64 {
    50.0
}

fn default_band() -> f64 {
    3.0
}

impl Default for AnalysisSpec {
    fn default() -> Self {
        AnalysisSpec {
            compare_up_to_hz: default_compare_hz(),
            crossover_band: default_band(),
        }
    }
}

fn bad(key: &str, msg: impl std::fmt::Display) -> LtiError {
    LtiError::InvalidArgument(format!("{key}: {msg}"))
}

impl DesignSpec {
    /// Parses and checks a spec; relative model paths are resolved against `base_dir`.
    ///
    /// # Errors
    /// TOML that does not parse, an unknown key, or a value out of range; the message names the key
    /// (`reduction.order: must be at least 1`).
    ///
    /// # Examples
    /// ```
    /// use skyloop::spec::design::DesignSpec;
    /// let bad = "[plant]\nmodel = \"1/(s+1)\"\n[synthesis]\nmethod = \"ncfsyn\"\nw1 = \"1/s\"\nfactr = 1.1\n";
    /// let e = DesignSpec::from_toml_str(bad, std::path::Path::new(".")).expect_err("typo");
    /// assert!(e.to_string().contains("factr"));
    /// ```
    pub fn from_toml_str(text: &str, base_dir: &Path) -> Result<DesignSpec> {
        let mut spec: DesignSpec =
            toml::from_str(text).map_err(|e| LtiError::InvalidArgument(format!("design spec: {e}")))?;
        spec.base_dir = base_dir.to_path_buf();
        spec.check()?;
        Ok(spec)
    }

    /// Reads and checks a spec file.
    pub fn from_file(path: &Path) -> Result<DesignSpec> {
        let text = skyloop_lti::json::read_text_file(path)
            .map_err(|e| LtiError::InvalidArgument(format!("cannot read {}: {e}", path.display())))?;
        let base = path.parent().unwrap_or(Path::new("."));
        DesignSpec::from_toml_str(&text, base)
    }

    /// Value checks that the TOML types cannot express.
    fn check(&self) -> Result<()> {
        if self.plant.pade_order == 0 || self.plant.pade_order > 10 {
            return Err(bad(
                "plant.pade_order",
                format!("must be 1..=10, got {}", self.plant.pade_order),
            ));
        }
        let s = &self.synthesis;
        let stray = |keys: &[(&str, bool)]| -> Result<()> {
            for (k, present) in keys {
                if *present {
                    return Err(bad(
                        &format!("synthesis.{k}"),
                        format!("not used by method {:?}", s.method).to_lowercase(),
                    ));
                }
            }
            Ok(())
        };
        match s.method {
            SynthesisMethod::Ncfsyn => {
                stray(&[
                    ("ws", s.ws.is_some()),
                    ("wks", s.wks.is_some()),
                    ("wt", s.wt.is_some()),
                    ("controller", s.controller.is_some()),
                ])?;
                if let Some(f) = s.factor {
                    if !(f > 1.0 && f.is_finite()) {
                        return Err(bad("synthesis.factor", format!("must be a finite number > 1, got {f}")));
                    }
                }
            }
            SynthesisMethod::Mixsyn => {
                stray(&[
                    ("w1", s.w1.is_some()),
                    ("w2", s.w2.is_some()),
                    ("factor", s.factor.is_some()),
                    ("controller", s.controller.is_some()),
                ])?;
                if s.ws.is_none() && s.wks.is_none() && s.wt.is_none() {
                    return Err(bad("synthesis", "mixsyn needs at least one of ws, wks, wt"));
                }
            }
            SynthesisMethod::Given => {
                stray(&[
                    ("w1", s.w1.is_some()),
                    ("w2", s.w2.is_some()),
                    ("factor", s.factor.is_some()),
                    ("ws", s.ws.is_some()),
                    ("wks", s.wks.is_some()),
                    ("wt", s.wt.is_some()),
                ])?;
                if s.controller.is_none() {
                    return Err(bad("synthesis.controller", "method given needs a controller"));
                }
            }
        }
        if let Some(b) = &self.boost {
            match (b.crossover_hz, b.gain) {
                (Some(f), None) if f > 0.0 && f.is_finite() => {}
                (Some(f), None) => return Err(bad("boost.crossover_hz", format!("must be finite and > 0, got {f}"))),
                (None, Some(g)) if g > 0.0 && g.is_finite() => {}
                (None, Some(g)) => return Err(bad("boost.gain", format!("must be finite and > 0, got {g}"))),
                _ => return Err(bad("boost", "give exactly one of crossover_hz and gain")),
            }
        }
        if let Some(r) = &self.reduction {
            if r.order == 0 {
                return Err(bad("reduction.order", "must be at least 1"));
            }
            r.method
                .parse::<skyloop_lti::reduce::Method>()
                .map_err(|e| bad("reduction.method", e))?;
        }
        if let Some(d) = &self.discretize {
            if !(d.rate_hz > 0.0 && d.rate_hz.is_finite()) {
                return Err(bad(
                    "discretize.rate_hz",
                    format!("must be finite and > 0, got {}", d.rate_hz),
                ));
            }
            if let Some(p) = d.prewarp_hz {
                if !(p > 0.0 && p < d.rate_hz / 2.0) {
                    return Err(bad(
                        "discretize.prewarp_hz",
                        format!("must be in (0, rate_hz/2) = (0, {}), got {p}", d.rate_hz / 2.0),
                    ));
                }
            }
        }
        let a = &self.analysis;
        if !(a.compare_up_to_hz > 0.0 && a.compare_up_to_hz.is_finite()) {
            return Err(bad("analysis.compare_up_to_hz", "must be finite and > 0"));
        }
        if let Some(d) = &self.discretize {
            if a.compare_up_to_hz >= d.rate_hz / 2.0 {
                return Err(bad(
                    "analysis.compare_up_to_hz",
                    format!("must be below the Nyquist frequency {} Hz", d.rate_hz / 2.0),
                ));
            }
        }
        if !(a.crossover_band > 1.0 && a.crossover_band.is_finite()) {
            return Err(bad("analysis.crossover_band", "must be finite and > 1"));
        }
        Ok(())
    }

    /// Loads a model named by `key`: an LTI JSON file (relative to the spec's directory) when the
    /// text ends in `.json`, else a transfer-function expression.
    pub fn load_model(&self, key: &str, text: &str) -> Result<StateSpace> {
        let t = text.trim();
        let sys = if t.ends_with(".json") {
            let path = self.base_dir.join(t);
            let body = skyloop_lti::json::read_text_file(&path)
                .map_err(|e| bad(key, format!("cannot read {}: {e}", path.display())))?;
            skyloop_lti::json::from_json_str(&body).map_err(|e| bad(key, e))?
        } else {
            skyloop_lti::expr::parse_model(t).map_err(|e| bad(key, e))?
        };
        if !sys.is_continuous() {
            return Err(bad(key, "must be a continuous-time model"));
        }
        Ok(sys)
    }
}
