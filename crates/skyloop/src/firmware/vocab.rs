//! The words every firmware file shares, and no firmware owns: the rate-loop axis, a header's
//! lowpass and notch settings as written, the rate loop's channels in a log, and the tests that
//! say where a log is flying. The firmware files use this module, never each other.

use crate::error::{Error, Result};
use serde::Serialize;
use skyloop_sysid::logs::Log;

/// A rate-loop axis (the CLI names, the order of the firmware's per-axis arrays and Betaflight's
/// yaw I factor depend on it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// Roll (body x), index 0.
    Roll,
    /// Pitch (body y), index 1.
    Pitch,
    /// Yaw (body z), index 2.
    Yaw,
}

impl Axis {
    /// Roll, pitch and yaw, in the firmware's order.
    pub const ALL: [Axis; 3] = [Axis::Roll, Axis::Pitch, Axis::Yaw];

    /// "roll", "pitch" or "yaw".
    pub fn name(&self) -> &'static str {
        match self {
            Axis::Roll => "roll",
            Axis::Pitch => "pitch",
            Axis::Yaw => "yaw",
        }
    }

    /// Parses "roll", "pitch" or "yaw".
    ///
    /// # Errors
    /// Any other text.
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "roll" => Ok(Axis::Roll),
            "pitch" => Ok(Axis::Pitch),
            "yaw" => Ok(Axis::Yaw),
            _ => Err(Error::Input(format!("axis must be roll, pitch or yaw, got `{s}`"))),
        }
    }

    /// 0, 1, 2 for roll, pitch, yaw (the order of the firmware's per-axis arrays, `gyroADC[i]`,
    /// `xyz[i]`).
    pub fn index(&self) -> usize {
        match self {
            Axis::Roll => 0,
            Axis::Pitch => 1,
            Axis::Yaw => 2,
        }
    }
}

impl std::str::FromStr for Axis {
    type Err = Error;
    /// Also accepts x/y/z and 0/1/2, any case (as `identify --axis` always has).
    fn from_str(s: &str) -> Result<Axis> {
        match s.trim().to_ascii_lowercase().as_str() {
            "roll" | "x" | "0" => Ok(Axis::Roll),
            "pitch" | "y" | "1" => Ok(Axis::Pitch),
            "yaw" | "z" | "2" => Ok(Axis::Yaw),
            _ => Err(Error::Input(format!("unknown axis '{s}' (roll, pitch or yaw)"))),
        }
    }
}

/// A lowpass filter stage as a header states it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LowpassSetting {
    /// Filter type: "PT1", "BIQUAD", "PT2", "PT3", or the firmware's number when unknown.
    pub kind: String,
    /// Static cutoff, Hz.
    pub cutoff_hz: f64,
    /// Dynamic cutoff range (min, max), Hz, when the cutoff follows throttle.
    pub dynamic_hz: Option<(f64, f64)>,
}

/// A static notch as a header states it (Betaflight and INAV `*_notch_hz` / `*_notch_cutoff`):
/// the centre and the lower −3 dB frequency, Hz.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NotchSetting {
    /// Notch centre, Hz.
    pub center_hz: f64,
    /// Lower cutoff, Hz (below the centre; the width follows from it).
    pub cutoff_hz: f64,
}

/// The numbers of a comma-separated header value ("35,75,35,140").
pub(crate) fn numbers(v: &str) -> Vec<f64> {
    v.split(',').filter_map(|x| x.trim().parse::<f64>().ok()).collect()
}

/// The numbers of setting `key` of `log` (empty when absent).
pub(crate) fn setting_list(log: &Log, key: &str) -> Vec<f64> {
    log.setting(key).map(numbers).unwrap_or_default()
}

/// The first number of setting `key` of `log`.
pub(crate) fn setting_one(log: &Log, key: &str) -> Option<f64> {
    setting_list(log, key).first().copied()
}

/// The static notches of a header's centre and cutoff lists: on when the centre is above zero and
/// the cutoff below it.
pub(crate) fn header_notches(log: &Log, hz: &str, cut: &str) -> Vec<NotchSetting> {
    setting_list(log, hz)
        .into_iter()
        .zip(setting_list(log, cut))
        .filter(|&(c, k)| c > 0.0 && k > 0.0 && k < c)
        .map(|(center_hz, cutoff_hz)| NotchSetting { center_hz, cutoff_hz })
        .collect()
}

