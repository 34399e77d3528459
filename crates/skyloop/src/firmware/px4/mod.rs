//! PX4's multicopter rate controller.
//!
//! Source: PX4 `src/modules/mc_rate_control/mc_rate_control_params.c`: "output =
//! MC_ROLLRATE_K·(MC_ROLLRATE_P·error + MC_ROLLRATE_I·error_integral + MC_ROLLRATE_D·
//! error_derivative)", K = 1 for the parallel form; the feedforward MC_ROLLRATE_FF multiplies the
//! rate setpoint and is not scaled by K. The rate controller (`RateControl`) differentiates the
//! measurement (D on the angular acceleration, lowpassed by `IMU_DGYRO_CUTOFF`, a 2nd-order
//! Butterworth), while P and I act on the error of the rate lowpassed by `IMU_GYRO_CUTOFF` (2nd
//! order Butterworth). Units: rad/s in, normalized torque (−1..1) out.
//!
//! So C_fb(s) = K·[(P + I/s)·F_gyro(s) + D·s·F_dgyro(s)] and C_r(s) = K·(P + I/s) + FF.

use super::filter_settings::{FilterSetting, FilterSettings, Knob, LineStyle};
use super::filters::{FilterChain, Path, Shape, Stage, StageKind};
use super::lowpass::{derivative_rolloff, Lowpass};
use crate::error::{Error, Result};
use crate::firmware::vocab::Axis;
use serde::Serialize;
use skyloop_lti::StateSpace;
use skyloop_robust::structured::blocks::Block;
pub mod flight;
pub mod header;

pub use header::Px4Tuning;

/// `MC_<AXIS>RATE_{K,P,I,D,FF}`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Gains {
    /// Global gain K.
    pub k: f64,
    /// P.
    pub p: f64,
    /// I.
    pub i: f64,
    /// D.
    pub d: f64,
    /// Feedforward on the rate setpoint.
    pub ff: f64,
}

impl Default for Gains {
    /// K = 1 (the parallel form), P = I = D = FF = 0.
    fn default() -> Self {
        Gains {
            k: 1.0,
            p: 0.0,
            i: 0.0,
            d: 0.0,
            ff: 0.0,
        }
    }
}

/// Filters and loop rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Filters {
    /// `IMU_GYRO_CUTOFF`, Hz (0 disables).
    pub gyro_cutoff_hz: f64,
    /// `IMU_DGYRO_CUTOFF`, Hz (0 disables).
    pub dgyro_cutoff_hz: f64,
    /// Rate loop rate (`IMU_GYRO_RATEMAX`), Hz.
    pub loop_hz: f64,
}

impl Default for Filters {
    /// PX4's defaults: IMU_GYRO_CUTOFF 40 Hz, IMU_DGYRO_CUTOFF 30 Hz, 400 Hz loop.
    fn default() -> Self {
        Filters {
            gyro_cutoff_hz: 40.0,
            dgyro_cutoff_hz: 30.0,
            loop_hz: 400.0,
        }
    }
}

/// The parameter names of an axis, in the order K, P, I, D, FF.
pub fn param_names(axis: Axis) -> [String; 5] {
    let a = axis.name().to_uppercase();
    ["K", "P", "I", "D", "FF"].map(|s| format!("MC_{a}RATE_{s}"))
}

/// The tunable structure (continuous gains K·P, K·I, K·D).
///
/// # Errors
/// Negative or non-finite cutoffs.
pub fn block(f: &Filters) -> Result<Block> {
    for (name, v) in [
        ("IMU_GYRO_CUTOFF", f.gyro_cutoff_hz),
        ("IMU_DGYRO_CUTOFF", f.dgyro_cutoff_hz),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(Error::Input(format!("{name} must be >= 0 Hz (0 disables), got {v}")));
        }
    }
    let pi_filter = if f.gyro_cutoff_hz > 0.0 {
        Some(Lowpass::Biquad(f.gyro_cutoff_hz).model()?)
    } else {
        None
    };
    let d = if f.dgyro_cutoff_hz > 0.0 {
        Lowpass::Biquad(f.dgyro_cutoff_hz)
    } else {
        derivative_rolloff(f.loop_hz)
    };
    Ok(Block::PidFiltered {
        pi_filter,
        d_filter: d.model()?,
    })
}

