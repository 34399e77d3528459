//! Where an INAV log holds its rate loop, and where it is flying. INAV writes its header from its
//! mixer (`blackbox.c`, the sysinfo lines): `minthrottle` and `maxthrottle` are the throttle idle
//! value and the maximum throttle, `motorOutput` is the same pair, and `motor[k]` is logged in those
//! units (µs-like 1000–2000 also with DShot); the rate target of each axis is `axisRate[i]`, deg/s.

use crate::error::Result;
use crate::firmware::vocab::{
    gyro_limits, pid_sum_channels, setting_list, setting_one, AirborneCriteria, Axis, Limit, RateLoopChannels,
    GYRO_FULL_SCALE_DEG_S, MOTOR_EDGE,
};
use skyloop_sysid::logs::Log;

/// The rate loop of `axis`: PID sum → `gyroADC[i]`, with INAV's rate target `axisRate[i]` (or
/// `rcCommand[i]`) as the instrument.
///
/// # Errors
/// A log without the axis' channels (the message names them).
pub fn rate_loop_channels(log: &Log, axis: Axis) -> Result<RateLoopChannels> {
    let i = axis.index();
    pid_sum_channels(
        log,
        axis,
        &[
            format!("setpoint[{i}]"),
            format!("axisRate[{i}]"),
            format!("rcCommand[{i}]"),
        ],
        None,
    )
}

/// INAV's throttle floor (the idle value, the low end of `rcCommand[3]`) and motor output range, from
/// its header: `motorOutput` (idle, max), else `minthrottle`/`maxthrottle`, else 1000–2000. A header
/// range that holds fewer than half of the logged motor samples (at or inside its ends) is not the
/// logged scale (a header of another build or a hand-edited log), and the motors' own logged span is
/// used instead, so a flight is never taken for saturated because the header's scale differs.
pub fn throttle_and_motor_range(log: &Log) -> (f64, (f64, f64)) {
    let thr_lo = setting_one(log, "minthrottle")
        .filter(|v| (800.0..1500.0).contains(v))
        .unwrap_or(1000.0);
    let pair = |k: &str| {
        let v = setting_list(log, k);
        (v.len() >= 2).then(|| (v[0], v[1]))
    };
    let header = pair("motorOutput")
        .or_else(|| Some((setting_one(log, "minthrottle")?, setting_one(log, "maxthrottle")?)))
        .filter(|(a, b)| b > a)
        .unwrap_or((1000.0, 2000.0));
    let mut values = Vec::new();
    for k in 0..8 {
        if let Ok((_, v)) = log.channel(&format!("motor[{k}]")) {
            values.extend(v.iter().copied().filter(|x| x.is_finite()));
        }
    }
    if values.is_empty() {
        return (thr_lo, header);
    }
    let inside = values.iter().filter(|v| **v >= header.0 && **v <= header.1).count();
    if 2 * inside >= values.len() {
        return (thr_lo, header);
    }
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (thr_lo, (lo, hi))
}

/// The airborne tests: throttle `rcCommand[3]` 50 above the idle value, every `motor[k]` above the
/// idle value ("motors at idle": with airmode INAV holds them there at zero throttle, where they
/// cannot push the other way) and below the maximum ("motor saturation"), less 1 % of the range,
/// every |`gyroADC[i]`| below 97.5 % of 2000 deg/s.
pub fn airborne_criteria(log: &Log) -> AirborneCriteria {
    let (thr_lo, (lo, hi)) = throttle_and_motor_range(log);
    let mut limits = vec![Limit {
        channel: "rcCommand[3]".into(),
        lo: thr_lo + 0.05 * 1000.0,
        hi: f64::INFINITY,
        reason: "idle throttle",
    }];
    let edge = MOTOR_EDGE * (hi - lo);
    for k in 0..8 {
        limits.push(Limit {
            channel: format!("motor[{k}]"),
            lo: lo + edge,
            hi: f64::INFINITY,
            reason: "motors at idle",
        });
        limits.push(Limit {
            channel: format!("motor[{k}]"),
            lo: f64::NEG_INFINITY,
            hi: hi - edge,
            reason: "motor saturation",
        });
    }
    let gyros: Vec<String> = (0..3).map(|i| format!("gyroADC[{i}]")).collect();
    limits.extend(gyro_limits(&gyros, GYRO_FULL_SCALE_DEG_S));
    AirborneCriteria::with_limits(log, limits)
}