/// The (major, minor) version in a revision such as "Betaflight 3.1.5 (4646f9d) OMNIBUSF4" or
/// "INAV 9.0.1 (d44f2cf6) …": the first dotted word.
pub(crate) fn version_of(rev: &str) -> Option<(u32, u32)> {
    rev.split_whitespace().find_map(|w| {
        if !w.contains('.') {
            return None;
        }
        let mut it = w.split('.');
        let major = it.next()?.parse().ok()?;
        let minor = it.next().and_then(|m| m.parse().ok()).unwrap_or(0);
        Some((major, minor))
    })
}

/// The channels of one axis' rate loop, as column specs `Log::series` accepts, with their units.
#[derive(Debug, Clone, PartialEq)]
pub struct RateLoopChannels {
    /// Which axis.
    pub axis: Axis,
    /// Plant input: the rate controller's output (Betaflight's PID sum
    /// `axisP[i]+axisI[i]+axisD[i]+axisF[i]` of the terms the log holds; PX4's
    /// `vehicle_torque_setpoint.xyz[i]`; ArduPilot's `RATE.ROut`).
    pub input: String,
    /// Plant output: the gyro (`gyroADC[i]`; `vehicle_angular_velocity.xyz[i]`; `RATE.R`).
    pub output: String,
    /// Instrument: the rate setpoint (`setpoint[i]`, `axisRate[i]`; `vehicle_rates_setpoint.roll`;
    /// `RATE.RDes`).
    pub instrument: String,
    /// Unit of the input ("PID unit" for Betaflight, "normalized torque" for PX4).
    pub input_unit: &'static str,
    /// Unit of the output ("deg/s" for Betaflight, "rad/s" for PX4).
    pub output_unit: &'static str,
    /// Symmetric limit of the input the firmware clips the controller's output at (Betaflight's
    /// `pidsum_limit`), in input units; None where the firmware states none.
    pub input_limit: Option<f64>,
    /// The collective thrust command (Betaflight's and INAV's `rcCommand[3]`; PX4's thrust
    /// setpoint; ArduPilot's `RATE.AOut`), when the log holds it: throttle changes torque the frame
    /// through unequal motors and props or an offset centre of gravity, so the identification removes
    /// its linear effect on the gyro as a measured disturbance.
    pub disturbance: Option<String>,
}

impl RateLoopChannels {
    /// Unit of a rate-loop model's gain K in K·e^(−Td·s)/(s·(τs+1)): output acceleration per input
    /// unit, e.g. "deg/s² per PID unit".
    pub fn gain_unit(&self) -> String {
        format!("{}² per {}", self.output_unit, self.input_unit)
    }
}

/// A usable-range test on one channel: a sample is usable when `lo < value < hi`.
#[derive(Debug, Clone, PartialEq)]
pub struct Limit {
    /// Channel (full name).
    pub channel: String,
    /// Exclusive lower limit (−∞ for none).
    pub lo: f64,
    /// Exclusive upper limit (+∞ for none).
    pub hi: f64,
    /// Why a sample outside is excluded, e.g. "idle throttle", "motor saturation".
    pub reason: &'static str,
}

/// How the flying parts of a log are found: the firmware's tests and the margins around them.
#[derive(Debug, Clone, PartialEq)]
pub struct AirborneCriteria {
    /// Every test a usable sample passes.
    pub limits: Vec<Limit>,
    /// Shortest segment kept, s (shorter ones carry too little low-frequency information).
    pub min_len_s: f64,
    /// Trimmed from both ends of every segment, s: take-off, landing and the entry into and exit from
    /// saturation are transients the linear model does not describe.
    pub margin_s: f64,
    /// Trimmed from a segment that runs to the end of the log, s: a log that stops while flying
    /// usually ends in a crash or a power loss, whose last moments are not flight.
    pub crash_tail_s: f64,
}

/// Fraction of a motor output's range taken as "at the limit": mixer clipping makes the commanded
/// torque differ from the one applied.
pub const MOTOR_EDGE: f64 = 0.01;
/// Betaflight's, INAV's and PX4's usual gyro full scale is ±2000 deg/s.
pub const GYRO_FULL_SCALE_DEG_S: f64 = 2000.0;
/// The share of the gyro's full scale from which it counts as saturated.
pub const GYRO_SATURATED: f64 = 0.975;

