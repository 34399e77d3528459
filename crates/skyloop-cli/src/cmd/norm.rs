//! `skyloop norm MODEL [--json]`: H∞ norm with its peak frequency, and the H2 norm.

use crate::output;
use serde_json::{json, Value};
use skyloop::lti::norms::{h2_norm, hinf_norm, linf_norm};
use std::f64::consts::PI;

/// Arguments of `skyloop norm`.
#[derive(clap::Args)]
pub struct Args {
    /// Transfer-function expression or path to an LTI JSON file.
    #[arg(allow_hyphen_values = true)]
    model: String,
    /// Print `{"hinf":..,"hinf_freq_hz":..,"h2":..}` (null where a norm is infinite).
    #[arg(long)]
    json: bool,
    /// Repeat the H∞ computation N times and print the fastest wall time on stderr (for bench/compare.py).
    #[arg(long, value_name = "N")]
    bench: Option<usize>,
}

fn fin(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

/// Computes the norms and prints them.
pub fn run(a: Args) -> skyloop::Result<()> {
    let sys = skyloop::model::load_model(&a.model)?;
    output::bench(a.bench, || hinf_norm(&sys))?;
    let (hinf, w) = hinf_norm(&sys)?;
    let h2 = h2_norm(&sys)?;
    // The peak gain of an unstable model (its L∞ norm) is still informative for a reader.
    let (linf, wl) = if hinf.is_finite() { (hinf, w) } else { linf_norm(&sys)? };
    let hz = |w: f64| w / (2.0 * PI);
    if a.json {
        return output::print_json(&json!({
            "hinf": fin(hinf),
            "hinf_freq_hz": fin(hz(w)),
            "h2": fin(h2),
            "linf": fin(linf),
            "linf_freq_hz": fin(hz(wl)),
        }));
    }
    let show = |x: f64| {
        if x.is_finite() {
            format!("{x:.10e}")
        } else {
            "inf".into()
        }
    };
    println!(
        "H-inf norm   {}{}",
        show(hinf),
        if w.is_finite() {
            format!(" at {:.6e} Hz", hz(w))
        } else {
            String::new()
        }
    );
    if !hinf.is_finite() && linf.is_finite() {
        println!(
            "L-inf norm   {} at {:.6e} Hz (peak gain; the model is unstable)",
            show(linf),
            hz(wl)
        );
    }
    println!("H2 norm      {}", show(h2));
    Ok(())
}
