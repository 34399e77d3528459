//! Where a PX4 ULog holds its rate loop, and where it is flying: `vehicle_torque_setpoint` (or
//! `actuator_controls_0`) → `vehicle_angular_velocity` (or `sensor_combined`) with
//! `vehicle_rates_setpoint` as the instrument; landed flag, collective thrust, motors and gyro tests.

use crate::error::Result;
use crate::firmware::vocab::{
    first_channel, gyro_limits, AirborneCriteria, Axis, Limit, RateLoopChannels, GYRO_FULL_SCALE_DEG_S, MOTOR_EDGE,
};
use skyloop_sysid::logs::Log;

/// Below this logging rate, Hz, a PX4 log's rate-loop topics cannot show the loop's dynamics (20–50
/// Hz and up): PX4's default `SDLOG_PROFILE` logs them at 10–50 Hz, its high-rate bit at the loop's
/// rate.
pub const MIN_RATE_HZ: f64 = 100.0;

/// What to change so that a log too slow for the rate loop is logged at the loop's rate next time.
pub const SLOW_LOG_ADVICE: &str = "set SDLOG_PROFILE bit 4 (High rate, value 16: vehicle_angular_velocity, vehicle_torque_setpoint, vehicle_rates_setpoint and actuator_motors at the rate loop's rate; `param set SDLOG_PROFILE 17` keeps the default set beside it) and fly again";

/// The rate loop of `axis` (rad/s, normalized torque).
///
/// # Errors
/// A log without the axis' channels (the message names them).
pub fn rate_loop_channels(log: &Log, axis: Axis) -> Result<RateLoopChannels> {
    let i = axis.index();
    Ok(RateLoopChannels {
        axis,
        input: first_channel(
            log,
            axis,
            &[
                format!("vehicle_torque_setpoint.xyz[{i}]"),
                format!("actuator_controls_0.control[{i}]"),
            ],
            "rate-controller output",
        )?,
        output: first_channel(
            log,
            axis,
            &[
                format!("vehicle_angular_velocity.xyz[{i}]"),
                format!("sensor_combined.gyro_rad[{i}]"),
            ],
            "gyro",
        )?,
        instrument: first_channel(
            log,
            axis,
            &[format!("vehicle_rates_setpoint.{}", axis.name())],
            "rate setpoint",
        )?,
        input_unit: "normalized torque",
        output_unit: "rad/s",
        input_limit: Some(1.0),
        disturbance: [
            "vehicle_thrust_setpoint.xyz[2]",
            "vehicle_rates_setpoint.thrust_body[2]",
            "actuator_controls_0.control[3]",
        ]
        .into_iter()
        .find(|n| log.channel(n).is_ok())
        .map(str::to_string),
    })
}

/// The airborne tests: `vehicle_land_detected.landed` false, collective thrust above 5 %
/// (`vehicle_rates_setpoint.thrust_body[2]` or `actuator_controls_0.control[3]`),
/// `actuator_motors.control[k]` inside (0.01, 0.99) (below: "motors at idle", above: "motor
/// saturation"), |gyro| below 97.5 % of 2000 deg/s.
pub fn airborne_criteria(log: &Log) -> AirborneCriteria {
    let mut limits = vec![Limit {
        channel: "vehicle_land_detected.landed".into(),
        lo: f64::NEG_INFINITY,
        hi: 0.5,
        reason: "landed",
    }];
    if log.channel("vehicle_rates_setpoint.thrust_body[2]").is_ok() {
        // NED: upward thrust is negative z.
        limits.push(Limit {
            channel: "vehicle_rates_setpoint.thrust_body[2]".into(),
            lo: f64::NEG_INFINITY,
            hi: -0.05,
            reason: "idle throttle",
        });
    } else {
        limits.push(Limit {
            channel: "actuator_controls_0.control[3]".into(),
            lo: 0.05,
            hi: f64::INFINITY,
            reason: "idle throttle",
        });
    }
    // Each end under its own name: motors at 0 throughout are a vehicle on the ground (or a test
    // stand), not a saturated mixer.
    for k in 0..8 {
        let ch = format!("actuator_motors.control[{k}]");
        limits.push(Limit {
            channel: ch.clone(),
            lo: MOTOR_EDGE,
            hi: f64::INFINITY,
            reason: "motors at idle",
        });
        limits.push(Limit {
            channel: ch,
            lo: f64::NEG_INFINITY,
            hi: 1.0 - MOTOR_EDGE,
            reason: "motor saturation",
        });
    }
    let gyros: Vec<String> = (0..3)
        .flat_map(|i| {
            [
                format!("vehicle_angular_velocity.xyz[{i}]"),
                format!("sensor_combined.gyro_rad[{i}]"),
            ]
        })
        .collect();
    limits.extend(gyro_limits(&gyros, GYRO_FULL_SCALE_DEG_S.to_radians()));
    AirborneCriteria::with_limits(log, limits)
}
