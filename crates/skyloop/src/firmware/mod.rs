//! Firmware rate-controller structures and their gain mappings: the gains a pilot types into the
//! flight controller ↔ the loop's feedback controller C_fb(s) (y → u, what margins use) and the
//! reference path, in the plant's units.
//!
//! - [`betaflight`]: Betaflight's PIDF (P and I on the error, D on the measurement, F on the
//!   setpoint derivative) with its scale factors from `pid.h` and the gyro / D-term lowpass chain.
//! - [`inav`]: INAV's multicopter rate PID (P and I on the error, D on the measurement through the
//!   D-term lowpass, the control derivative `mc_cd` on the target) with its `FP_PID_RATE_*`
//!   multipliers.
//! - [`px4`]: PX4's multicopter rate PID `MC_{ROLL,PITCH,YAW}RATE_{K,P,I,D,FF}` (parallel form,
//!   K scales P, I and D), D on the measurement through `IMU_DGYRO_CUTOFF`, P and I through
//!   `IMU_GYRO_CUTOFF`.
//!
//! Both are continuous models of discrete firmware: the filters are their continuous prototypes at
//! the configured (for dynamic filters: the given operating-point) cutoff, and the loop's sample
//! and hold is a delay of half a loop period added to the plant (`hold_delay_s`); the discrete
//! controller at the loop rate is C_fb mapped by Tustin ([`discrete`]).

pub mod ardupilot;
pub mod betaflight;
pub mod channels;
pub mod excitation;
pub mod filter_settings;
pub mod filters;
pub mod flown;
pub mod inav;
mod knobs;
pub mod lowpass;
mod numbers;
mod optimum;
pub mod px4;
pub mod rate_gains;
pub mod sampling;
pub mod tuning;
pub mod vocab;

pub use lowpass::*;
pub(crate) use numbers::*;
pub use sampling::*;
pub use tuning::FirmwareTuning;
pub use vocab::{AirborneCriteria, Axis, Limit, RateLoopChannels};

use crate::error::{Error, Result};
use skyloop_sysid::logs::{Log, LogFormat};
use std::f64::consts::PI;

/// The flight-control firmware whose controller structure, gains and pasteable lines a tune uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Firmware {
    /// Betaflight PIDF (integers p, i, d, f).
    Betaflight,
    /// INAV multicopter rate PID (integers mc_p, mc_i, mc_d, mc_cd).
    Inav,
    /// PX4 multicopter rate PID (MC_*RATE_*).
    Px4,
    /// ArduPilot multicopter rate PID (ATC_RAT_*).
    Ardupilot,
    /// C = kp + ki/s + kd·s/(tf·s + 1) in the plant's units.
    Generic,
}

