//! Where an ArduPilot DataFlash log holds its rate loop, and where it is flying: `RATE.<x>Out` (or
//! the PID message's P+I+D+FF) → `RATE.<x>` with `RATE.<x>Des` as the instrument; throttle output,
//! motor PWM and gyro tests.

use crate::error::{Error, Result};
use crate::firmware::vocab::{
    gyro_limits, motor_limits, setting_one, AirborneCriteria, Axis, Limit, RateLoopChannels, GYRO_FULL_SCALE_DEG_S,
};
use skyloop_sysid::logs::Log;

/// Lowest logging rate of ArduPilot's RATE/PID messages that supports a rate-loop identification,
/// Hz: the loop's dynamics reach 20–50 Hz, and ArduCopter's 10 Hz ATTITUDE_MED logging (the
/// default without ATTITUDE_FAST) or the 25–50 Hz of rate-capped logs cannot show them.
pub const MIN_RATE_HZ: f64 = 100.0;

/// What to change so that a log too slow for the rate loop is logged at the loop's rate next time.
pub const SLOW_LOG_ADVICE: &str = "set LOG_BITMASK bits 0 (ATTITUDE_FAST) and 12 (PID) so RATE and PIDR/PIDP/PIDY are logged at the loop rate, and fly again";

/// ArduPilot's rate loop of `axis`: the rate controller's output `RATE.ROut` (or the PID message's
/// P+I+D+FF), the achieved rate `RATE.R` (deg/s) and the desired rate `RATE.RDes` (or `PIDR.Tar`);
/// refused, with the logging settings to change, when they are logged too slowly to identify.
///
/// # Errors
/// Channels the log lacks or logs too slowly (the message says what to set).
pub fn rate_loop_channels(log: &Log, axis: Axis) -> Result<RateLoopChannels> {
    let (x, pid) = match axis {
        Axis::Roll => ("R", "PIDR"),
        Axis::Pitch => ("P", "PIDP"),
        Axis::Yaw => ("Y", "PIDY"),
    };
    let has = |n: &str| log.channel(n).is_ok();
    let pid_sum: Vec<String> = ["P", "I", "D", "FF"]
        .iter()
        .map(|t| format!("{pid}.{t}"))
        .filter(|n| has(n))
        .collect();
    let input = if has(&format!("RATE.{x}Out")) {
        format!("RATE.{x}Out")
    } else if !pid_sum.is_empty() {
        pid_sum.join("+")
    } else {
        return Err(Error::Input(format!(
            "{}: no rate-controller output for the {} axis (looked for RATE.{x}Out and {pid}.P/I/D/FF): log RATE or {pid} (LOG_BITMASK bits 0 ATTITUDE_FAST and 12 PID)",
            log.source,
            axis.name()
        )));
    };
    let output = format!("RATE.{x}");
    if !has(&output) {
        return Err(Error::Input(format!(
            "{}: no RATE message (the achieved rate {output}): set LOG_BITMASK bit 0 (ATTITUDE_FAST) so ArduCopter logs RATE at its loop rate",
            log.source
        )));
    }
    let instrument = [format!("RATE.{x}Des"), format!("{pid}.Tar")]
        .into_iter()
        .find(|n| has(n))
        .ok_or_else(|| Error::Input(format!("{}: no desired rate RATE.{x}Des or {pid}.Tar", log.source)))?;
    let group = |name: &str| name.split(['.', '+']).next().unwrap_or_default().to_string();
    let slowest = [&input, &output, &instrument]
        .into_iter()
        .filter_map(|c| {
            let g = group(c);
            log.info().into_iter().find(|i| i.name == g).map(|i| (g, i.rate_hz))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1));
    if let Some((g, hz)) = slowest.filter(|(_, hz)| *hz < MIN_RATE_HZ) {
        return Err(Error::Input(format!(
            "{}: {g} is logged at {hz:.0} Hz, too slow to identify the rate loop (at least {MIN_RATE_HZ:.0} Hz): set LOG_BITMASK bits 0 (ATTITUDE_FAST) and 12 (PID) so RATE and PIDR/PIDP/PIDY are logged at the loop rate (SCHED_LOOP_RATE), and LOG_FILE_RATEMAX = 0 where the firmware has it, then fly again",
            log.source
        )));
    }
    Ok(RateLoopChannels {
        axis,
        input,
        output,
        instrument,
        input_unit: "rate-controller output",
        output_unit: "deg/s",
        input_limit: Some(1.0),
        disturbance: has("RATE.AOut").then(|| "RATE.AOut".to_string()),
    })
}

/// The airborne tests: throttle output `CTUN.ThO` above 0.05, every `RCOU.C<k>` inside
/// `MOT_PWM_MIN`..`MOT_PWM_MAX` (1000–2000 by default) less 1 % at either end, |`RATE.<x>`| below
/// 97.5 % of 2000 deg/s.
pub fn airborne_criteria(log: &Log) -> AirborneCriteria {
    let mut limits = vec![Limit {
        channel: "CTUN.ThO".into(),
        lo: 0.05,
        hi: f64::INFINITY,
        reason: "idle throttle",
    }];
    let pwm = |k: &str, d: f64| setting_one(log, k).filter(|v| *v > 0.0).unwrap_or(d);
    let (lo, hi) = (pwm("MOT_PWM_MIN", 1000.0), pwm("MOT_PWM_MAX", 2000.0));
    limits.extend(motor_limits(1..=8, |k| format!("RCOU.C{k}"), lo, hi));
    let rates: Vec<String> = ["R", "P", "Y"].iter().map(|x| format!("RATE.{x}")).collect();
    limits.extend(gyro_limits(&rates, GYRO_FULL_SCALE_DEG_S));
    AirborneCriteria::with_limits(log, limits)
}
