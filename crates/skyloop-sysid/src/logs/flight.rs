//! What a flight log holds for rate-loop identification: which firmware wrote it, which channels are
//! the rate loop's input (the controller's output), output (the gyro) and instrument (the rate
//! setpoint) on each axis, and the airborne segments in which the loop is flying and linear enough to
//! identify (no idle throttle, no motor or gyro saturation, no crash tail).

use std::ops::Range;

use crate::error::{invalid, Result, SysidError};
use crate::logs::{uniform, Log, LogFormat};

/// A rate-loop axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// Roll (body x), index 0.
    Roll,
    /// Pitch (body y), index 1.
    Pitch,
    /// Yaw (body z), index 2.
    Yaw,
}

impl Axis {
    /// 0, 1, 2 for roll, pitch, yaw: the index firmware uses in `gyroADC[i]`, `xyz[i]`.
    pub fn index(self) -> usize {
        match self {
            Axis::Roll => 0,
            Axis::Pitch => 1,
            Axis::Yaw => 2,
        }
    }

    /// "roll", "pitch" or "yaw".
    pub fn name(self) -> &'static str {
        ["roll", "pitch", "yaw"][self.index()]
    }
}

impl std::str::FromStr for Axis {
    type Err = SysidError;
    fn from_str(s: &str) -> Result<Axis> {
        match s.trim().to_ascii_lowercase().as_str() {
            "roll" | "x" | "0" => Ok(Axis::Roll),
            "pitch" | "y" | "1" => Ok(Axis::Pitch),
            "yaw" | "z" | "2" => Ok(Axis::Yaw),
            _ => Err(invalid(format!("unknown axis '{s}' (roll, pitch or yaw)"))),
        }
    }
}

/// The firmware family a log comes from, as far as its channel names and units go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlightFirmware {
    /// Betaflight, and the forks that log its layout (EmuFlight): blackbox logs.
    Betaflight,
    /// INAV: blackbox logs whose header names INAV (`Firmware revision:INAV …` or `Firmware type:INAV`).
    Inav,
    /// PX4: ULog logs.
    Px4,
    /// ArduPilot: DataFlash logs.
    Ardupilot,
}

/// Lowest logging rate of ArduPilot's RATE/PID messages that supports a rate-loop identification,
/// Hz: the loop's dynamics reach 20–50 Hz, and ArduCopter's 10 Hz ATTITUDE_MED logging (the
/// default without ATTITUDE_FAST) or the 25–50 Hz of rate-capped logs cannot show them.
pub const ARDUPILOT_MIN_RATE_HZ: f64 = 100.0;

/// Below this logging rate, Hz, a PX4 log's rate-loop topics cannot show the loop's dynamics (20–50
/// Hz and up): PX4's default `SDLOG_PROFILE` logs them at 10–50 Hz, its high-rate bit at the loop's
/// rate.
pub const PX4_MIN_RATE_HZ: f64 = 100.0;

/// Whether a blackbox log's header names INAV.
pub fn is_inav(log: &Log) -> bool {
    let rev = log.setting("Firmware revision").unwrap_or_default().trim();
    let kind = log.setting("Firmware type").unwrap_or_default().trim();
    rev.get(..4).is_some_and(|p| p.eq_ignore_ascii_case("INAV")) || kind.eq_ignore_ascii_case("INAV")
}

impl FlightFirmware {
    /// Recognises the firmware from the log's format; CSV logs carry no firmware and are refused.
    pub fn of(log: &Log) -> Result<FlightFirmware> {
        match log.format {
            LogFormat::Blackbox if is_inav(log) => Ok(FlightFirmware::Inav),
            LogFormat::Blackbox => Ok(FlightFirmware::Betaflight),
            LogFormat::Ulog => Ok(FlightFirmware::Px4),
            LogFormat::Dataflash => Ok(FlightFirmware::Ardupilot),
            LogFormat::Csv => Err(invalid(format!(
                "{}: a CSV log names no firmware, so --axis cannot choose its channels; give --input, --output and --excitation",
                log.source
            ))),
        }
    }

