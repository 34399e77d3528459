//! The flight controller's tuning as the log records it: Betaflight's header settings (PIDF gains,
//! filters, loop rate, TPA, d_min), PX4's rate-controller and IMU-filter parameters, and ArduPilot's
//! rate PIDs, gyro filter and harmonic notch (DataFlash PARM messages) with the vehicle and firmware
//! version from its MSG banner.
//!
//! Values are in the firmware's own units, as a pilot types them into the configurator or QGC; the
//! field docs name each unit. A setting the log does not carry (older firmware, a filter switched
//! off) is `None`, never a guessed default.

use serde::Serialize;

use super::flight::FlightFirmware;
use super::{median_rate_hz, Log};

/// One axis of Betaflight's PIDF controller, in Betaflight's integer gain units (the numbers of the
/// configurator's PID tab; the firmware multiplies them by PTERM_SCALE, ITERM_SCALE, DTERM_SCALE and
/// FTERM_SCALE).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BetaflightPidf {
    /// P gain.
    pub p: f64,
    /// I gain.
    pub i: f64,
    /// D gain (the maximum when d_min is active).
    pub d: f64,
    /// Feedforward gain (`feedforward_weight`/`ff_weight`, Betaflight 4.x); `None` on 3.x.
    pub f: Option<f64>,
    /// d_min: the D gain away from fast stick moves and prop wash (Betaflight 4.x); `None` when absent.
    pub d_min: Option<f64>,
}

/// A lowpass filter stage.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Lowpass {
    /// Filter type: "PT1", "BIQUAD", "PT2", "PT3", or the firmware's number when unknown.
    pub kind: String,
    /// Static cutoff, Hz.
    pub cutoff_hz: f64,
    /// Dynamic cutoff range (min, max), Hz, when the cutoff follows throttle.
    pub dynamic_hz: Option<(f64, f64)>,
}

/// A static notch (Betaflight `dterm_notch_hz` / `dterm_notch_cutoff`, `gyro_notch_hz` /
/// `gyro_notch_cutoff`): the centre and the lower −3 dB frequency, Hz.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Notch {
    /// Notch centre, Hz.
    pub center_hz: f64,
    /// Lower cutoff, Hz (below the centre; the width follows from it).
    pub cutoff_hz: f64,
}

/// Betaflight's stick-to-rate curve (the configurator's Rates tab) of one axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Rates {
    /// RC rate (`rc_rates` 4.x, `rcRate`/`rcYawRate` 3.x), as the configurator shows it ×100.
    pub rc_rate: f64,
    /// Super rate (`rates`), ×100.
    pub super_rate: f64,
    /// RC expo (`rc_expo` 4.x, `rcExpo`/`rcYawExpo` 3.x), ×100.
    pub expo: f64,
    /// `rates_type` (0: Betaflight's curve; others are not modelled); `None` before 4.1.
    pub rates_type: Option<f64>,
}

/// Betaflight's dynamic notch (gyro FFT tracking).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DynamicNotch {
    /// Lowest notch centre, Hz.
    pub min_hz: f64,
    /// Highest notch centre, Hz.
    pub max_hz: f64,
    /// Quality factor Q (the header's `dyn_notch_q` / 100).
    pub q: Option<f64>,
    /// Number of notches (`dyn_notch_count`, 4.3+).
    pub count: Option<f64>,
}

/// Betaflight's RPM filter (bidirectional DShot motor telemetry).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RpmFilter {
    /// Harmonics notched per motor.
    pub harmonics: f64,
    /// Quality factor Q (the header's `gyro_rpm_notch_q` / 100).
    pub q: Option<f64>,
    /// Lowest notch frequency, Hz.
    pub min_hz: Option<f64>,
}

