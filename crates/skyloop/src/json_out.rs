//! JSON shapes of analysis results that more than one front end prints. The CLI (`--json`) and the
//! Python package both build their result from these functions, so a script that moves from one to
//! the other reads the same keys and values by construction.

use crate::error::Result;
use serde_json::{json, Value};
use skyloop_lti::margins::{allmargin, diskmargin, margin_from, AllMargins, DiskMargin, Margins};
use skyloop_lti::StateSpace;
use std::f64::consts::PI;

/// A non-finite number as JSON `null` (JSON has no infinity; an infinite margin reads as "none").
fn fin(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

fn hz(w_rad_s: f64) -> f64 {
    w_rad_s / (2.0 * PI)
}

/// The `skyloop margins --json` object of already computed margins of one SISO loop.
///
/// Keys: `gain_margin_db` (dB), `gain_margin_freq_hz` (Hz), `phase_margin_deg` (degrees),
/// `phase_margin_freq_hz` (Hz), `delay_margin_s` (s), `disk_margin` {`alpha`, `gain_db` [low,
/// high] (dB), `phase_deg` (± degrees), `freq_hz`}, `closed_loop_stable`, `unit_gain_band_hz`
/// ([low, high] Hz, or null unless |L| = 1 on a band), `all_gain_margins` [{`gm_db`, `freq_hz`}],
/// `all_phase_margins` [{`pm_deg`, `freq_hz`}]. Infinite values are `null`.
pub fn margins_to_json(all: &AllMargins, m: &Margins, dm: &DiskMargin) -> Value {
    json!({
        "gain_margin_db": fin(m.gm_db),
        "gain_margin_freq_hz": fin(hz(m.gm_w_rad_s)),
        "phase_margin_deg": fin(m.pm_deg),
        "phase_margin_freq_hz": fin(hz(m.pm_w_rad_s)),
        "delay_margin_s": fin(m.delay_margin_s),
        "disk_margin": {
            "alpha": fin(dm.alpha),
            "gain_db": [fin(dm.gain_db[0]), fin(dm.gain_db[1])],
            "phase_deg": fin(dm.phase_deg),
            "freq_hz": fin(hz(dm.w_rad_s)),
        },
        "closed_loop_stable": all.stable,
        "unit_gain_band_hz": all.unit_gain_band_rad_s.map(|(a, b)| [hz(a), hz(b)]),
        "all_gain_margins": all.gain_margins.iter()
            .map(|g| json!({"gm_db": fin(g.gm_db), "freq_hz": hz(g.w_rad_s)}))
            .collect::<Vec<_>>(),
        "all_phase_margins": all.phase_margins.iter()
            .map(|p| json!({"pm_deg": p.pm_deg, "freq_hz": hz(p.w_rad_s)}))
            .collect::<Vec<_>>(),
    })
}

/// Computes the classic, delay and disk margins of a SISO loop L = P·C (closed as u = −y, exact
/// with delays) and returns the [`margins_to_json`] object.
///
/// # Errors
/// A model that is not SISO or whose margins cannot be computed (skyloop-lti's error).
///
/// # Examples
/// ```
/// let l = skyloop::lti::expr::parse_model("2*exp(-0.1*s)/(s*(s+1))")?;
/// let v = skyloop::json_out::margins_json(&l)?;
/// assert!(v["phase_margin_deg"].as_f64().unwrap() > 0.0);
/// assert_eq!(v["closed_loop_stable"], true);
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn margins_json(sys: &StateSpace) -> Result<Value> {
    let all = allmargin(sys)?;
    let m = margin_from(&all);
    let dm = diskmargin(sys)?;
    Ok(margins_to_json(&all, &m, &dm))
}

/// The `skyloop ncfsyn --json` object: `gamma_min`, `gamma` and `controller` (LTI JSON of C for
/// u = C·(r − y)).
pub fn ncfsyn_json(sol: &skyloop_robust::ncfsyn::NcfSolution) -> Value {
    json!({
        "gamma_min": sol.gamma_min,
        "gamma": sol.gamma,
        "controller": skyloop_lti::json::LtiJson::from_ss(&sol.controller),
    })
}