    /// What to change so that a log too slow for the rate loop (below [`PX4_MIN_RATE_HZ`] /
    /// [`ARDUPILOT_MIN_RATE_HZ`]) is logged at the loop's rate next time; `None` where the firmware's
    /// rate-loop channels are not logged slower than the loop.
    pub fn slow_log_advice(self) -> Option<&'static str> {
        match self {
            FlightFirmware::Px4 => Some(
                "set SDLOG_PROFILE bit 2 (High rate: vehicle_angular_velocity, vehicle_torque_setpoint, vehicle_rates_setpoint and actuator_motors at the rate loop's rate) and fly again",
            ),
            FlightFirmware::Ardupilot => Some(
                "set LOG_BITMASK bits 0 (ATTITUDE_FAST) and 12 (PID) so RATE and PIDR/PIDP/PIDY are logged at the loop rate, and fly again",
            ),
            FlightFirmware::Betaflight | FlightFirmware::Inav => None,
        }
    }

    /// The lowest logging rate of the rate-loop channels that supports an identification, Hz
    /// (`None` where no limit is known).
    pub fn min_rate_hz(self) -> Option<f64> {
        match self {
            FlightFirmware::Px4 => Some(PX4_MIN_RATE_HZ),
            FlightFirmware::Ardupilot => Some(ARDUPILOT_MIN_RATE_HZ),
            FlightFirmware::Betaflight | FlightFirmware::Inav => None,
        }
    }

    /// "Betaflight", "INAV" or "PX4".
    pub fn name(self) -> &'static str {
        match self {
            FlightFirmware::Betaflight => "Betaflight",
            FlightFirmware::Inav => "INAV",
            FlightFirmware::Px4 => "PX4",
            FlightFirmware::Ardupilot => "ArduPilot",
        }
    }
}

/// The channels of one axis' rate loop, as column specs [`Log::series`] accepts, with their units.
#[derive(Debug, Clone, PartialEq)]
pub struct RateLoopChannels {
    /// Which firmware wrote the log.
    pub firmware: FlightFirmware,
    /// Which axis.
    pub axis: Axis,
    /// Plant input: the rate controller's output (Betaflight's PID sum `axisP[i]+axisI[i]+axisD[i]+axisF[i]`
    /// of the terms the log holds; PX4's `vehicle_torque_setpoint.xyz[i]` or, on older logs,
    /// `actuator_controls_0.control[i]`).
    pub input: String,
    /// Plant output: the gyro (`gyroADC[i]`; `vehicle_angular_velocity.xyz[i]` or, on older logs,
    /// `sensor_combined.gyro_rad[i]`).
    pub output: String,
    /// Instrument: the rate setpoint (`setpoint[i]`, or `rcCommand[i]` on logs without it;
    /// `vehicle_rates_setpoint.roll|pitch|yaw`).
    pub instrument: String,
    /// Unit of the input ("PID unit" for Betaflight, "normalized torque" for PX4).
    pub input_unit: &'static str,
    /// Unit of the output ("deg/s" for Betaflight, "rad/s" for PX4).
    pub output_unit: &'static str,
}

impl RateLoopChannels {
    /// Unit of a rate-loop model's gain K in K·e^(−Td·s)/(s·(τs+1)): output acceleration per input
    /// unit, e.g. "deg/s² per PID unit".
    pub fn gain_unit(&self) -> String {
        format!("{}² per {}", self.output_unit, self.input_unit)
    }

    /// Finds the channels of `axis` in `log`; errors name the channel the log lacks.
    pub fn find(log: &Log, axis: Axis) -> Result<RateLoopChannels> {
        let firmware = FlightFirmware::of(log)?;
        let i = axis.index();
        let has = |n: &str| log.channel(n).is_ok();
        let first = |names: &[String], what: &str| -> Result<String> {
            names.iter().find(|n| has(n)).cloned().ok_or_else(|| {
                invalid(format!(
                    "{}: no {what} channel for the {} axis (looked for {})",
                    log.source,
                    axis.name(),
                    names.join(", ")
                ))
            })
        };
        match firmware {
            FlightFirmware::Betaflight | FlightFirmware::Inav => {
                // Betaflight and INAV do not log a term that is always zero (axisD[2] when yaw D is 0).
                let terms: Vec<String> = ["axisP", "axisI", "axisD", "axisF"]
                    .iter()
                    .map(|t| format!("{t}[{i}]"))
                    .filter(|n| has(n))
                    .collect();
                if terms.is_empty() {
                    return Err(invalid(format!(
                        "{}: no PID terms (axisP[{i}], axisI[{i}], ...) for the {} axis",
                        log.source,
                        axis.name()
                    )));
                }
                Ok(RateLoopChannels {
                    firmware,
                    axis,
                    input: terms.join("+"),
                    output: first(&[format!("gyroADC[{i}]")], "gyro")?,
                    // INAV logs its rate target (deg/s) as `axisRate[i]`.
                    instrument: first(
                        &[
                            format!("setpoint[{i}]"),
                            format!("axisRate[{i}]"),
                            format!("rcCommand[{i}]"),
                        ],
                        "setpoint",
                    )?,
                    input_unit: "PID unit",
                    output_unit: "deg/s",
                })
            }
            FlightFirmware::Ardupilot => ardupilot_channels(log, axis),
            FlightFirmware::Px4 => Ok(RateLoopChannels {
                firmware,
                axis,
                input: first(
                    &[
                        format!("vehicle_torque_setpoint.xyz[{i}]"),
                        format!("actuator_controls_0.control[{i}]"),
                    ],
                    "rate-controller output",
                )?,
                output: first(
                    &[
                        format!("vehicle_angular_velocity.xyz[{i}]"),
                        format!("sensor_combined.gyro_rad[{i}]"),
                    ],
                    "gyro",
                )?,
                instrument: first(&[format!("vehicle_rates_setpoint.{}", axis.name())], "rate setpoint")?,
                input_unit: "normalized torque",
                output_unit: "rad/s",
            }),
        }
    }
}

