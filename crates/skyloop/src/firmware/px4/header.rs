//! PX4's rate-loop tuning as the ULog's parameters state it (MC_*RATE_*, IMU_GYRO_CUTOFF,
//! IMU_DGYRO_CUTOFF, IMU_GYRO_RATEMAX).

use serde::Serialize;
use skyloop_sysid::logs::Log;

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

/// Reads the tuning from a ULog's parameters.
pub fn from_log(log: &Log) -> Px4Tuning {
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