/// Betaflight's (and its forks') tuning from the blackbox header.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BetaflightTuning {
    /// `Firmware revision`, e.g. "Betaflight 4.2.8 (101738d8e) STM32F7X2".
    pub firmware_revision: String,
    /// Roll, pitch, yaw.
    pub pidf: Vec<BetaflightPidf>,
    /// `d_min_gain` (how strongly D rises towards its maximum), Betaflight units.
    pub d_min_gain: Option<f64>,
    /// `d_min_advance`, Betaflight units.
    pub d_min_advance: Option<f64>,
    /// Gyro lowpass 1.
    pub gyro_lowpass: Option<Lowpass>,
    /// Gyro lowpass 2.
    pub gyro_lowpass2: Option<Lowpass>,
    /// D-term lowpass 1.
    pub dterm_lowpass: Option<Lowpass>,
    /// D-term lowpass 2.
    pub dterm_lowpass2: Option<Lowpass>,
    /// D-term static notch (`dterm_notch_hz`, `dterm_notch_cutoff`); `None` when off.
    pub dterm_notch: Option<Notch>,
    /// Gyro static notches (`gyro_notch_hz`, `gyro_notch_cutoff`, up to two), on.
    pub gyro_notches: Vec<Notch>,
    /// The stick-to-rate curve of roll, pitch and yaw (empty when the header has no rates).
    pub rates: Vec<Rates>,
    /// Firmware major version (3 or 4 for Betaflight), from `Firmware revision`.
    pub version_major: Option<u32>,
    /// Dynamic notch; `None` when absent or off.
    pub dynamic_notch: Option<DynamicNotch>,
    /// RPM filter; `None` when absent or off (0 harmonics).
    pub rpm_filter: Option<RpmFilter>,
    /// Gyro loop rate, Hz (1e6 / `looptime` µs).
    pub gyro_rate_hz: Option<f64>,
    /// PID loop rate, Hz (gyro rate / `pid_process_denom`).
    pub pid_rate_hz: Option<f64>,
    /// TPA: PID attenuation at full throttle, percent (`tpa_rate`; `dynThrPID` on 3.x).
    pub tpa_rate_percent: Option<f64>,
    /// TPA breakpoint: throttle above which the attenuation starts, µs (1000–2000).
    pub tpa_breakpoint_us: Option<f64>,
}

/// One axis of PX4's rate controller, parallel form with the overall gain K
/// (MC_{ROLL,PITCH,YAW}RATE_{K,P,I,D,FF}): torque = K·(P·e + I·∫e + D·ė_meas) + FF·setpoint, with
/// rates in rad/s and torque normalized to [−1, 1].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Px4RatePid {
    /// MC_*RATE_K (dimensionless; `None` on firmware before it existed).
    pub k: Option<f64>,
    /// MC_*RATE_P, per rad/s.
    pub p: Option<f64>,
    /// MC_*RATE_I, per rad.
    pub i: Option<f64>,
    /// MC_*RATE_D, per rad/s².
    pub d: Option<f64>,
    /// MC_*RATE_FF, per rad/s.
    pub ff: Option<f64>,
}

/// PX4's rate-loop tuning from the ULog parameters.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Px4Tuning {
    /// Roll, pitch, yaw.
    pub rate: Vec<Px4RatePid>,
    /// IMU_GYRO_CUTOFF: gyro lowpass cutoff, Hz.
    pub gyro_cutoff_hz: Option<f64>,
    /// IMU_DGYRO_CUTOFF: cutoff of the lowpass on the gyro derivative (the D term), Hz.
    pub dgyro_cutoff_hz: Option<f64>,
    /// IMU_GYRO_RATEMAX: the rate loop's maximum rate, Hz.
    pub gyro_rate_max_hz: Option<f64>,
}

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
    pub gyro_lowpass: Option<Lowpass>,
    /// D-term lowpass (`dterm_lpf_hz`, `dterm_lpf_type`).
    pub dterm_lowpass: Option<Lowpass>,
    /// Second D-term lowpass (`dterm_lpf2_hz`, `dterm_lpf2_type`), on older INAV.
    pub dterm_lowpass2: Option<Lowpass>,
    /// D-term static notch (`dterm_notch_hz`, `dterm_notch_cutoff`), older INAV.
    pub dterm_notch: Option<Notch>,
    /// Gyro static notches (`gyro_notch_hz`, `gyro_notch_cutoff`).
    pub gyro_notches: Vec<Notch>,
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

fn numbers(v: &str) -> Vec<f64> {
    v.split(',').filter_map(|x| x.trim().parse::<f64>().ok()).collect()
}

