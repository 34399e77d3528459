//! `--axis`: what `skyloop identify LOG --axis roll` chooses on the pilot's behalf, as one value the
//! CLI, `tune LOG --axis` and the Python bindings share.

use crate::firmware::{AirborneCriteria, Axis, Firmware, RateLoopChannels};
use skyloop_sysid::fit::ParamSpec;
use skyloop_sysid::logs::Log;
use skyloop_sysid::spectral::Frf;

use crate::error::Result;

/// The default rate-loop model: the airframe's rotational inertia behind the motors' lag and the
/// loop's delay, acceleration K per unit of controller output.
pub const RATE_LOOP_MODEL: &str = "K*exp(-Td*s)/(s*(tau*s+1))";

/// Everything `--axis` fills in.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisPreset {
    /// The firmware that wrote the log.
    pub firmware: Firmware,
    /// Input, output and instrument channels with their units.
    pub channels: RateLoopChannels,
    /// The model fitted unless `--model` is given: [`RATE_LOOP_MODEL`].
    pub model: &'static str,
    /// How the airborne segments are found.
    pub criteria: AirborneCriteria,
}

/// The preset of `axis` for `log`: the firmware's channels and airborne tests.
///
/// # Errors
/// A CSV log (it names no firmware), or a log without the axis' channels (the message names them).
pub fn axis_preset(log: &Log, axis: Axis) -> Result<AxisPreset> {
    let firmware = Firmware::of_log_or_refuse(log)?;
    Ok(AxisPreset {
        firmware,
        channels: firmware.rate_loop_channels(log, axis)?,
        model: RATE_LOOP_MODEL,
        criteria: firmware.airborne_criteria(log),
    })
}

/// Starting points for fitting [`RATE_LOOP_MODEL`] to `frf` within [fmin_hz, fmax_hz]: a grid of τ and
/// Td with K from the measured magnitude (|G|·ω·|jωτ + 1| at each point, the median), bounded to
/// K ≥ 0, 0.1 ms ≤ τ ≤ 2 s, 0 ≤ Td ≤ 0.2 s.
pub fn rate_loop_starts(frf: &Frf, fmin_hz: f64, fmax_hz: f64) -> Vec<Vec<ParamSpec>> {
    let mut out = Vec::new();
    for tau in [0.01, 0.03, 0.1] {
        for td in [0.002, 0.008, 0.03] {
            let mut k: Vec<f64> = frf
                .freq_hz
                .iter()
                .zip(&frf.response)
                .filter(|(f, g)| **f >= fmin_hz && **f <= fmax_hz && **f > 0.0 && g.norm().is_finite())
                .map(|(f, g)| {
                    let w = 2.0 * std::f64::consts::PI * f;
                    g.norm() * w * (1.0 + (w * tau).powi(2)).sqrt()
                })
                .collect();
            if k.is_empty() {
                continue;
            }
            k.sort_by(f64::total_cmp);
            let k0 = k[k.len() / 2].max(1e-9);
            let spec = |name: &str, init: f64, lower: f64, upper: f64| ParamSpec {
                name: name.into(),
                init,
                lower,
                upper,
            };
            out.push(vec![
                spec("K", k0, 0.0, f64::INFINITY),
                spec("tau", tau, 1e-4, 2.0),
                spec("Td", td, 0.0, 0.2),
            ]);
        }
    }
    out
}
