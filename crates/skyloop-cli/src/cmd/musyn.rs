//! `skyloop musyn SPEC.toml [--json] [--out DIR]`: μ-synthesis by DK-iteration.
//!
//! The spec names the generalized plant (`plant = "file.json"` relative to the spec, or an
//! expression, or an inline `[plant]` table with LTI JSON fields a, b, c, d), its uncertainty
//! block structure, `nmeas`, `ncon` and optional `[options]` (see `examples/musyn-distillation.toml`).
//! Plant convention: the Δ channels first, then exogenous inputs / performance outputs, then the
//! `ncon` controls / `nmeas` measurements ([`skyloop_robust::musyn`]).

use crate::input::load_model;
use crate::output::print_json;
use clap::Args as ClapArgs;
use serde::Deserialize;
use skyloop_lti::json::LtiJson;
use skyloop_lti::StateSpace;
use skyloop_robust::hinfsyn::HinfOptions;
use skyloop_robust::musyn::{musyn, MusynOptions, MusynSolution};
use skyloop_robust::uncertainty::BlockStructure;
use std::path::{Path, PathBuf};

/// Arguments of `skyloop musyn`.
#[derive(ClapArgs)]
pub struct Args {
    /// The synthesis spec (TOML): plant, blocks, nmeas, ncon, [options].
    pub spec: PathBuf,
    /// Print {"mu_peak":..,"iterations":[..],"controller":LTI JSON,..} on stdout instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Directory for controller.json (the best controller, LTI JSON) and musyn.json (the summary).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The spec file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Spec {
    /// Free text.
    #[serde(default)]
    name: Option<String>,
    plant: PlantSpec,
    /// Block structure of Δ, e.g. "c1x1,c1x1,f2x2".
    blocks: String,
    nmeas: usize,
    ncon: usize,
    #[serde(default)]
    options: OptionsSpec,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum PlantSpec {
    /// Path (relative to the spec) or expression.
    Named(String),
    /// Inline LTI JSON fields.
    Inline(LtiJson),
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct OptionsSpec {
    max_iter: Option<usize>,
    d_order: Option<usize>,
    tol: Option<f64>,
    /// Explicit grid (rad/s).
    w_rad_s: Option<Vec<f64>>,
    /// Log grid from w_min_rad_s to w_max_rad_s with n_freq points (all three needed).
    w_min_rad_s: Option<f64>,
    w_max_rad_s: Option<f64>,
    n_freq: Option<usize>,
    reduce_order: Option<usize>,
    /// Relative tolerance of each K-step's γ bisection.
    hinf_tol: Option<f64>,
}

fn load_plant(p: &PlantSpec, base: &Path) -> Result<StateSpace, String> {
    match p {
        PlantSpec::Inline(j) => j.to_ss().map_err(|e| format!("[plant]: {e}")),
        PlantSpec::Named(name) => {
            let rel = base.join(name);
            if rel.is_file() {
                load_model(&rel.to_string_lossy())
            } else {
                load_model(name)
            }
        }
    }
}

fn options(o: &OptionsSpec) -> Result<MusynOptions, String> {
    let mut opts = MusynOptions::default();
    if let Some(v) = o.max_iter {
        opts.max_iter = v;
    }
    if let Some(v) = o.d_order {
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
        (Some(w), None, None, None) => opts.w_rad_s = w.clone(),
        (None, Some(lo), Some(hi), Some(n)) => {
            if !(lo > 0.0 && hi > lo && hi.is_finite() && n >= 2) {
                return Err(format!(
                    "options: need 0 < w_min_rad_s < w_max_rad_s and n_freq >= 2, got {lo}, {hi}, {n}"
                ));
            }
            opts.w_rad_s = skyloop_lti::freqresp::logspace(lo.log10(), hi.log10(), n);
        }
        (None, None, None, None) => {}
        _ => return Err("options: give either w_rad_s = [..] or all of w_min_rad_s, w_max_rad_s, n_freq".into()),
    }
    Ok(opts)
}

fn summary(sol: &MusynSolution, with_controller: bool) -> serde_json::Value {
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

/// Runs the DK-iteration and reports it.
pub fn run(a: Args) -> Result<(), String> {
    let text = std::fs::read_to_string(&a.spec).map_err(|e| format!("cannot read {}: {e}", a.spec.display()))?;
    let spec: Spec = toml::from_str(&text).map_err(|e| format!("{}: {e}", a.spec.display()))?;
    let base = a.spec.parent().unwrap_or(Path::new("."));
    let p = load_plant(&spec.plant, base)?;
    let blocks = BlockStructure::parse(&spec.blocks).map_err(|e| format!("blocks: {e}"))?;
    let opts = options(&spec.options)?;
    let sol = musyn(&p, &blocks, spec.nmeas, spec.ncon, &opts).map_err(|e| format!("musyn: {e}"))?;
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let kpath = dir.join("controller.json");
        std::fs::write(&kpath, skyloop_lti::json::to_json_string(&sol.controller))
            .map_err(|e| format!("cannot write {}: {e}", kpath.display()))?;
        let spath = dir.join("musyn.json");
        let body = serde_json::to_string_pretty(&summary(&sol, false)).map_err(|e| e.to_string())?;
        std::fs::write(&spath, body).map_err(|e| format!("cannot write {}: {e}", spath.display()))?;
    }
    if a.json {
        return print_json(&summary(&sol, true));
    }
    if let Some(n) = &spec.name {
        println!("{n}");
    }
    println!(
        "{:>4} {:>10} {:>10} {:>10} {:>12} {:>10} {:>8} {:>8}",
        "iter", "gamma", "mu_peak", "mu_lower", "peak_rad_s", "mu_rs", "K_order", "P_order"
    );
    for (k, it) in sol.iterations.iter().enumerate() {
        println!(
            "{:>4} {:>10.5} {:>10.5} {:>10.5} {:>12.5} {:>10.5} {:>8} {:>8}{}",
            k + 1,
            it.gamma,
            it.mu_peak,
            it.mu_lower_peak,
            it.mu_peak_w_rad_s,
            it.mu_rs_peak,
            it.controller_order,
            it.scaled_plant_order,
            if k == sol.best { "  <- best" } else { "" }
        );
    }
    println!("stopped: {}", sol.stop_reason);
    println!(
        "best: iteration {}, peak mu {:.5}, controller with {} states{}",
        sol.best + 1,
        sol.mu_peak,
        sol.controller.nx(),
        a.out
            .as_ref()
            .map(|d| format!(" written to {}", d.join("controller.json").display()))
            .unwrap_or_default()
    );
    Ok(())
}