impl FirmwareTuning {
    /// Reads the tuning from a blackbox, ULog or DataFlash log; `None` for CSV.
    pub fn from_log(log: &Log) -> Option<FirmwareTuning> {
        match FlightFirmware::of(log).ok()? {
            FlightFirmware::Betaflight => Some(FirmwareTuning::Betaflight(Box::new(betaflight(log)))),
            FlightFirmware::Inav => Some(FirmwareTuning::Inav(Box::new(inav(log)))),
            FlightFirmware::Px4 => Some(FirmwareTuning::Px4(px4(log))),
            FlightFirmware::Ardupilot => Some(FirmwareTuning::ArduPilot(Box::new(ardupilot(log)))),
        }
    }
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

fn inav(log: &Log) -> InavTuning {
    let list = |k: &str| log.setting(k).map(numbers).unwrap_or_default();
    let one = |k: &str| list(k).first().copied();
    let first = |ks: &[&str]| ks.iter().find_map(|k| one(k));
    let lowpass = |hz: &[&str], ty: &[&str]| -> Option<Lowpass> {
        let f = first(hz).filter(|f| *f > 0.0)?;
        Some(Lowpass {
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
    let notches = |hz: &str, cut: &str| -> Vec<Notch> {
        list(hz)
            .into_iter()
            .zip(list(cut))
            .filter(|&(c, k)| c > 0.0 && k > 0.0 && k < c)
            .map(|(center_hz, cutoff_hz)| Notch { center_hz, cutoff_hz })
            .collect()
    };
    let rev = log.setting("Firmware revision").unwrap_or_default().to_string();
    InavTuning {
        version_major: version_major(&rev),
        firmware_revision: rev,
        pid,
        gyro_lowpass: lowpass(
            &["gyro_main_lpf_hz", "gyro_lpf_hz"],
            &["gyro_main_lpf_type", "gyro_lpf_type"],
        ),
        dterm_lowpass: lowpass(&["dterm_lpf_hz"], &["dterm_lpf_type"]),
        dterm_lowpass2: lowpass(&["dterm_lpf2_hz"], &["dterm_lpf2_type"]),
        dterm_notch: notches("dterm_notch_hz", "dterm_notch_cutoff").first().copied(),
        gyro_notches: notches("gyro_notch_hz", "gyro_notch_cutoff"),
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

fn betaflight(log: &Log) -> BetaflightTuning {
    let list = |k: &str| log.setting(k).map(numbers).unwrap_or_default();
    let one = |k: &str| list(k).first().copied();
    let ff = log
        .setting("feedforward_weight")
        .or_else(|| log.setting("ff_weight"))
        .map(numbers)
        .unwrap_or_default();
    let d_min = list("d_min");
    let pidf = ["rollPID", "pitchPID", "yawPID"]
        .iter()
        .enumerate()
        .filter_map(|(i, k)| {
            let g = list(k);
            (g.len() >= 3).then(|| BetaflightPidf {
                p: g[0],
                i: g[1],
                d: g[2],
                f: ff.get(i).copied(),
                d_min: d_min.get(i).copied(),
            })
        })
        .collect();
    let kind = |t: Option<f64>| match t.map(|t| t as i64) {
        Some(0) | None => "PT1".to_string(),
        Some(1) => "BIQUAD".to_string(),
        Some(2) => "PT2".to_string(),
        Some(3) => "PT3".to_string(),
        Some(n) => n.to_string(),
    };
    // A stage is on when its static or its dynamic cutoff is non-zero.
    let lowpass = |ty: &str, hz: &str, dyn_hz: Option<&str>| -> Option<Lowpass> {
        let cutoff = one(hz)?;
        let dynamic = dyn_hz
            .map(list)
            .filter(|d| d.len() >= 2 && d[0] > 0.0 && d[1] > 0.0)
            .map(|d| (d[0], d[1]));
        (cutoff > 0.0 || dynamic.is_some()).then(|| Lowpass {
            kind: kind(one(ty)),
            cutoff_hz: cutoff,
            dynamic_hz: dynamic,
        })
    };
    // A notch is on when its centre is above zero and its cutoff below the centre.
    let notches = |hz: &str, cut: &str| -> Vec<Notch> {
        list(hz)
            .into_iter()
            .zip(list(cut))
            .filter(|&(c, k)| c > 0.0 && k > 0.0 && k < c)
            .map(|(center_hz, cutoff_hz)| Notch { center_hz, cutoff_hz })
            .collect()
    };
    let gyro_rate_hz = one("looptime").filter(|&l| l > 0.0).map(|l| 1e6 / l);
    let dynamic_notch = match (one("dyn_notch_min_hz"), one("dyn_notch_max_hz")) {
        (Some(lo), Some(hi)) if hi > 0.0 && one("dyn_notch_count") != Some(0.0) => Some(DynamicNotch {
            min_hz: lo,
            max_hz: hi,
            q: one("dyn_notch_q").map(|q| q / 100.0),
            count: one("dyn_notch_count"),
        }),
        _ => None,
    };
    let rpm_filter = one("gyro_rpm_notch_harmonics")
        .filter(|&h| h > 0.0 && one("dshot_bidir") != Some(0.0))
        .map(|h| RpmFilter {
            harmonics: h,
            q: one("gyro_rpm_notch_q").map(|q| q / 100.0),
            min_hz: one("gyro_rpm_notch_min"),
        });
    BetaflightTuning {
        firmware_revision: log.setting("Firmware revision").unwrap_or_default().to_string(),
        pidf,
        d_min_gain: one("d_min_gain"),
        d_min_advance: one("d_min_advance"),
        gyro_lowpass: lowpass("gyro_lowpass_type", "gyro_lowpass_hz", Some("gyro_lowpass_dyn_hz")),
        gyro_lowpass2: lowpass("gyro_lowpass2_type", "gyro_lowpass2_hz", None),
        // Betaflight 3.x names the D-term lowpass `dterm_lpf_hz` (type in `dterm_filter_type`).
        dterm_lowpass: lowpass("dterm_filter_type", "dterm_lowpass_hz", Some("dterm_lowpass_dyn_hz"))
            .or_else(|| lowpass("dterm_filter_type", "dterm_lpf_hz", None)),
        dterm_lowpass2: lowpass("dterm_filter2_type", "dterm_lowpass2_hz", None),
        dynamic_notch,
        rpm_filter,
        gyro_rate_hz,
        pid_rate_hz: gyro_rate_hz.map(|g| g / one("pid_process_denom").filter(|&d| d >= 1.0).unwrap_or(1.0)),
        tpa_rate_percent: one("tpa_rate").or_else(|| one("dynThrPID")),
        dterm_notch: notches("dterm_notch_hz", "dterm_notch_cutoff").first().copied(),
        gyro_notches: notches("gyro_notch_hz", "gyro_notch_cutoff"),
        rates: rates(log),
        version_major: version_major(log.setting("Firmware revision").unwrap_or_default()),
        tpa_breakpoint_us: one("tpa_breakpoint"),
    }
}

/// The rate curves: 4.x `rc_rates`, `rc_expo`, `rates` (three values each); 3.x `rcRate`,
/// `rcExpo` (roll and pitch), `rcYawRate`, `rcYawExpo`, `rates`.
fn rates(log: &Log) -> Vec<Rates> {
    let list = |k: &str| log.setting(k).map(numbers).unwrap_or_default();
    let one = |k: &str| list(k).first().copied();
    let sup = list("rates");
    let rates_type = one("rates_type");
    let (rc, ex) = (list("rc_rates"), list("rc_expo"));
    if rc.len() >= 3 && ex.len() >= 3 && sup.len() >= 3 {
        return (0..3)
            .map(|i| Rates {
                rc_rate: rc[i],
                super_rate: sup[i],
                expo: ex[i],
                rates_type,
            })
            .collect();
    }
    match (one("rcRate"), one("rcExpo"), sup.len() >= 3) {
        (Some(r), Some(e), true) => (0..3)
            .map(|i| Rates {
                rc_rate: if i == 2 { one("rcYawRate").unwrap_or(r) } else { r },
                super_rate: sup[i],
                expo: if i == 2 { one("rcYawExpo").unwrap_or(0.0) } else { e },
                rates_type,
            })
            .collect(),
        _ => Vec::new(),
    }
}

/// The major version in a revision such as "Betaflight 3.1.5 (4646f9d) OMNIBUSF4".
fn version_major(rev: &str) -> Option<u32> {
    rev.split_whitespace()
        .find_map(|w| w.split('.').next().filter(|_| w.contains('.'))?.parse().ok())
}

fn px4(log: &Log) -> Px4Tuning {
    let p = |k: &str| log.setting(k).and_then(|v| v.trim().parse::<f64>().ok());
    let rate = ["ROLL", "PITCH", "YAW"]
        .iter()
        .map(|a| Px4RatePid {
            k: p(&format!("MC_{a}RATE_K")),
            p: p(&format!("MC_{a}RATE_P")),
            i: p(&format!("MC_{a}RATE_I")),
            d: p(&format!("MC_{a}RATE_D")),
            ff: p(&format!("MC_{a}RATE_FF")),
        })
        .collect();
    Px4Tuning {
        rate,
        gyro_cutoff_hz: p("IMU_GYRO_CUTOFF"),
        dgyro_cutoff_hz: p("IMU_DGYRO_CUTOFF"),
        gyro_rate_max_hz: p("IMU_GYRO_RATEMAX"),
    }
}

/// Splits an ArduPilot banner "ArduCopter V4.5.7 (2a3dc4b7)" into ("ArduCopter", "4.5.7").
fn vehicle_version(banner: &str) -> (Option<String>, Option<String>) {
    let mut w = banner.split_whitespace();
    let vehicle = w.next().map(str::to_string);
    let version = w.next().and_then(|v| v.strip_prefix('V')).map(str::to_string);
    (vehicle, version.filter(|v| !v.is_empty()))
}

fn ardupilot(log: &Log) -> ArduPilotTuning {
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
