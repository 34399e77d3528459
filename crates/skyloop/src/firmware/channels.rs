//! Where a firmware's log holds the signals of the noise picture: the gyro (from the rate loop's
//! channels), the D term, the motor commands, the throttle and the motors' rotation speed.

use super::vocab::Axis;
use super::{inav, Firmware};
use skyloop_sysid::logs::Log;

/// The noise picture's channels of a log; absent ones are None or empty.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseChannels {
    /// Filtered gyro of roll, pitch, yaw, or why the firmware model found none for the axis
    /// (which channels it looked for, what to log).
    pub gyro: [std::result::Result<String, String>; 3],
    /// The gyro's unit ("deg/s", "rad/s").
    pub gyro_unit: &'static str,
    /// D term of roll, pitch, yaw (Betaflight, INAV `axisD[i]`).
    pub dterm: [Option<String>; 3],
    /// The D term's unit.
    pub dterm_unit: &'static str,
    /// Motor commands.
    pub motors: Vec<String>,
    /// The motor commands' unit.
    pub motor_unit: &'static str,
    /// Throttle channel and the values it takes at zero and full throttle.
    pub throttle: Option<(String, f64, f64)>,
    /// Per-motor rotation telemetry, and the factor from its value to the rotation frequency in Hz.
    pub rotation: Option<(Vec<String>, f64)>,
}

/// The channels of `log`'s noise picture; None for a log whose firmware skyloop cannot name.
pub fn noise_channels(log: &Log) -> Option<NoiseChannels> {
    let firmware = Firmware::of_log(log)?;
    let has = |n: &str| log.channel(n).is_ok();
    let gyro = Axis::ALL.map(|a| {
        firmware
            .rate_loop_channels(log, a)
            .map(|c| c.output)
            .map_err(|e| e.to_string())
    });
    let listed = |f: &dyn Fn(usize) -> String| (0..8).map(f).filter(|n| has(n)).collect::<Vec<_>>();
    Some(match firmware {
        Firmware::Betaflight | Firmware::Inav => {
            let throttle = if firmware == Firmware::Inav {
                let (lo, _) = inav::flight::throttle_and_motor_range(log);
                (lo, 2000.0)
            } else {
                (1000.0, 2000.0)
            };
            // Betaflight logs eRPM/100 (bidirectional DShot); electrical revolutions are
            // motor_poles/2 per mechanical one.
            let poles = log
                .setting("motor_poles")
                .and_then(|v| v.trim().parse::<f64>().ok())
                .filter(|p| *p >= 2.0)
                .unwrap_or(14.0);
            let erpm = listed(&|k| format!("eRPM[{k}]"));
            NoiseChannels {
                gyro,
                gyro_unit: "deg/s",
                dterm: [0, 1, 2].map(|i| Some(format!("axisD[{i}]")).filter(|n| has(n))),
                dterm_unit: "PID unit",
                motors: listed(&|k| format!("motor[{k}]")),
                motor_unit: "motor command",
                throttle: has("rcCommand[3]").then(|| ("rcCommand[3]".to_string(), throttle.0, throttle.1)),
                rotation: (!erpm.is_empty()).then(|| (erpm, 100.0 / 60.0 / (poles / 2.0))),
            }
        }
        Firmware::Ardupilot => {
            let motors: Vec<String> = (1..=8).map(|k| format!("RCOU.C{k}")).filter(|n| has(n)).collect();
            NoiseChannels {
                gyro,
                gyro_unit: "deg/s",
                dterm: [None, None, None],
                dterm_unit: "",
                throttle: has("CTUN.ThO").then(|| ("CTUN.ThO".to_string(), 0.0, 1.0)),
                motors,
                motor_unit: "PWM µs",
                rotation: None,
            }
        }
        Firmware::Px4 => {
            let motors = listed(&|k| format!("actuator_motors.control[{k}]"));
            let rpm = listed(&|k| format!("esc_status.esc[{k}].esc_rpm"));
            NoiseChannels {
                gyro,
                gyro_unit: "rad/s",
                dterm: [None, None, None],
                dterm_unit: "",
                throttle: motors.first().map(|m| (m.clone(), 0.0, 1.0)),
                motors,
                motor_unit: "normalized command",
                rotation: (!rpm.is_empty()).then(|| (rpm, 1.0 / 60.0)),
            }
        }
        Firmware::Generic => return None,
    })
}
