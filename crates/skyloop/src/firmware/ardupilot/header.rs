//! ArduPilot's rate-loop tuning as a DataFlash log's PARM and MSG messages state it
//! (`ATC_RAT_*`, `INS_GYRO_FILTER`, `SCHED_LOOP_RATE`, the harmonic notches), with the vehicle and
//! firmware version from its banner.

use serde::Serialize;
use skyloop_sysid::logs::{median_rate_hz, Log};

/// One axis of ArduPilot's rate PID, `ATC_RAT_<RLL|PIT|YAW>_{P,I,D,FF,FLTT,FLTE,FLTD}` (an
/// `AC_PID`; the model is in `skyloop::firmware::ardupilot`): gains in mixer command per rad/s
/// (P, FF), per rad (I), per rad/s² (D); filter cutoffs in Hz, 0 = off.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ArduPilotRatePid {
    /// `_P`.
    pub p: Option<f64>,
    /// `_I`.
    pub i: Option<f64>,
    /// `_D`.
    pub d: Option<f64>,
    /// `_FF`.
    pub ff: Option<f64>,
    /// `_FLTT`: target lowpass, Hz.
    pub fltt_hz: Option<f64>,
    /// `_FLTE`: error lowpass, Hz.
    pub flte_hz: Option<f64>,
    /// `_FLTD`: D-term lowpass, Hz.
    pub fltd_hz: Option<f64>,
    /// `ATC_ACCEL_{R,P,Y}_MAX`: the attitude controller's limit on the rate target's
    /// acceleration, centidegrees/s² (0 disables).
    pub accel_max_cdeg_s2: Option<f64>,
}

/// A named number (a parameter, or a message's logging rate in Hz).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NamedValue {
    /// Parameter or message name.
    pub name: String,
    /// Its value.
    pub value: f64,
}

/// ArduPilot's rate-loop tuning from a DataFlash log's PARM and MSG messages.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ArduPilotTuning {
    /// The firmware banner, e.g. "ArduCopter V4.5.7 (2a3dc4b7)" (empty when the log has none).
    pub firmware_revision: String,
    /// The vehicle firmware, e.g. "ArduCopter".
    pub vehicle: Option<String>,
    /// The version, e.g. "4.5.7".
    pub version: Option<String>,
    /// The frame, e.g. "QUAD/X".
    pub frame: Option<String>,
    /// Roll, pitch, yaw.
    pub rate: Vec<ArduPilotRatePid>,
    /// `INS_GYRO_FILTER`: gyro lowpass, Hz.
    pub gyro_filter_hz: Option<f64>,
    /// `SCHED_LOOP_RATE`: main loop, Hz.
    pub loop_rate_hz: Option<f64>,
    /// Every `INS_HNTCH_*` and `INS_HNTC2_*` parameter (harmonic notches 1 and 2), by name.
    pub harmonic_notch: Vec<NamedValue>,
    /// Logging rates, Hz (median interval of `TimeUS`), of the rate-loop messages the log holds:
    /// RATE, PIDR, PIDP, PIDY, IMU, GYR (every instance) and RCOU.
    pub log_rates_hz: Vec<NamedValue>,
}

/// Splits an ArduPilot banner "ArduCopter V4.5.7 (2a3dc4b7)" into ("ArduCopter", "4.5.7").
fn vehicle_version(banner: &str) -> (Option<String>, Option<String>) {
    let mut w = banner.split_whitespace();
    let vehicle = w.next().map(str::to_string);
    let version = w.next().and_then(|v| v.strip_prefix('V')).map(str::to_string);
    (vehicle, version.filter(|v| !v.is_empty()))
}

/// Reads the tuning from a DataFlash log's PARM and MSG messages.
pub fn from_log(log: &Log) -> ArduPilotTuning {
    let p = |k: &str| log.setting(k).and_then(|v| v.trim().parse::<f64>().ok());
    let rate = [("RLL", 'R'), ("PIT", 'P'), ("YAW", 'Y')]
        .iter()
        .map(|(a, x)| {
            let g = |k: &str| p(&format!("ATC_RAT_{a}_{k}"));
            ArduPilotRatePid {
                p: g("P"),
                i: g("I"),
                d: g("D"),
                ff: g("FF"),
                fltt_hz: g("FLTT"),
                flte_hz: g("FLTE"),
                fltd_hz: g("FLTD"),
                accel_max_cdeg_s2: p(&format!("ATC_ACCEL_{x}_MAX")),
            }
        })
        .collect();
    let mut notch: Vec<String> = log
        .settings
        .iter()
        .map(|(k, _)| k)
        .filter(|k| k.starts_with("INS_HNTCH_") || k.starts_with("INS_HNTC2_"))
        .cloned()
        .collect();
    notch.sort();
    notch.dedup();
    let harmonic_notch = notch
        .into_iter()
        .filter_map(|name| p(&name).map(|value| NamedValue { name, value }))
        .collect();
    let rate_message = |g: &str| {
        let base = g.split('[').next().unwrap_or(g);
        matches!(base, "RATE" | "PIDR" | "PIDP" | "PIDY" | "IMU" | "GYR" | "RCOU")
    };
    let log_rates_hz = log
        .groups
        .iter()
        .filter(|g| rate_message(&g.name))
        .map(|g| NamedValue {
            name: g.name.clone(),
            value: median_rate_hz(&g.time_s),
        })
        .collect();
    let firmware_revision = log.setting("Firmware revision").unwrap_or_default().to_string();
    let (vehicle, version) = vehicle_version(&firmware_revision);
    ArduPilotTuning {
        firmware_revision,
        vehicle,
        version,
        frame: log.setting("Frame").map(str::to_string),
        rate,
        gyro_filter_hz: p("INS_GYRO_FILTER"),
        loop_rate_hz: p("SCHED_LOOP_RATE"),
        harmonic_notch,
        log_rates_hz,
    }
}
