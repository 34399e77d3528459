//! The channels an identification reads (the `--axis` preset's or the user's input, output and
//! instrument) and the band their logging rates allow.

use super::preset::{axis_preset, AxisPreset};
use super::remarks::Remarks;
use super::request::IdentifyRequest;
use crate::error::{Error, Result};
use crate::firmware::Axis;
use skyloop_sysid::logs::{median_rate_hz, Log, LogFormat};
use skyloop_sysid::spectral::Method;

/// The columns of one identification.
pub(crate) struct Channels {
    /// The firmware's rate-loop preset, with `--axis`.
    pub preset: Option<AxisPreset>,
    /// The plant input column (spec: a channel, or channels joined by + and −).
    pub input: String,
    /// The plant output column.
    pub output: String,
    /// The instrument (excitation) column; `None` estimates open loop.
    pub excitation: Option<String>,
    /// The measured disturbance conditioned out of the spectra (the throttle), or `None`.
    pub disturbance: Option<String>,
}

impl Channels {
    /// The column specs read from the log: input, output and the instrument when there is one.
    pub fn specs(&self) -> Vec<&str> {
        let mut specs = vec![self.input.as_str(), self.output.as_str()];
        if let Some(r) = &self.excitation {
            specs.push(r);
        }
        if let Some(d) = &self.disturbance {
            specs.push(d);
        }
        specs
    }
}

/// The channels of the request: its own `--input`/`--output`/`--excitation`, else the `--axis`
/// preset's; notes which were chosen and warns of an open-loop estimate of closed-loop data.
///
/// # Errors
/// An unknown axis, a log the preset cannot find the rate loop in, or no `--input`/`--output`
/// without `--axis`.
pub(crate) fn resolve(log: &Log, a: &IdentifyRequest, rm: &mut Remarks) -> Result<Channels> {
    let preset = a
        .axis
        .as_deref()
        .map(|ax| -> Result<AxisPreset> { axis_preset(log, ax.parse::<Axis>()?) })
        .transpose()?;
    let input = a
        .input
        .clone()
        .or_else(|| preset.as_ref().map(|p| p.channels.input.clone()))
        .ok_or_else(|| Error::Input("--input is required without --axis".into()))?;
    let output = a
        .output
        .clone()
        .or_else(|| preset.as_ref().map(|p| p.channels.output.clone()))
        .ok_or_else(|| Error::Input("--output is required without --axis".into()))?;
    let excitation = match a.excitation.as_deref() {
        Some(x) if x.eq_ignore_ascii_case("none") => None,
        Some(x) => Some(x.to_string()),
        None => preset.as_ref().map(|p| p.channels.instrument.clone()),
    };
    let disturbance = disturbance_of(log, a, preset.as_ref(), rm);
    if let Some(p) = &preset {
        rm.note(format!(
            "{} log, {} axis: input {input}, output {output}, instrument {}",
            p.firmware.display_name(),
            p.channels.axis.name(),
            excitation.as_deref().unwrap_or("none (open loop)")
        ));
    }
    if excitation.is_none() {
        open_loop_warning(log, a.axis.is_some(), rm);
    }
    Ok(Channels {
        preset,
        input,
        output,
        excitation,
        disturbance,
    })
}

/// The measured disturbance of the request (`--disturbance`, else the preset's throttle), kept only
/// for the estimators that can condition on it (notes when it is dropped for the method);
/// [`conditioning::choose`](super::conditioning::choose) then keeps the preset's only where it helps.
fn disturbance_of(log: &Log, a: &IdentifyRequest, preset: Option<&AxisPreset>, rm: &mut Remarks) -> Option<String> {
    let chosen = match a.disturbance.as_deref() {
        Some(x) if x.eq_ignore_ascii_case("none") => return None,
        Some(x) => Some(x.to_string()),
        None => preset.and_then(|p| p.channels.disturbance.clone()),
    }?;
    if !a.method.parse::<Method>().is_ok_and(Method::conditions_on_disturbance) {
        rm.note(format!(
            "the throttle's effect is not removed: --method {} cannot condition on a measured disturbance ({chosen}); welch and spafdr can",
            a.method
        ));
        return None;
    }
    if a.disturbance.is_none() && log.series(&chosen).is_err() {
        return None;
    }
    Some(chosen)
}

