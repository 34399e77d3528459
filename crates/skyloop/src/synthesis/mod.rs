//! Synthesis workflows driven by a spec file: μ-synthesis by DK-iteration and its outputs; and
//! [`diagnose`], which says what about the plant or weights made a synthesis fail.

pub mod diagnose;

use crate::error::{Error, Result};
use crate::spec::musyn::MusynSpec;
use skyloop_lti::json::LtiJson;
use skyloop_robust::musyn::{musyn, MusynSolution};
use std::path::Path;

/// Runs the DK-iteration a spec describes.
///
/// # Errors
/// A plant, structure or option the spec gets wrong, or a DK-iteration in which no K-step succeeds.
pub fn musyn_from_spec(spec: &MusynSpec) -> Result<MusynSolution> {
    let p = spec.plant()?;
    let blocks = spec.structure()?;
    let opts = spec.options()?;
    musyn(&p, &blocks, spec.nmeas, spec.ncon, &opts).map_err(|e| {
        Error::Failed(diagnose::explain(
            "musyn",
            &e,
            &[("the spec's generalized plant", &p)],
            diagnose::Synthesis::Generalized,
        ))
    })
}

/// Writes `controller.json` (the best controller, LTI JSON) and `musyn.json` (the summary) to `dir`.
///
/// # Errors
/// A directory or file that cannot be written.
pub fn write_musyn_outputs(sol: &MusynSolution, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::create(dir, e))?;
    let kpath = dir.join("controller.json");
    std::fs::write(&kpath, skyloop_lti::json::to_json_string(&sol.controller)).map_err(|e| Error::write(&kpath, e))?;
    let spath = dir.join("musyn.json");
    let body = serde_json::to_string_pretty(&musyn_summary(sol, false))?;
    std::fs::write(&spath, body).map_err(|e| Error::write(&spath, e))
}

/// The DK-iteration as JSON: `{"mu_peak", "best", "stop_reason", "iterations": [{gamma, mu_peak,
/// mu_peak_w_rad_s, mu_lower_peak, mu_rs_peak, controller_order, scaled_plant_order}]}`, and with
/// `with_controller` the best controller as LTI JSON under "controller".
pub fn musyn_summary(sol: &MusynSolution, with_controller: bool) -> serde_json::Value {
    let iters: Vec<serde_json::Value> = sol
        .iterations
        .iter()
        .map(|it| {
            serde_json::json!({
                "gamma": it.gamma,
                "mu_peak": it.mu_peak,
                "mu_peak_w_rad_s": it.mu_peak_w_rad_s,
                "mu_lower_peak": it.mu_lower_peak,
                "mu_rs_peak": it.mu_rs_peak,
                "controller_order": it.controller_order,
                "scaled_plant_order": it.scaled_plant_order,
            })
        })
        .collect();
    let mut v = serde_json::json!({
        "mu_peak": sol.mu_peak,
        "best": sol.best,
        "stop_reason": sol.stop_reason,
        "iterations": iters,
    });
    if with_controller {
        v["controller"] = serde_json::to_value(LtiJson::from_ss(&sol.controller)).unwrap_or(serde_json::Value::Null);
    }
    v
}