impl AirborneCriteria {
    /// The criteria with the usual margins (2 s shortest segment, 0.2 s margins, 1 s crash tail),
    /// keeping only the limits on channels `log` holds.
    pub fn with_limits(log: &Log, limits: Vec<Limit>) -> AirborneCriteria {
        AirborneCriteria {
            limits: limits.into_iter().filter(|l| log.channel(&l.channel).is_ok()).collect(),
            min_len_s: 2.0,
            margin_s: 0.2,
            crash_tail_s: 1.0,
        }
    }
}

/// The tests "motor at either end of `lo..hi`" of the channels `name(k)` for k in `ks`.
pub(crate) fn motor_limits(
    ks: std::ops::RangeInclusive<usize>,
    name: impl Fn(usize) -> String,
    lo: f64,
    hi: f64,
) -> Vec<Limit> {
    let edge = MOTOR_EDGE * (hi - lo);
    ks.map(|k| Limit {
        channel: name(k),
        lo: lo + edge,
        hi: hi - edge,
        reason: "motor saturation",
    })
    .collect()
}

/// The tests "gyro within [`GYRO_SATURATED`] of ±`full_scale`" of the channels `names`.
pub(crate) fn gyro_limits(names: &[String], full_scale: f64) -> Vec<Limit> {
    let g = GYRO_SATURATED * full_scale;
    names
        .iter()
        .map(|n| Limit {
            channel: n.clone(),
            lo: -g,
            hi: g,
            reason: "gyro saturation",
        })
        .collect()
}

/// The first of `names` the log holds, or an error naming them all.
pub(crate) fn first_channel(log: &Log, axis: Axis, names: &[String], what: &str) -> Result<String> {
    names.iter().find(|n| log.channel(n).is_ok()).cloned().ok_or_else(|| {
        Error::Input(format!(
            "{}: no {what} channel for the {} axis (looked for {})",
            log.source,
            axis.name(),
            names.join(", ")
        ))
    })
}

/// The rate loop of a blackbox log (Betaflight's and INAV's shared layout): the PID sum of the
/// terms the log holds (neither logs a term that is always zero, such as `axisD[2]` when yaw D is
/// 0), `gyroADC[i]`, and the first of `instruments` the log holds.
///
/// # Errors
/// A log without PID terms, gyro or setpoint for the axis (the message names them).
pub(crate) fn pid_sum_channels(
    log: &Log,
    axis: Axis,
    instruments: &[String],
    input_limit: Option<f64>,
) -> Result<RateLoopChannels> {
    let i = axis.index();
    let terms: Vec<String> = ["axisP", "axisI", "axisD", "axisF"]
        .iter()
        .map(|t| format!("{t}[{i}]"))
        .filter(|n| log.channel(n).is_ok())
        .collect();
    if terms.is_empty() {
        return Err(Error::Input(format!(
            "{}: no PID terms (axisP[{i}], axisI[{i}], ...) for the {} axis",
            log.source,
            axis.name()
        )));
    }
    Ok(RateLoopChannels {
        axis,
        input: terms.join("+"),
        output: first_channel(log, axis, &[format!("gyroADC[{i}]")], "gyro")?,
        instrument: first_channel(log, axis, instruments, "setpoint")?,
        input_unit: "PID unit",
        output_unit: "deg/s",
        input_limit,
        disturbance: log.channel("rcCommand[3]").is_ok().then(|| "rcCommand[3]".to_string()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_are_read_from_revisions() {
        assert_eq!(version_of("Betaflight 4.2.8 (101738d8e) STM32F7X2"), Some((4, 2)));
        assert_eq!(version_of("INAV 9.0.1 (d44f2cf6) IFLIGHT_BLITZ_F722"), Some((9, 0)));
        assert_eq!(version_of("Betaflight 2025.12.1 (abc) STM32H743"), Some((2025, 12)));
        assert_eq!(version_of("c49bd40"), None);
    }

    #[test]
    fn axes_parse_and_index() {
        for (k, a) in Axis::ALL.iter().enumerate() {
            assert_eq!(a.index(), k);
            assert_eq!(Axis::parse(a.name()).unwrap(), *a);
        }
        assert!(Axis::parse("roll ").is_err());
    }
}