/// ArduPilot's rate loop of `axis`: the rate controller's output `RATE.ROut` (or the PID message's
/// P+I+D+FF), the achieved rate `RATE.R` (deg/s) and the desired rate `RATE.RDes` (or `PIDR.Tar`);
/// refused, with the logging settings to change, when they are logged too slowly to identify.
fn ardupilot_channels(log: &Log, axis: Axis) -> Result<RateLoopChannels> {
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
        return Err(invalid(format!(
            "{}: no rate-controller output for the {} axis (looked for RATE.{x}Out and {pid}.P/I/D/FF): log RATE or {pid} (LOG_BITMASK bits 0 ATTITUDE_FAST and 12 PID)",
            log.source,
            axis.name()
        )));
    };
    let output = format!("RATE.{x}");
    if !has(&output) {
        return Err(invalid(format!(
            "{}: no RATE message (the achieved rate {output}): set LOG_BITMASK bit 0 (ATTITUDE_FAST) so ArduCopter logs RATE at its loop rate",
            log.source
        )));
    }
    let instrument = [format!("RATE.{x}Des"), format!("{pid}.Tar")]
        .into_iter()
        .find(|n| has(n))
        .ok_or_else(|| invalid(format!("{}: no desired rate RATE.{x}Des or {pid}.Tar", log.source)))?;
    let group = |name: &str| name.split(['.', '+']).next().unwrap_or_default().to_string();
    let slowest = [&input, &output, &instrument]
        .into_iter()
        .filter_map(|c| {
            let g = group(c);
            log.info().into_iter().find(|i| i.name == g).map(|i| (g, i.rate_hz))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1));
    if let Some((g, hz)) = slowest.filter(|(_, hz)| *hz < ARDUPILOT_MIN_RATE_HZ) {
        return Err(invalid(format!(
            "{}: {g} is logged at {hz:.0} Hz, too slow to identify the rate loop (at least {ARDUPILOT_MIN_RATE_HZ:.0} Hz): set LOG_BITMASK bits 0 (ATTITUDE_FAST) and 12 (PID) so RATE and PIDR/PIDP/PIDY are logged at the loop rate (SCHED_LOOP_RATE), and LOG_FILE_RATEMAX = 0 where the firmware has it, then fly again",
            log.source
        )));
    }
    Ok(RateLoopChannels {
        firmware: FlightFirmware::Ardupilot,
        axis,
        input,
        output,
        instrument,
        input_unit: "rate-controller output",
        output_unit: "deg/s",
    })
}

/// A stretch of a log, s (the log's own time axis).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Span {
    /// Start, s.
    pub from_s: f64,
    /// End, s.
    pub to_s: f64,
}