/// Closed-loop data estimated open loop: Φ_yu/Φ_uu is pulled towards −1/C by the feedback noise.
/// Warns when the log is a flight log (or a CSV with a setpoint column), naming the better option.
fn open_loop_warning(log: &Log, with_axis: bool, rm: &mut Remarks) {
    let fields = log.field_names();
    let setpoint = fields
        .iter()
        .find(|f| f.to_lowercase().contains("setpoint"))
        .or_else(|| fields.iter().find(|f| f.starts_with("rcCommand[")))
        .cloned();
    if log.format == LogFormat::Csv && setpoint.is_none() {
        return;
    }
    let better = match (with_axis, &setpoint) {
        (true, _) => "drop --excitation none".to_string(),
        (false, Some(s)) => format!("--excitation {s} (or --axis roll|pitch|yaw)"),
        (false, None) => "--excitation SETPOINT (or --axis roll|pitch|yaw)".to_string(),
    };
    rm.warn(format!(
        "open-loop estimate of closed loop data: feedback makes Φ_yu/Φ_uu biased (low gain, wrong phase where the controller acts); give the setpoint as instrument: {better}"
    ));
}

/// The channels a column spec (a channel, or channels joined by + and −) reads.
fn spec_channels(spec: &str) -> Vec<String> {
    spec.split(['+', '-'])
        .map(|t| t.trim().to_string())
        .filter(|t| !t.is_empty())
        .collect()
}

/// The slowest channel behind the specs and its own median rate, Hz.
fn slowest_channel(log: &Log, specs: &[&str]) -> Result<(String, f64)> {
    let mut slowest = (String::new(), f64::INFINITY);
    for spec in specs {
        let names = if log.channel(spec).is_ok() {
            vec![spec.to_string()]
        } else {
            spec_channels(spec)
        };
        for n in names {
            let (t, _) = log.channel(&n)?;
            let r = median_rate_hz(t);
            if r < slowest.1 {
                slowest = (n, r);
            }
        }
    }
    Ok(slowest)
}

/// The top of the estimate's band, Hz: the user's `--fmax-hz` checked against the slowest
/// channel's Nyquist frequency, else 1/2.5 of that channel's rate when it is slower than the
/// grid; `None` leaves the band to the estimate. A channel's own rate bounds the band: nothing
/// above its Nyquist frequency exists in the data. Warns when a preset's rate loop is logged too
/// slowly to show its dynamics, with the firmware's setting that logs it faster.
///
/// # Errors
/// A channel the log does not hold, or `--fmax-hz` above the slowest channel's Nyquist frequency.
pub(crate) fn band_limit(log: &Log, a: &IdentifyRequest, ch: &Channels, rm: &mut Remarks) -> Result<Option<f64>> {
    let specs = ch.specs();
    let (slow_name, slow_rate) = slowest_channel(log, &specs)?;
    let fastest = specs
        .iter()
        .map(|s| log.series(s).map(|(t, _)| median_rate_hz(&t)))
        .collect::<std::result::Result<Vec<_>, _>>()?
        .into_iter()
        .fold(0.0f64, f64::max);
    let grid_rate = a.rate.unwrap_or(fastest);
    let mut fmax_hz = a.fmax_hz;
    if let Some(f) = a.fmax_hz {
        if f > 0.5 * slow_rate {
            return Err(Error::Input(format!(
                "channel '{slow_name}' is logged at {slow_rate:.1} Hz: nothing above its Nyquist frequency {:.1} Hz is in the data, but --fmax-hz asks for {f} Hz; ask for at most {:.1} Hz (2.5 samples per period) or log the channel faster",
                0.5 * slow_rate,
                slow_rate / 2.5
            )));
        }
        if f > slow_rate / 2.5 {
            rm.warn(format!(
                "channel '{slow_name}' is logged at {slow_rate:.1} Hz, less than 2.5 × the requested band {f} Hz: the estimate near {f} Hz is attenuated and aliased"
            ));
        }
    } else if slow_rate < 0.99 * grid_rate {
        fmax_hz = Some(slow_rate / 2.5);
        rm.warn(format!(
            "channel '{slow_name}' is logged at only {slow_rate:.1} Hz (resampled to {grid_rate:.1} Hz): the estimate stops at {:.2} Hz, 1/2.5 of its rate",
            slow_rate / 2.5
        ));
    }
    // A rate loop logged below what shows its dynamics: the firmware's setting that logs it faster.
    if let Some(fw) = ch.preset.as_ref().map(|p| p.firmware) {
        if let Some((min, advice)) = fw.slow_log() {
            if slow_rate < min {
                rm.warn(format!(
                    "'{slow_name}' is logged at {slow_rate:.1} Hz, too slow to show the rate loop's dynamics (at least {min:.0} Hz): the fit below is not to be trusted; {advice}"
                ));
            }
        }
    }
    Ok(fmax_hz)
}
