//! Where a Betaflight log holds its rate loop, and where it is flying: the PID sum, `gyroADC` and
//! `setpoint` (3.x: `rcCommand`, until the setpoint is derived through the rate curve), and the
//! airborne tests on throttle, motors and gyro.

use crate::error::Result;
use crate::firmware::vocab::{
    gyro_limits, motor_limits, pid_sum_channels, setting_list, setting_one, AirborneCriteria, Axis, Limit,
    RateLoopChannels, GYRO_FULL_SCALE_DEG_S,
};
use skyloop_sysid::logs::Log;

/// The rate loop of `axis`: PID sum → `gyroADC[i]`, with `setpoint[i]` (or `rcCommand[i]` on a
/// log without it) as the instrument, and the PID sum's limit (`pidsum_limit`, `pidsum_limit_yaw`;
/// 500 and 400 by default in 4.x).
///
/// # Errors
/// A log without the axis' channels (the message names them).
pub fn rate_loop_channels(log: &Log, axis: Axis) -> Result<RateLoopChannels> {
    let i = axis.index();
    let limit = if axis == Axis::Yaw {
        setting_one(log, "pidsum_limit_yaw")
    } else {
        setting_one(log, "pidsum_limit")
    }
    .filter(|l| *l > 0.0);
    pid_sum_channels(log, axis, &[format!("setpoint[{i}]"), format!("rcCommand[{i}]")], limit)
}

/// The motors' output range `motorOutput` (low, high) in the logged units (DShot values or µs);
/// 1000–2000 when the header has none.
pub fn motor_range(log: &Log) -> (f64, f64) {
    let m = setting_list(log, "motorOutput");
    match m.as_slice() {
        [lo, hi, ..] if hi > lo => (*lo, *hi),
        _ => (1000.0, 2000.0),
    }
}

/// The airborne tests: throttle `rcCommand[3]` above 1050 (5 % of its 1000–2000 range), every
/// `motor[k]` inside the `motorOutput` range less 1 % at either end, every |`gyroADC[i]`| below
/// 97.5 % of 2000 deg/s.
pub fn airborne_criteria(log: &Log) -> AirborneCriteria {
    let mut limits = vec![Limit {
        channel: "rcCommand[3]".into(),
        lo: 1050.0,
        hi: f64::INFINITY,
        reason: "idle throttle",
    }];
    let (lo, hi) = motor_range(log);
    limits.extend(motor_limits(0..=7, |k| format!("motor[{k}]"), lo, hi));
    let gyros: Vec<String> = (0..3).map(|i| format!("gyroADC[{i}]")).collect();
    limits.extend(gyro_limits(&gyros, GYRO_FULL_SCALE_DEG_S));
    AirborneCriteria::with_limits(log, limits)
}