impl Firmware {
    /// Parses "betaflight", "inav", "px4", "ardupilot" or "generic".
    ///
    /// # Errors
    /// Any other text.
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "betaflight" => Ok(Firmware::Betaflight),
            "inav" => Ok(Firmware::Inav),
            "px4" => Ok(Firmware::Px4),
            "ardupilot" => Ok(Firmware::Ardupilot),
            "generic" => Ok(Firmware::Generic),
            _ => Err(Error::Input(format!(
                "--firmware must be betaflight, inav, px4, ardupilot or generic, got `{s}`"
            ))),
        }
    }

    /// The name `--firmware` takes.
    pub fn name(&self) -> &'static str {
        match self {
            Firmware::Betaflight => "betaflight",
            Firmware::Inav => "inav",
            Firmware::Px4 => "px4",
            Firmware::Ardupilot => "ardupilot",
            Firmware::Generic => "generic",
        }
    }

    /// The name a pilot knows it by ("Betaflight", "PX4", ...).
    pub fn display_name(&self) -> &'static str {
        match self {
            Firmware::Betaflight => "Betaflight",
            Firmware::Inav => "INAV",
            Firmware::Px4 => "PX4",
            Firmware::Ardupilot => "ArduPilot",
            Firmware::Generic => "generic",
        }
    }

    /// The firmware that wrote `log` (None: a CSV file, which names none): ULog is PX4, DataFlash
    /// ArduPilot, a blackbox log INAV when its header names INAV and Betaflight (or a fork that
    /// logs its layout, such as EmuFlight) otherwise.
    pub fn of_log(log: &Log) -> Option<Firmware> {
        match log.format {
            LogFormat::Blackbox if inav::header::writes(log) => Some(Firmware::Inav),
            LogFormat::Blackbox => Some(Firmware::Betaflight),
            LogFormat::Ulog => Some(Firmware::Px4),
            LogFormat::Dataflash => Some(Firmware::Ardupilot),
            LogFormat::Csv => None,
        }
    }

    /// [`Firmware::of_log`], or the refusal of a CSV log, which names no firmware.
    ///
    /// # Errors
    /// A CSV log.
    pub fn of_log_or_refuse(log: &Log) -> Result<Firmware> {
        Firmware::of_log(log).ok_or_else(|| {
            Error::Input(format!(
                "{}: a CSV log names no firmware, so --axis cannot choose its channels; give --input, --output and --excitation",
                log.source
            ))
        })
    }

    /// The rate loop of `axis` in `log` as this firmware logs it.
    ///
    /// # Errors
    /// A log without the axis' channels, or (PX4, ArduPilot) one that logs them too slowly; the
    /// message names the channels and what to set.
    pub fn rate_loop_channels(&self, log: &Log, axis: Axis) -> Result<RateLoopChannels> {
        match self {
            Firmware::Betaflight => betaflight::flight::rate_loop_channels(log, axis),
            Firmware::Inav => inav::flight::rate_loop_channels(log, axis),
            Firmware::Px4 => px4::flight::rate_loop_channels(log, axis),
            Firmware::Ardupilot => ardupilot::flight::rate_loop_channels(log, axis),
            Firmware::Generic => Err(Error::Input(format!(
                "{}: the generic firmware logs no rate loop; give --input, --output and --excitation",
                log.source
            ))),
        }
    }

    /// This firmware's tests of where `log` is flying.
    pub fn airborne_criteria(&self, log: &Log) -> AirborneCriteria {
        match self {
            Firmware::Betaflight => betaflight::flight::airborne_criteria(log),
            Firmware::Inav => inav::flight::airborne_criteria(log),
            Firmware::Px4 => px4::flight::airborne_criteria(log),
            Firmware::Ardupilot => ardupilot::flight::airborne_criteria(log),
            Firmware::Generic => AirborneCriteria::with_limits(log, Vec::new()),
        }
    }

    /// The lowest logging rate of the rate-loop channels that supports an identification, Hz, and
    /// what to set to log faster (`None` where the firmware logs its rate loop at the loop rate).
    pub fn slow_log(&self) -> Option<(f64, &'static str)> {
        match self {
            Firmware::Px4 => Some((px4::flight::MIN_RATE_HZ, px4::flight::SLOW_LOG_ADVICE)),
            Firmware::Ardupilot => Some((ardupilot::flight::MIN_RATE_HZ, ardupilot::flight::SLOW_LOG_ADVICE)),
            _ => None,
        }
    }

    /// The units of its logged rate loop, for the 6-DOF check: (gyro unit in rad/s, largest
    /// controller output), None for a firmware whose log units are not known.
    pub fn flight_units(&self) -> Option<(f64, f64)> {
        match self {
            // gyroADC in deg/s; the PID sum is limited to ±500 (pidsum_limit; INAV's too).
            Firmware::Betaflight | Firmware::Inav => Some((PI / 180.0, 500.0)),
            // rad/s; normalized torque in [−1, 1].
            Firmware::Px4 => Some((1.0, 1.0)),
            // RATE.R in deg/s; RATE.ROut, the mixer's command, in [−1, 1].
            Firmware::Ardupilot => Some((ardupilot::LOG_RATE_UNIT_RAD_S, 1.0)),
            Firmware::Generic => None,
        }
    }
}