impl Span {
    /// to_s − from_s, s.
    pub fn len_s(&self) -> f64 {
        self.to_s - self.from_s
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

/// How airborne segments are found.
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
const MOTOR_EDGE: f64 = 0.01;
/// Betaflight's and PX4's usual gyro full scale is ±2000 deg/s; the last 2.5 % of it counts as saturated.
const GYRO_FULL_SCALE_DEG_S: f64 = 2000.0;
const GYRO_SATURATED: f64 = 0.975;
/// The exclusion reason of NaN samples in a tested channel (PX4: a stopped motor).
const NAN_REASON: &str = "no value (NaN, e.g. a stopped motor)";

impl AirborneCriteria {
    /// The firmware's default tests for `log` (only channels the log holds are tested):
    /// - Betaflight: throttle `rcCommand[3]` above 1050 (5 % of its 1000–2000 range), every `motor[k]`
    ///   inside the `motorOutput` range less 1 % at either end, every |`gyroADC[i]`| below 1950 deg/s;
    /// - PX4: `vehicle_land_detected.landed` false, collective thrust above 5 %
    ///   (`vehicle_rates_setpoint.thrust_body[2]` or `actuator_controls_0.control[3]`),
    ///   `actuator_motors.control[k]` inside (0.01, 0.99) (below: "motors at idle", above: "motor
    ///   saturation"), |gyro| below 34 rad/s;
    /// - 2 s shortest segment, 0.2 s margins, 1 s crash tail.
    pub fn for_log(log: &Log) -> Result<AirborneCriteria> {
        let firmware = FlightFirmware::of(log)?;
        let has = |n: &str| log.channel(n).is_ok();
        let mut limits = Vec::new();
        let mut push = |channel: String, lo: f64, hi: f64, reason: &'static str| {
            if has(&channel) {
                limits.push(Limit {
                    channel,
                    lo,
                    hi,
                    reason,
                });
            }
        };
        match firmware {
            FlightFirmware::Betaflight => {
                push("rcCommand[3]".into(), 1050.0, f64::INFINITY, "idle throttle");
                let (lo, hi) = log
                    .setting("motorOutput")
                    .and_then(|v| {
                        let mut it = v.split(',').map(|x| x.trim().parse::<f64>().ok());
                        Some((it.next()??, it.next()??))
                    })
                    .filter(|(a, b)| b > a)
                    .unwrap_or((1000.0, 2000.0));
                let edge = MOTOR_EDGE * (hi - lo);
                for k in 0..8 {
                    push(format!("motor[{k}]"), lo + edge, hi - edge, "motor saturation");
                }
                let g = GYRO_SATURATED * GYRO_FULL_SCALE_DEG_S;
                for i in 0..3 {
                    push(format!("gyroADC[{i}]"), -g, g, "gyro saturation");
                }
            }
            FlightFirmware::Inav => {
                let (thr_lo, motor) = inav_throttle_and_motor_range(log);
                push(
                    "rcCommand[3]".into(),
                    thr_lo + 0.05 * 1000.0,
                    f64::INFINITY,
                    "idle throttle",
                );
                let (lo, hi) = motor;
                let edge = MOTOR_EDGE * (hi - lo);
                for k in 0..8 {
                    push(format!("motor[{k}]"), lo + edge, hi - edge, "motor saturation");
                }
                let g = GYRO_SATURATED * GYRO_FULL_SCALE_DEG_S;
                for i in 0..3 {
                    push(format!("gyroADC[{i}]"), -g, g, "gyro saturation");
                }
            }
            FlightFirmware::Ardupilot => {
                // CTUN.ThO: the throttle output, 0..1.
                push("CTUN.ThO".into(), 0.05, f64::INFINITY, "idle throttle");
                let pwm = |k: &str, d: f64| {
                    log.setting(k)
                        .and_then(|v| v.trim().parse::<f64>().ok())
                        .filter(|v| *v > 0.0)
                        .unwrap_or(d)
                };
                let (lo, hi) = (pwm("MOT_PWM_MIN", 1000.0), pwm("MOT_PWM_MAX", 2000.0));
                let edge = MOTOR_EDGE * (hi - lo);
                for k in 1..=8 {
                    push(format!("RCOU.C{k}"), lo + edge, hi - edge, "motor saturation");
                }
                let g = GYRO_SATURATED * GYRO_FULL_SCALE_DEG_S;
                for x in ["R", "P", "Y"] {
                    push(format!("RATE.{x}"), -g, g, "gyro saturation");
                }
            }
            FlightFirmware::Px4 => {
                push("vehicle_land_detected.landed".into(), f64::NEG_INFINITY, 0.5, "landed");
                if has("vehicle_rates_setpoint.thrust_body[2]") {
                    // NED: upward thrust is negative z.
                    push(
                        "vehicle_rates_setpoint.thrust_body[2]".into(),
                        f64::NEG_INFINITY,
                        -0.05,
                        "idle throttle",
                    );
                } else {
                    push(
                        "actuator_controls_0.control[3]".into(),
                        0.05,
                        f64::INFINITY,
                        "idle throttle",
                    );
                }
                // Each end under its own name: motors at 0 throughout are a vehicle on the ground
                // (or a test stand), not a saturated mixer.
                for k in 0..8 {
                    let ch = format!("actuator_motors.control[{k}]");
                    push(ch.clone(), MOTOR_EDGE, f64::INFINITY, "motors at idle");
                    push(ch, f64::NEG_INFINITY, 1.0 - MOTOR_EDGE, "motor saturation");
                }
                let g = GYRO_SATURATED * GYRO_FULL_SCALE_DEG_S.to_radians();
                for i in 0..3 {
                    for n in [
                        format!("vehicle_angular_velocity.xyz[{i}]"),
                        format!("sensor_combined.gyro_rad[{i}]"),
                    ] {
                        push(n, -g, g, "gyro saturation");
                    }
                }
            }
        }
        Ok(AirborneCriteria {
            limits,
            min_len_s: 2.0,
            margin_s: 0.2,
            crash_tail_s: 1.0,
        })
    }
}

/// INAV's throttle floor (the low end of `rcCommand[3]`) and motor output range, from its header:
/// `motorOutput` (low, high), else `minthrottle`/`maxthrottle`, else 1000–2000. INAV's header range is
/// in its mixer's units, which with DShot and since INAV 7 (idle as `throttle_idle` percent) need not
/// be the units `motor[k]` is logged in: a range that holds fewer than half of the logged motor
/// samples is not the logged one, and the motors' own logged span is used instead (a motor pinned at
/// the largest value logged is still saturation), so a flight is never taken for saturated because
/// the header's scale differs.
pub fn inav_throttle_and_motor_range(log: &Log) -> (f64, (f64, f64)) {
    let one = |k: &str| {
        log.setting(k)
            .and_then(|v| v.split(',').next()?.trim().parse::<f64>().ok())
    };
    let pair = |k: &str| {
        log.setting(k).and_then(|v| {
            let mut it = v.split(',').map(|x| x.trim().parse::<f64>().ok());
            Some((it.next()??, it.next()??))
        })
    };
    let thr_lo = one("minthrottle")
        .filter(|v| (800.0..1500.0).contains(v))
        .unwrap_or(1000.0);
    let header = pair("motorOutput")
        .or_else(|| Some((one("minthrottle")?, one("maxthrottle")?)))
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
    let inside = values.iter().filter(|v| **v > header.0 && **v < header.1).count();
    if 2 * inside >= values.len() {
        return (thr_lo, header);
    }
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (thr_lo, (lo, hi))
}

/// The airborne segments and what was excluded.
#[derive(Debug, Clone, PartialEq)]
pub struct Airborne {
    /// The usable segments, in time order.
    pub segments: Vec<Span>,
    /// Seconds of the searched span excluded by each reason (a sample failing several tests counts
    /// for each), in the order of the criteria.
    pub excluded_s: Vec<(&'static str, f64)>,
    /// The searched span, s.
    pub searched: Span,
}

/// Finds the airborne segments of `log` within [from_s, to_s] on the time base of channel `base` (the
/// identification's output channel; other channels are held at their last sample, so a slow flag
/// such as PX4's 1 Hz `landed` applies until it changes).
///
/// # Errors
/// A base channel the log lacks, or no segment of at least `min_len_s` (the message says how much
/// each reason excluded).
pub fn airborne_segments(
    log: &Log,
    base: &str,
    c: &AirborneCriteria,
    from_s: Option<f64>,
    to_s: Option<f64>,
) -> Result<Airborne> {
    let (t_all, _) = log.series(base)?;
    let lo = from_s.unwrap_or(f64::NEG_INFINITY);
    let hi = to_s.unwrap_or(f64::INFINITY);
    let t: Vec<f64> = t_all.iter().copied().filter(|&x| x >= lo && x <= hi).collect();
    if t.len() < 2 {
        return Err(SysidError::NotEnoughData(format!(
            "{}: '{base}' has fewer than 2 samples in the selected span",
            log.source
        )));
    }
    let (t_first, t_last) = (t[0], t[t.len() - 1]);
    let log_end = t_all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut ok = vec![true; t.len()];
    let mut excluded: Vec<(&'static str, f64)> = Vec::new();
    let dt = (t_last - t_first) / (t.len() - 1) as f64;
    for l in &c.limits {
        let (tc, vc) = log.channel(&l.channel)?;
        let (tc, vc) = uniform::sorted(tc, vc);
        // PX4 logs NaN for the outputs a frame does not use (motors 7–12 of a hexarotor) and for
        // stopped motors: a channel that is NaN throughout is not tested, and NaN samples of a
        // used one are excluded under their own reason, not taken for saturation.
        if vc.iter().all(|v| v.is_nan()) {
            continue;
        }
        let held = hold_last(&tc, &vc, &t);
        let (mut bad, mut nan) = (0usize, 0usize);
        for (k, v) in held.iter().enumerate() {
            if v.is_nan() {
                ok[k] = false;
                nan += 1;
            } else if !(*v > l.lo && *v < l.hi) {
                ok[k] = false;
                bad += 1;
            }
        }
        for (reason, count) in [(l.reason, bad), (NAN_REASON, nan)] {
            if reason == NAN_REASON && count == 0 {
                continue;
            }
            match excluded.iter_mut().find(|(r, _)| *r == reason) {
                Some(e) => e.1 = e.1.max(count as f64 * dt),
                None => excluded.push((reason, count as f64 * dt)),
            }
        }
    }
    let mut segments = Vec::new();
    for r in runs(&ok) {
        let mut a = t[r.start] + c.margin_s;
        let mut b = t[r.end - 1] - c.margin_s;
        // The run reaches the last sample of the log: it stopped in flight.
        if r.end == t.len() && log_end - t_last <= 1.5 * dt {
            b -= c.crash_tail_s;
        }
        a = a.max(t_first);
        b = b.min(t_last);
        if b - a >= c.min_len_s {
            segments.push(Span { from_s: a, to_s: b });
        }
    }
    let searched = Span {
        from_s: t_first,
        to_s: t_last,
    };
    if segments.is_empty() {
        return Err(no_segment_error(log, c, (t_first, t_last), &excluded));
    }
    Ok(Airborne {
        segments,
        excluded_s: excluded,
        searched,
    })
}

/// The refusal of a span without an airborne segment: how much each reason excluded, and, when one
/// reason held for the whole span (motors idle or saturated, throttle at idle, landed), that there
/// was no flight to identify and the vehicle must fly.
fn no_segment_error(log: &Log, c: &AirborneCriteria, span: (f64, f64), excluded: &[(&'static str, f64)]) -> SysidError {
    let (t_first, t_last) = span;
    let why: Vec<String> = excluded
        .iter()
        .filter(|(_, s)| *s > 0.0)
        .map(|(r, s)| format!("{r} {s:.1} s"))
        .collect();
    let whole: Vec<&str> = excluded
        .iter()
        .filter(|(_, s)| *s >= 0.99 * (t_last - t_first) && t_last > t_first)
        .map(|(r, _)| *r)
        .collect();
    let advice = if whole.is_empty() {
        String::new()
    } else {
        format!(
            "; {} for the whole log, so it holds no flight (a test stand, or a vehicle that never took off?): fly and log again",
            whole.join(" and ")
        )
    };
    SysidError::NotEnoughData(format!(
        "{}: no airborne segment of {} s or more between {:.2} s and {:.2} s (excluded: {}){advice}",
        log.source,
        c.min_len_s,
        t_first,
        t_last,
        if why.is_empty() {
            "nothing; the span is too short".to_string()
        } else {
            why.join(", ")
        }
    ))
}

/// Maximal runs of `true`.
fn runs(mask: &[bool]) -> Vec<Range<usize>> {
    super::segments_where(mask, 1)
}

/// The value of (t, v) (t increasing) last sampled at or before each time of `at`; the first value
/// before the first sample.
fn hold_last(t: &[f64], v: &[f64], at: &[f64]) -> Vec<f64> {
    at.iter()
        .map(|&x| {
            let k = t.partition_point(|&s| s <= x);
            v[k.saturating_sub(1).min(v.len().saturating_sub(1))]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::logs::{Channel, Group};

    fn log(format: LogFormat, channels: Vec<(&str, Vec<f64>)>, dt: f64) -> Log {
        let n = channels[0].1.len();
        Log {
            source: "test".into(),
            format,
            groups: vec![Group {
                name: "main".into(),
                prefix: None,
                time_s: (0..n).map(|i| i as f64 * dt).collect(),
                channels: channels
                    .into_iter()
                    .map(|(name, values)| Channel {
                        name: name.into(),
                        values,
                    })
                    .collect(),
            }],
            notes: vec![],
            settings: vec![("motorOutput".into(), "158,2047".into())],
            clock_origin_s: 0.0,
        }
    }

    /// A 20 s synthetic Betaflight session at 100 Hz: idle until 2 s, flying with a motor pinned at its
    /// maximum from 8 to 9 s and the gyro saturated from 12 to 12.5 s, log ending in flight (crash).
    #[test]
    fn segments_exclude_idle_saturation_and_crash_tail() {
        let n = 2000;
        let t = |i: usize| i as f64 * 0.01;
        let thr: Vec<f64> = (0..n).map(|i| if t(i) < 2.0 { 1000.0 } else { 1400.0 }).collect();
        let m0: Vec<f64> = (0..n)
            .map(|i| if (8.0..9.0).contains(&t(i)) { 2047.0 } else { 900.0 })
            .collect();
        let g0: Vec<f64> = (0..n)
            .map(|i| if (12.0..12.5).contains(&t(i)) { 1999.0 } else { 100.0 })
            .collect();
        let l = log(
            LogFormat::Blackbox,
            vec![
                ("rcCommand[3]", thr),
                ("motor[0]", m0),
                ("gyroADC[0]", g0),
                ("axisP[0]", vec![0.0; n]),
                ("setpoint[0]", vec![0.0; n]),
            ],
            0.01,
        );
        let c = AirborneCriteria::for_log(&l).unwrap();
        let a = airborne_segments(&l, "gyroADC[0]", &c, None, None).unwrap();
        let got: Vec<(f64, f64)> = a.segments.iter().map(|s| (s.from_s, s.to_s)).collect();
        let want = [(2.2, 7.79), (9.2, 11.79), (12.7, 19.99 - 0.2 - 1.0)];
        assert_eq!(got.len(), want.len(), "{got:?}");
        for (g, w) in got.iter().zip(want) {
            assert!((g.0 - w.0).abs() < 1e-9 && (g.1 - w.1).abs() < 1e-9, "{got:?}");
        }
        let idle = a.excluded_s.iter().find(|(r, _)| *r == "idle throttle").unwrap().1;
        assert!((idle - 2.0).abs() < 0.02, "{idle}");
        // A span with no flight names what excluded it.
        let e = airborne_segments(&l, "gyroADC[0]", &c, Some(0.0), Some(1.9))
            .unwrap_err()
            .to_string();
        assert!(e.contains("idle throttle"), "{e}");
        // Channels: the PID sum of the terms logged, setpoint as instrument.
        let ch = RateLoopChannels::find(&l, Axis::Roll).unwrap();
        assert_eq!(ch.input, "axisP[0]");
        assert_eq!(ch.instrument, "setpoint[0]");
        assert_eq!(ch.gain_unit(), "deg/s² per PID unit");
        assert!(RateLoopChannels::find(&l, Axis::Pitch).is_err());
    }
}

#[cfg(test)]
mod px4_tests {
    use super::*;
    use crate::logs::{Channel, Group};

    /// A 5 s PX4 log at 100 Hz whose four motors sit at `motor` throughout (a test stand).
    fn stand(motor: f64) -> Log {
        let n = 500;
        let mut channels = vec![Channel {
            name: "vehicle_angular_velocity.xyz[0]".into(),
            values: vec![0.1; n],
        }];
        for k in 0..4 {
            channels.push(Channel {
                name: format!("actuator_motors.control[{k}]"),
                values: vec![motor; n],
            });
        }
        Log {
            source: "stand.ulg".into(),
            format: LogFormat::Ulog,
            groups: vec![Group {
                name: "all".into(),
                prefix: None,
                time_s: (0..n).map(|i| i as f64 * 0.01).collect(),
                channels,
            }],
            notes: vec![],
            settings: vec![],
            clock_origin_s: 0.0,
        }
    }

    #[test]
    fn motors_idle_or_saturated_throughout_are_refused_by_name_with_the_advice_to_fly() {
        for (m, reason) in [(0.0, "motors at idle"), (1.0, "motor saturation")] {
            let l = stand(m);
            let c = AirborneCriteria::for_log(&l).unwrap();
            let e = airborne_segments(&l, "vehicle_angular_velocity.xyz[0]", &c, None, None)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&format!("{reason} for the whole log")) && e.contains("fly"),
                "{e}"
            );
            let other = if m == 0.0 { "motor saturation" } else { "motors at idle" };
            assert!(!e.contains(other), "{e}");
        }
    }
}

#[cfg(test)]
mod inav_tests {
    use super::*;
    use crate::logs::{Channel, Group};

    /// A 10 s synthetic INAV session at 100 Hz whose header's `motorOutput` is not the scale
    /// `motor[k]` is logged in (as on INAV 9 with DShot): read as Betaflight, every sample would be
    /// "motor saturation"; read as INAV, only the motor pinned at its largest logged value is.
    fn inav_log(settings: Vec<(&str, &str)>) -> Log {
        let n = 1000;
        let t = |i: usize| i as f64 * 0.01;
        let m0: Vec<f64> = (0..n)
            .map(|i| {
                if (5.0..5.5).contains(&t(i)) {
                    1850.0
                } else {
                    1300.0 + 100.0 * (t(i)).sin()
                }
            })
            .collect();
        let channels = vec![
            ("rcCommand[3]", vec![1400.0; n]),
            ("motor[0]", m0),
            // One low sample sets the logged span's floor (1100) away from the sine's trough.
            (
                "motor[1]",
                (0..n).map(|i| if i == 0 { 1100.0 } else { 1350.0 }).collect(),
            ),
            ("gyroADC[0]", vec![10.0; n]),
            ("axisP[0]", vec![0.0; n]),
            ("axisI[0]", vec![0.0; n]),
            ("axisD[0]", vec![0.0; n]),
            ("axisRate[0]", vec![0.0; n]),
            ("rcCommand[0]", vec![0.0; n]),
        ];
        Log {
            source: "inav".into(),
            format: LogFormat::Blackbox,
            groups: vec![Group {
                name: "main".into(),
                prefix: None,
                time_s: (0..n).map(t).collect(),
                channels: channels
                    .into_iter()
                    .map(|(name, values)| Channel {
                        name: name.into(),
                        values,
                    })
                    .collect(),
            }],
            notes: vec![],
            settings: settings
                .into_iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
            clock_origin_s: 0.0,
        }
    }

    #[test]
    fn inav_is_recognised_and_its_motor_range_gives_no_false_saturation() {
        let l = inav_log(vec![
            ("Firmware type", "Cleanflight"),
            ("Firmware revision", "INAV 9.0.1 (d44f2cf6) IFLIGHT_BLITZ_F722"),
            ("motorOutput", "48,1000"),
            ("minthrottle", "1000"),
            ("maxthrottle", "2000"),
        ]);
        assert_eq!(FlightFirmware::of(&l).unwrap(), FlightFirmware::Inav);
        assert_eq!(FlightFirmware::Inav.name(), "INAV");
        let ch = RateLoopChannels::find(&l, Axis::Roll).unwrap();
        assert_eq!(ch.input, "axisP[0]+axisI[0]+axisD[0]");
        assert_eq!(ch.instrument, "axisRate[0]");
        assert_eq!(ch.output, "gyroADC[0]");
        let (_, range) = inav_throttle_and_motor_range(&l);
        assert_eq!(range, (1100.0, 1850.0));
        let c = AirborneCriteria::for_log(&l).unwrap();
        let a = airborne_segments(&l, "gyroADC[0]", &c, None, None).unwrap();
        let sat = a.excluded_s.iter().find(|(r, _)| *r == "motor saturation").unwrap().1;
        assert!((sat - 0.5).abs() < 0.05, "{sat}");
        assert_eq!(a.segments.len(), 2, "{:?}", a.segments);
        // The same data read as Betaflight (no INAV in the header) is saturated throughout.
        let mut bf = l.clone();
        bf.settings.retain(|(k, _)| !k.starts_with("Firmware"));
        assert_eq!(FlightFirmware::of(&bf).unwrap(), FlightFirmware::Betaflight);
        let c = AirborneCriteria::for_log(&bf).unwrap();
        assert!(airborne_segments(&bf, "gyroADC[0]", &c, None, None).is_err());
        // `Firmware type:INAV` alone also names INAV; a header range that holds the motors is used.
        let l2 = inav_log(vec![("Firmware type", "INAV"), ("motorOutput", "1000,2000")]);
        assert_eq!(FlightFirmware::of(&l2).unwrap(), FlightFirmware::Inav);
        assert_eq!(inav_throttle_and_motor_range(&l2).1, (1000.0, 2000.0));
    }

    #[test]
    fn inav_header_is_read_with_inav_keys() {
        use crate::logs::tuning::FirmwareTuning;
        let l = inav_log(vec![
            ("Firmware revision", "INAV 9.0.1 (d44f2cf6) IFLIGHT_BLITZ_F722"),
            ("rollPID", "44,75,25,60"),
            ("pitchPID", "46,80,26,60"),
            ("yawPID", "35,80,0,60"),
            ("gyro_main_lpf_hz", "110"),
            ("gyro_main_lpf_type", "PT1"),
            ("dterm_lpf_hz", "110"),
            ("dterm_lpf_type", "3"),
            ("yaw_lpf_hz", "30"),
            ("looptime", "1022"),
            ("motorOutput", "48,1000"),
        ]);
        let Some(FirmwareTuning::Inav(t)) = FirmwareTuning::from_log(&l) else {
            panic!("not read as INAV")
        };
        assert_eq!(t.version_major, Some(9));
        assert_eq!(
            (t.pid[0].p, t.pid[0].i, t.pid[0].d, t.pid[0].cd),
            (44.0, 75.0, 25.0, Some(60.0))
        );
        assert_eq!(t.pid.len(), 3);
        let g = t.gyro_lowpass.as_ref().unwrap();
        assert_eq!((g.kind.as_str(), g.cutoff_hz), ("PT1", 110.0));
        let d = t.dterm_lowpass.as_ref().unwrap();
        assert_eq!((d.kind.as_str(), d.cutoff_hz), ("PT3", 110.0));
        assert!((t.pid_rate_hz.unwrap() - 978.47).abs() < 0.01);
        assert_eq!(t.motor_output, Some((48.0, 1000.0)));
        assert_eq!(t.yaw_lpf_hz, Some(30.0));
    }
}
