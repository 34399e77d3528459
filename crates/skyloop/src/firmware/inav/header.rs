//! INAV's tuning as its blackbox header states it, with INAV's own keys (`gyro_main_lpf_hz` or
//! `gyro_lpf_hz`, `dterm_lpf_hz`, `looptime` as the PID period, `motorOutput`, ...).
//! A setting the header does not carry is `None`, never a guessed default.

use serde::Serialize;
use skyloop_sysid::logs::Log;

use crate::firmware::vocab::{header_notches, numbers, version_of, LowpassSetting, NotchSetting};

/// One axis of INAV's multicopter rate PID, in INAV's integer units (`mc_p_<axis>`, `mc_i_<axis>`,
/// `mc_d_<axis>`, `mc_cd_<axis>`; the firmware divides them by its `FP_PID_RATE_*_MULTIPLIER`s).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct InavPid {
    /// P gain.
    pub p: f64,
    /// I gain.
    pub i: f64,
    /// D gain.
    pub d: f64,
    /// Control derivative (`mc_cd_<axis>`, INAV's multicopter feedforward): the header's fourth
    /// PID value; `None` when the header gives three.
    pub cd: Option<f64>,
}

/// INAV's tuning from the blackbox header. INAV writes its own keys (`gyro_lpf_hz` or
/// `gyro_main_lpf_hz`, `dterm_lpf_hz`, `dterm_lpf_type`, `yaw_lpf_hz`, `looptime` as the PID loop
/// period in µs, `motorOutput`, `minthrottle`, `maxthrottle`), not Betaflight's.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InavTuning {
    /// `Firmware revision`, e.g. "INAV 9.0.1 (…) IFLIGHT_BLITZ_F722".
    pub firmware_revision: String,
    /// Major version, from the revision.
    pub version_major: Option<u32>,
    /// Roll, pitch, yaw.
    pub pid: Vec<InavPid>,
    /// Gyro main lowpass (`gyro_main_lpf_hz`/`gyro_lpf_hz`, type `gyro_main_lpf_type`/`gyro_lpf_type`).
    pub gyro_lowpass: Option<LowpassSetting>,
    /// D-term lowpass (`dterm_lpf_hz`, `dterm_lpf_type`).
    pub dterm_lowpass: Option<LowpassSetting>,
    /// Second D-term lowpass (`dterm_lpf2_hz`, `dterm_lpf2_type`), on older INAV.
    pub dterm_lowpass2: Option<LowpassSetting>,
    /// D-term static notch (`dterm_notch_hz`, `dterm_notch_cutoff`), older INAV.
    pub dterm_notch: Option<NotchSetting>,
    /// Gyro static notches (`gyro_notch_hz`, `gyro_notch_cutoff`).
    pub gyro_notches: Vec<NotchSetting>,
    /// Yaw P-term lowpass, Hz (`yaw_lpf_hz`; 0 off).
    pub yaw_lpf_hz: Option<f64>,
    /// Lowpass of the control derivative's setpoint difference, Hz (`mc_cd_lpf_hz`).
    pub cd_lpf_hz: Option<f64>,
    /// PID loop rate, Hz (1e6 / `looptime` µs: INAV writes the PID period there).
    pub pid_rate_hz: Option<f64>,
    /// `motorOutput` (low, high), in INAV's mixer units.
    pub motor_output: Option<(f64, f64)>,
    /// `minthrottle` (INAV 7+: the idle value), mixer units.
    pub min_throttle: Option<f64>,
    /// `maxthrottle`, mixer units.
    pub max_throttle: Option<f64>,
    /// TPA, percent (`tpa_rate`).
    pub tpa_rate_percent: Option<f64>,
    /// TPA breakpoint, µs (`tpa_breakpoint`).
    pub tpa_breakpoint_us: Option<f64>,
}

/// INAV's filter type (`filterType_e`: 0 PT1, 1 BIQUAD, 2 PT2, 3 PT3), by number or by name.
fn inav_filter_kind(v: Option<&str>) -> String {
    let v = v.unwrap_or("0").trim();
    match v.parse::<i64>() {
        Ok(0) => "PT1".into(),
        Ok(1) => "BIQUAD".into(),
        Ok(2) => "PT2".into(),
        Ok(3) => "PT3".into(),
        Ok(n) => n.to_string(),
        Err(_) => v.to_ascii_uppercase(),
    }
}

/// Reads the tuning from an INAV blackbox header.
pub fn from_log(log: &Log) -> InavTuning {
    let list = |k: &str| log.setting(k).map(numbers).unwrap_or_default();
    let one = |k: &str| list(k).first().copied();
    let first = |ks: &[&str]| ks.iter().find_map(|k| one(k));
    let lowpass = |hz: &[&str], ty: &[&str]| -> Option<LowpassSetting> {
        let f = first(hz).filter(|f| *f > 0.0)?;
        Some(LowpassSetting {
            kind: inav_filter_kind(ty.iter().find_map(|k| log.setting(k))),
            cutoff_hz: f,
            dynamic_hz: None,
        })
    };
    let pid = ["rollPID", "pitchPID", "yawPID"]
        .iter()
        .filter_map(|k| {
            let g = list(k);
            (g.len() >= 3).then(|| InavPid {
                p: g[0],
                i: g[1],
                d: g[2],
                cd: g.get(3).copied(),
            })
        })
        .collect();
    let rev = log.setting("Firmware revision").unwrap_or_default().to_string();
    InavTuning {
        version_major: version_of(&rev).map(|v| v.0),
        firmware_revision: rev,
        pid,
        gyro_lowpass: lowpass(
            &["gyro_main_lpf_hz", "gyro_lpf_hz"],
            &["gyro_main_lpf_type", "gyro_lpf_type"],
        ),
        dterm_lowpass: lowpass(&["dterm_lpf_hz"], &["dterm_lpf_type"]),
        dterm_lowpass2: lowpass(&["dterm_lpf2_hz"], &["dterm_lpf2_type"]),
        dterm_notch: header_notches(log, "dterm_notch_hz", "dterm_notch_cutoff")
            .first()
            .copied(),
        gyro_notches: header_notches(log, "gyro_notch_hz", "gyro_notch_cutoff"),
        yaw_lpf_hz: one("yaw_lpf_hz"),
        cd_lpf_hz: one("mc_cd_lpf_hz"),
        pid_rate_hz: one("looptime").filter(|&l| l > 0.0).map(|l| 1e6 / l),
        motor_output: {
            let m = list("motorOutput");
            (m.len() >= 2).then(|| (m[0], m[1]))
        },
        min_throttle: one("minthrottle"),
        max_throttle: one("maxthrottle"),
        tpa_rate_percent: one("tpa_rate"),
        tpa_breakpoint_us: one("tpa_breakpoint"),
    }
}

/// Whether a blackbox log's header names INAV (`Firmware revision:INAV …` since INAV writes
/// `Firmware type:Cleanflight`, or `Firmware type:INAV`).
pub fn writes(log: &Log) -> bool {
    let rev = log.setting("Firmware revision").unwrap_or_default().trim();
    let kind = log.setting("Firmware type").unwrap_or_default().trim();
    rev.get(..4).is_some_and(|p| p.eq_ignore_ascii_case("INAV")) || kind.eq_ignore_ascii_case("INAV")
}