/// Reads a log (blackbox `session` counted from 1; None: the longest) and prepares it for its
/// firmware ([`prepare_log`]); returns it with the notes of what was derived.
///
/// # Errors
/// An unreadable or unrecognised file.
pub fn open_log(path: &std::path::Path, session: Option<usize>) -> Result<(skyloop_sysid::logs::Log, Vec<String>)> {
    let mut log = skyloop_sysid::logs::Log::open(
        path,
        &skyloop_sysid::logs::OpenOptions {
            session,
            ..Default::default()
        },
    )?;
    let notes = prepare_log(&mut log);
    Ok((log, notes))
}

/// [`open_log`] on a log's bytes already in memory (a browser's dropped file); `name` names it in
/// messages.
///
/// # Errors
/// A file that is not a log the readers know, or a session that is not in it.
pub fn open_log_bytes(
    bytes: &[u8],
    name: &str,
    session: Option<usize>,
) -> Result<(skyloop_sysid::logs::Log, Vec<String>)> {
    let mut log = skyloop_sysid::logs::Log::from_bytes(
        bytes,
        name,
        &skyloop_sysid::logs::OpenOptions {
            session,
            ..Default::default()
        },
    )?;
    let notes = prepare_log(&mut log);
    Ok((log, notes))
}

/// Interprets a freshly read log for the firmware that wrote it: channels the firmware computes but
/// does not record are derived (Betaflight 3.x: the setpoint from rcCommand through the rate
/// curve). Returns notes saying what was derived.
pub fn prepare_log(log: &mut skyloop_sysid::logs::Log) -> Vec<String> {
    let mut notes = Vec::new();
    if let Some(FirmwareTuning::Betaflight(b)) = FirmwareTuning::from_log(log) {
        notes.extend(betaflight::add_setpoint_from_rc(log, &b.rates));
    }
    notes
}

/// The tuning a log's header states, as `log info` lists it, in the firmware's own names.
pub fn header_lines(t: &FirmwareTuning) -> Vec<String> {
    match t {
        FirmwareTuning::Betaflight(b) => betaflight::header_lines(b),
        FirmwareTuning::Inav(t) => inav::header_lines(t),
        FirmwareTuning::Px4(p) => px4::header_lines(p),
        FirmwareTuning::ArduPilot(a) => ardupilot::header_lines(a),
    }
}

/// The filter chain the log's header (or parameters) state, with notes on what is assumed; None for
/// a log that states no filters (CSV).
pub fn flown_chain(log: &Log) -> Option<(filters::FilterChain, Vec<String>)> {
    match FirmwareTuning::from_log(log)? {
        FirmwareTuning::Betaflight(b) => Some(betaflight::filter_chain(&b, log)),
        FirmwareTuning::Inav(t) => Some(inav::filter_chain(&t)),
        FirmwareTuning::Px4(p) => Some(px4::filter_chain(&p)),
        FirmwareTuning::ArduPilot(a) => Some(ardupilot::filter_chain(&a)),
    }
}

/// The log's channels of the gyro before the firmware's filters, when its debug mode logs them.
pub fn raw_gyro_tap(log: &Log) -> Option<filters::RawGyroTap> {
    match FirmwareTuning::from_log(log)? {
        FirmwareTuning::Betaflight(b) => betaflight::raw_gyro_tap(&b, log),
        _ => None,
    }
}

/// The rate loop of `axis` as the firmware that wrote `log` logs it
/// ([`Firmware::rate_loop_channels`]).
///
/// # Errors
/// A CSV log (it names no firmware), or a log without the axis' channels.
pub fn rate_loop_channels(log: &Log, axis: Axis) -> Result<RateLoopChannels> {
    Firmware::of_log_or_refuse(log)?.rate_loop_channels(log, axis)
}

/// The airborne tests of the firmware that wrote `log` ([`Firmware::airborne_criteria`]).
///
/// # Errors
/// A CSV log (it names no firmware).
pub fn airborne_criteria(log: &Log) -> Result<AirborneCriteria> {
    Ok(Firmware::of_log_or_refuse(log)?.airborne_criteria(log))
}