/// Continuous (Kp, Ki, Kd) = K·(P, I, D).
pub fn continuous(g: &Gains) -> (f64, f64, f64) {
    (g.k * g.p, g.k * g.i, g.k * g.d)
}

/// C_fb(s) of the gains.
///
/// # Errors
/// As [`block`].
pub fn feedback_controller(g: &Gains, f: &Filters) -> Result<StateSpace> {
    let (kp, ki, kd) = continuous(g);
    Ok(block(f)?.realize(&[kp, ki, kd])?)
}

/// C_r(s) = K·(P + I/s) + FF.
///
/// # Errors
/// Never for finite gains.
pub fn reference_path(g: &Gains) -> Result<StateSpace> {
    let (kp, ki, _) = continuous(g);
    Ok(StateSpace::from_rows(
        &[vec![0.0]],
        &[vec![1.0]],
        &[vec![ki]],
        &[vec![kp + g.ff]],
        0.0,
    )?)
}

/// PX4 `param set` lines.
pub fn cli_lines(g: &Gains, axis: Axis) -> Vec<String> {
    let n = param_names(axis);
    [g.k, g.p, g.i, g.d, g.ff]
        .iter()
        .zip(n.iter())
        // The shortest text that reads back as the value: the analysis used exactly these numbers.
        .map(|(v, name)| format!("param set {name} {}", super::round6(*v)))
        .collect()
}

/// Reads the flown tune of `axis` from PX4's parameters: the controller's filters (IMU_DGYRO_CUTOFF
/// on D; IMU_GYRO_CUTOFF is inside a plant identified from `vehicle_angular_velocity`) and loop
/// rate, the gains (None when a parameter is missing), and the filter lines for a report.
pub fn flown_from_header(p: &Px4Tuning, axis: Axis) -> (Filters, Option<Gains>, Vec<String>) {
    let mut lines = Vec::new();
    let loop_hz = p.gyro_rate_max_hz.filter(|&r| r > 0.0).unwrap_or(400.0);
    let dgyro = p.dgyro_cutoff_hz.unwrap_or(30.0);
    lines.push(format!("IMU_DGYRO_CUTOFF {dgyro} Hz (in the controller)"));
    if let Some(g) = p.gyro_cutoff_hz {
        lines.push(format!(
            "IMU_GYRO_CUTOFF {g} Hz (inside the identified plant: vehicle_angular_velocity is logged after it)"
        ));
    }
    lines.push(format!("rate loop {loop_hz} Hz"));
    let filters = Filters {
        gyro_cutoff_hz: 0.0,
        dgyro_cutoff_hz: dgyro,
        loop_hz,
    };
    let mut gains = None;
    if let Some(r) = p.rate.get(axis.index()) {
        if let (Some(pp), Some(ii), Some(dd)) = (r.p, r.i, r.d) {
            let g = Gains {
                k: r.k.unwrap_or(1.0),
                p: pp,
                i: ii,
                d: dd,
                ff: r.ff.unwrap_or(0.0),
            };
            gains = Some(g);
        }
    }
    (filters, gains, lines)
}

/// The lowpass cutoffs `tune --tune-filters` may move: `IMU_GYRO_CUTOFF` (a biquad on the gyro)
/// and `IMU_DGYRO_CUTOFF` (a biquad on the D term), where on.
pub fn filter_settings(p: &Px4Tuning) -> FilterSettings {
    let on = |v: Option<f64>| v.filter(|x| x.is_finite() && *x > 0.0);
    let mut settings = Vec::new();
    let mut gyro = Vec::new();
    if let Some(g) = on(p.gyro_cutoff_hz) {
        settings.push(FilterSetting {
            name: "IMU_GYRO_CUTOFF".into(),
            knob: Knob::Gyro,
            flown_hz: g,
            shared: true,
        });
        gyro.push(Lowpass::Biquad(g));
    }
    // The controller assumes PX4's 30 Hz default where the parameter is not logged; so does this.
    let d = p.dgyro_cutoff_hz.unwrap_or(30.0);
    if d > 0.0 {
        settings.push(FilterSetting {
            name: "IMU_DGYRO_CUTOFF".into(),
            knob: Knob::Dterm,
            flown_hz: d,
            shared: true,
        });
    }
    FilterSettings {
        settings,
        gyro,
        style: LineStyle::Param,
    }
}

