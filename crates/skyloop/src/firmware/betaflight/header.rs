//! Betaflight's tuning as its blackbox header states it: PIDF gains, d_min, filters, dynamic notch,
//! RPM filter, rates, loop rates and TPA, in Betaflight's own units and names (3.x and 4.x keys).
//! A setting the header does not carry is `None`, never a guessed default.

use serde::Serialize;
use skyloop_sysid::logs::Log;

use crate::firmware::vocab::{header_notches, numbers, version_of, LowpassSetting, NotchSetting};

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

/// Betaflight's stick-to-rate curve (the configurator's Rates tab) of one axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Rates {
    /// RC rate (`rc_rates` 4.x, `rcRate`/`rcYawRate` 3.x), as the configurator shows it ×100.
    pub rc_rate: f64,
    /// Super rate (`rates`), ×100.
    pub super_rate: f64,
    /// RC expo (`rc_expo` 4.x, `rcExpo`/`rcYawExpo` 3.x), ×100.
    pub expo: f64,
    /// `rates_type` (0 BETAFLIGHT, 1 RACEFLIGHT, 2 KISS, 3 ACTUAL, 4 QUICK); `None` before 4.1
    /// (Betaflight's curve).
    pub rates_type: Option<f64>,
    /// `quickrates_rc_expo` (QUICK rates: expo on the stick, not on the super-rate term).
    pub quick_rc_expo: bool,
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
    pub gyro_lowpass: Option<LowpassSetting>,
    /// Gyro lowpass 2.
    pub gyro_lowpass2: Option<LowpassSetting>,
    /// D-term lowpass 1.
    pub dterm_lowpass: Option<LowpassSetting>,
    /// D-term lowpass 2.
    pub dterm_lowpass2: Option<LowpassSetting>,
    /// D-term static notch (`dterm_notch_hz`, `dterm_notch_cutoff`); `None` when off.
    pub dterm_notch: Option<NotchSetting>,
    /// Gyro static notches (`gyro_notch_hz`, `gyro_notch_cutoff`, up to two), on.
    pub gyro_notches: Vec<NotchSetting>,
    /// The stick-to-rate curve of roll, pitch and yaw (empty when the header has no rates).
    pub rates: Vec<Rates>,
    /// Firmware major version (3 or 4 for Betaflight), from `Firmware revision`.
    pub version_major: Option<u32>,
    /// `use_integrated_yaw` on (4.1–4.2): yaw's I is then not scaled ×2.5.
    pub integrated_yaw: bool,
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

/// Reads the tuning from a Betaflight (or EmuFlight) blackbox header.
pub fn from_log(log: &Log) -> BetaflightTuning {
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
    let lowpass = |ty: &str, hz: &str, dyn_hz: Option<&str>| -> Option<LowpassSetting> {
        let cutoff = one(hz)?;
        let dynamic = dyn_hz
            .map(list)
            .filter(|d| d.len() >= 2 && d[0] > 0.0 && d[1] > 0.0)
            .map(|d| (d[0], d[1]));
        (cutoff > 0.0 || dynamic.is_some()).then(|| LowpassSetting {
            kind: kind(one(ty)),
            cutoff_hz: cutoff,
            dynamic_hz: dynamic,
        })
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
        dterm_notch: header_notches(log, "dterm_notch_hz", "dterm_notch_cutoff")
            .first()
            .copied(),
        gyro_notches: header_notches(log, "gyro_notch_hz", "gyro_notch_cutoff"),
        rates: rates(log),
        version_major: version_of(log.setting("Firmware revision").unwrap_or_default()).map(|v| v.0),
        integrated_yaw: log.setting("use_integrated_yaw").is_some_and(|v| v.trim() == "1"),
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
    let quick_rc_expo = one("quickrates_rc_expo").is_some_and(|v| v != 0.0);
    let (rc, ex) = (list("rc_rates"), list("rc_expo"));
    if rc.len() >= 3 && ex.len() >= 3 && sup.len() >= 3 {
        return (0..3)
            .map(|i| Rates {
                rc_rate: rc[i],
                super_rate: sup[i],
                expo: ex[i],
                rates_type,
                quick_rc_expo,
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
                quick_rc_expo,
            })
            .collect(),
        _ => Vec::new(),
    }
}
