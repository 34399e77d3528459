//! The firmware's tuning recorded in a log, whichever firmware wrote it: each firmware's header
//! reader behind one enum, serialised as `log info --json` and the browser show it.

use serde::Serialize;
use skyloop_sysid::logs::Log;

use super::ardupilot::header::ArduPilotTuning;
use super::betaflight::header::BetaflightTuning;
use super::inav::header::InavTuning;
use super::px4::header::Px4Tuning;
use super::{ardupilot, betaflight, inav, px4, Firmware};

/// The firmware's tuning recorded in a log.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "firmware", rename_all = "lowercase")]
pub enum FirmwareTuning {
    /// A Betaflight (EmuFlight) blackbox header.
    Betaflight(Box<BetaflightTuning>),
    /// An INAV blackbox header.
    Inav(Box<InavTuning>),
    /// PX4 ULog parameters.
    Px4(Px4Tuning),
    /// ArduPilot DataFlash parameters.
    #[serde(rename = "ardupilot")]
    ArduPilot(Box<ArduPilotTuning>),
}

impl FirmwareTuning {
    /// Reads the tuning from a blackbox, ULog or DataFlash log; `None` for CSV.
    pub fn from_log(log: &Log) -> Option<FirmwareTuning> {
        Some(match Firmware::of_log(log)? {
            Firmware::Betaflight => FirmwareTuning::Betaflight(Box::new(betaflight::header::from_log(log))),
            Firmware::Inav => FirmwareTuning::Inav(Box::new(inav::header::from_log(log))),
            Firmware::Px4 => FirmwareTuning::Px4(px4::header::from_log(log)),
            Firmware::Ardupilot => FirmwareTuning::ArduPilot(Box::new(ardupilot::header::from_log(log))),
            Firmware::Generic => return None,
        })
    }
}
