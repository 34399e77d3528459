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

/// The yaw rate-loop model: [`RATE_LOOP_MODEL`] with a zero at 1/Tz. Yaw torque is the rotors'
/// reaction: their drag, which follows the motors' lag, and the torque that spins each rotor up or
/// down, which is proportional to its acceleration and so leads. The sum has a zero (Tz > 0, Tz in
/// s), and every real yaw log tried shows it: about −55° instead of −90° from 2 to 15 Hz, which
/// [`RATE_LOOP_MODEL`] cannot follow (its fit explains less than the mean).
pub const YAW_RATE_LOOP_MODEL: &str = "K*(Tz*s+1)*exp(-Td*s)/(s*(tau*s+1))";

/// Upper bound of the yaw model's Tz, s: a zero at 0.16 Hz, below every band a flight supports
/// (from 2 Hz). A fit that ends there has the zero below its band, where the rate follows the
/// command as K·Tz·e^(−Td·s)/(τs + 1): the rotors' spin-up torque outweighs their drag across the
/// band.
pub const TZ_MAX_S: f64 = 1.0;

/// Everything `--axis` fills in.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisPreset {
    /// The firmware that wrote the log.
    pub firmware: Firmware,
    /// Input, output and instrument channels with their units.
    pub channels: RateLoopChannels,
    /// The model fitted unless `--model` is given: [`YAW_RATE_LOOP_MODEL`] for yaw,
    /// [`RATE_LOOP_MODEL`] otherwise.
    pub model: &'static str,
    /// The model tried when the data do not support `model` (yaw: [`RATE_LOOP_MODEL`], for a craft
    /// whose rotors show no reaction-torque lead), if any.
    pub fallback_model: Option<&'static str>,
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
        model: if axis == Axis::Yaw {
            YAW_RATE_LOOP_MODEL
        } else {
            RATE_LOOP_MODEL
        },
        fallback_model: (axis == Axis::Yaw).then_some(RATE_LOOP_MODEL),
        criteria: firmware.airborne_criteria(log),
    })
}

/// Starting points for fitting [`RATE_LOOP_MODEL`] to `frf` within [fmin_hz, fmax_hz]: a grid of τ and
/// Td with K from the measured magnitude (|G|·ω·|jωτ + 1| at each point, the median), bounded to
/// K ≥ 0, 0.1 ms ≤ τ ≤ 2 s, 0 ≤ Td ≤ 0.2 s.
pub fn rate_loop_starts(frf: &Frf, fmin_hz: f64, fmax_hz: f64) -> Vec<Vec<ParamSpec>> {
    starts_with_zero(frf, fmin_hz, fmax_hz, &[None])
}

/// Starting points for fitting `model` (the `--axis` preset's: [`RATE_LOOP_MODEL`] or
/// [`YAW_RATE_LOOP_MODEL`], told apart by its parameter `Tz`) as [`rate_loop_starts`]; with a zero,
/// each start also tries Tz of 20 and 80 ms (bounded to 0..=1 s), K divided by |jωTz + 1|.
pub fn preset_starts(model: &str, frf: &Frf, fmin_hz: f64, fmax_hz: f64) -> Vec<Vec<ParamSpec>> {
    if model.contains("Tz") {
        starts_with_zero(frf, fmin_hz, fmax_hz, &[Some(0.02), Some(0.08)])
    } else {
        rate_loop_starts(frf, fmin_hz, fmax_hz)
    }
}

fn starts_with_zero(frf: &Frf, fmin_hz: f64, fmax_hz: f64, zeros: &[Option<f64>]) -> Vec<Vec<ParamSpec>> {
    let spec = |name: &str, init: f64, lower: f64, upper: f64| ParamSpec {
        name: name.into(),
        init,
        lower,
        upper,
    };
    let mut out = Vec::new();
    for tau in [0.01, 0.03, 0.1] {
        for td in [0.002, 0.008, 0.03] {
            for &tz in zeros {
                let mut k: Vec<f64> = frf
                    .freq_hz
                    .iter()
                    .zip(&frf.response)
                    .filter(|(f, g)| **f >= fmin_hz && **f <= fmax_hz && **f > 0.0 && g.norm().is_finite())
                    .map(|(f, g)| {
                        let w = 2.0 * std::f64::consts::PI * f;
                        let lead = (1.0 + (w * tz.unwrap_or(0.0)).powi(2)).sqrt();
                        g.norm() * w * (1.0 + (w * tau).powi(2)).sqrt() / lead
                    })
                    .collect();
                if k.is_empty() {
                    continue;
                }
                k.sort_by(f64::total_cmp);
                let k0 = k[k.len() / 2].max(1e-9);
                let mut start = vec![
                    spec("K", k0, 0.0, f64::INFINITY),
                    spec("tau", tau, 1e-4, 2.0),
                    spec("Td", td, 0.0, 0.2),
                ];
                if let Some(tz) = tz {
                    start.push(spec("Tz", tz, 0.0, TZ_MAX_S));
                }
                out.push(start);
            }
        }
    }
    out
}