/// PX4's filter chain from its parameters: `IMU_GYRO_CUTOFF` (a biquad on the gyro) and
/// `IMU_DGYRO_CUTOFF` (a biquad on the D term), at `IMU_GYRO_RATEMAX` (400 Hz when not set).
pub fn filter_chain(p: &Px4Tuning) -> (FilterChain, Vec<String>) {
    let mut notes = Vec::new();
    let loop_hz = p.gyro_rate_max_hz.filter(|&r| r > 0.0).unwrap_or_else(|| {
        notes.push("IMU_GYRO_RATEMAX not logged: a 400 Hz filter rate is assumed".into());
        400.0
    });
    let mut stages = Vec::new();
    for (hz, name, path) in [
        (p.gyro_cutoff_hz, "gyro_lpf1", Path::Gyro),
        (p.dgyro_cutoff_hz, "dterm_lpf1", Path::Dterm),
    ] {
        if let Some(hz) = hz.filter(|&h| h > 0.0 && h < 0.5 * loop_hz) {
            stages.push(Stage {
                name: name.into(),
                path,
                kind: StageKind::Lowpass {
                    shape: Shape::Biquad,
                    hz,
                },
            });
        }
    }
    notes.push("PX4's dynamic notches (IMU_GYRO_DNF_*) and static notch are not read".into());
    (FilterChain { loop_hz, stages }, notes)
}

/// The parameters as `log info` lists them, each under its own name ("not in the log" where the version has none: older PX4 has no MC_*RATE_K, i.e. K = 1).
pub fn header_lines(p: &Px4Tuning) -> Vec<String> {
    let mut out = Vec::new();
    // Each parameter under its own name; "not in the log" where the firmware version has
    // none (older PX4 has no MC_*RATE_K, i.e. K = 1).
    let named = |name: String, v: Option<f64>, unit: &str| match v {
        Some(x) => format!("{name} = {x}{unit}"),
        None => format!("{name} not in the log"),
    };
    out.push("tuning (PX4 parameters):".into());
    for (axis, g) in ["ROLL", "PITCH", "YAW"].iter().zip(&p.rate) {
        let items: Vec<String> = [("K", g.k), ("P", g.p), ("I", g.i), ("D", g.d), ("FF", g.ff)]
            .into_iter()
            .map(|(k, v)| named(format!("MC_{axis}RATE_{k}"), v, ""))
            .collect();
        out.push(format!("  {}", items.join(", ")));
    }
    out.push(format!(
        "  {}, {}, {}",
        named("IMU_GYRO_CUTOFF".into(), p.gyro_cutoff_hz, " Hz"),
        named("IMU_DGYRO_CUTOFF".into(), p.dgyro_cutoff_hz, " Hz"),
        named("IMU_GYRO_RATEMAX".into(), p.gyro_rate_max_hz, " Hz")
    ));
    out
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use skyloop_lti::c64;

    /// Well below the filters, C_fb = K·(P + I/s + D·s) with K multiplying all three.
    #[test]
    fn low_frequency_part_is_k_times_the_pid() {
        let g = Gains {
            k: 1.5,
            p: 0.15,
            i: 0.2,
            d: 0.003,
            ff: 0.0,
        };
        let c = feedback_controller(&g, &Filters::default()).unwrap();
        // The Butterworth filters lag by about √2·ω/ω_c, so the relative error grows like ω/ω_c.
        for w in [0.01, 0.05, 0.5] {
            let s = c64::new(0.0, w);
            let got = skyloop_lti::freqresp::evalfr(&c, s).unwrap()[(0, 0)];
            let want = 1.5 * (0.15 + 0.2 / s + 0.003 * s);
            let tol = 3.0 * w / (2.0 * std::f64::consts::PI * 30.0);
            assert!((got - want).norm() < tol * want.norm(), "w {w}: {got} vs {want}");
        }
        assert_eq!(param_names(Axis::Pitch)[1], "MC_PITCHRATE_P");
        assert_eq!(cli_lines(&g, Axis::Roll)[0], "param set MC_ROLLRATE_K 1.5");
    }
}
