//! Betaflight's rate PIDF and its scale factors.
//!
//! Source: Betaflight `src/main/flight/pid.h` (`PTERM_SCALE 0.032029f`, `ITERM_SCALE 0.244381f`,
//! `DTERM_SCALE 0.000529f`, `FEEDFORWARD_SCALE 0.013754f`) and `pid_init.c`
//! (`Kp = PTERM_SCALE·P`, `Ki = ITERM_SCALE·I`, `Kd = DTERM_SCALE·D`,
//! `Kf = FEEDFORWARD_SCALE·F/100`, yaw `Ki ×2.5` unless integrated yaw); `pid.c` computes, per loop
//! at `pidFrequency`, P = Kp·e and I += Ki·e·dT on the error e = setpoint − gyro (deg/s, after the
//! gyro lowpass chain), D = −Kd·Δgyro_dterm·pidFrequency on the measurement after the D-term
//! lowpass chain, F = Kf·Δsetpoint·pidFrequency.
//!
//! In the plant's units (input: Betaflight's PID sum P + I + D + F; output: gyro rate in deg/s)
//! the feedback controller y → u is therefore
//! C_fb(s) = (Kp + Ki/s)·F_gyro(s) + Kd·s·F_gyro(s)·F_dterm(s), and the reference path
//! C_r(s) = Kp + Ki/s + Kf·s/(T·s + 1) with T the loop period (the backward difference's roll-off).
//! Not modelled: TPA, anti-gravity, I-term relax, d_min's dynamic D (a flown tune with d_min is
//! analysed at D = d_min by [`crate::tune::log`]), feedforward smoothing.

use super::filter_settings::{from_header_stages, FilterSettings, HeaderStage, Knob};
use super::filters::{
    static_notches, FilterChain, Path, RawGyroTap, Shape, Stage, StageKind, ThrottleCurve, STAGE_NAMES,
};
use super::lowpass::{chain, derivative_rolloff, Lowpass};
use crate::error::{Error, Result};
use serde::Serialize;
use skyloop_lti::StateSpace;
use skyloop_robust::structured::blocks::Block;
pub mod filter_math;
pub mod flight;
pub mod header;

use super::vocab::{Axis, LowpassSetting};
pub use header::{BetaflightTuning, Rates};
use skyloop_sysid::logs::{Channel, Log};

/// `PTERM_SCALE` of Betaflight's pid.h.
pub const PTERM_SCALE: f64 = 0.032029;
/// `ITERM_SCALE` of Betaflight's pid.h.
pub const ITERM_SCALE: f64 = 0.244381;
/// `DTERM_SCALE` of Betaflight's pid.h.
pub const DTERM_SCALE: f64 = 0.000529;
/// `FEEDFORWARD_SCALE` of Betaflight's pid.h (applied to F/100 since Betaflight 4.3).
pub const FTERM_SCALE: f64 = 0.013754;
/// Largest P, I, D Betaflight accepts (`PID_GAIN_MAX`).
pub const PID_GAIN_MAX: u32 = 250;
/// Largest F (`F_GAIN_MAX`).
pub const F_GAIN_MAX: u32 = 1000;

/// Betaflight's yaw I factor from 4.0 on: `pid_init.c` multiplies yaw's Ki by 2.5 unless
/// `use_integrated_yaw` is on; 3.x has no such factor (checked against the sources of 3.5.7, 4.0.6,
/// 4.2.11, 4.5.5 and 2025.12.5).
pub const YAW_I_FACTOR: f64 = 2.5;

/// The yaw I factor a header's version and settings give: [`YAW_I_FACTOR`] from 4.0 on (and when
/// the version is unknown), 1 on 3.x or with integrated yaw.
pub fn yaw_i_factor(version_major: Option<u32>, integrated_yaw: bool) -> f64 {
    if version_major.is_some_and(|v| v < 4) || integrated_yaw {
        1.0
    } else {
        YAW_I_FACTOR
    }
}

/// The I factor of `axis` with these filters' yaw factor.
fn i_factor(axis: Axis, filters: &Filters) -> f64 {
    if axis == Axis::Yaw {
        filters.yaw_i_factor
    } else {
        1.0
    }
}

/// Betaflight's integer gains of one axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Gains {
    /// `p_<axis>`.
    pub p: u32,
    /// `i_<axis>`.
    pub i: u32,
    /// `d_<axis>`.
    pub d: u32,
    /// `f_<axis>`.
    pub f: u32,
}

impl Default for Gains {
    /// P = I = D = 0 and F 120, Betaflight 4.4's default feedforward.
    fn default() -> Self {
        Gains {
            p: 0,
            i: 0,
            d: 0,
            f: 120,
        }
    }
}

/// The filters and loop rate around the PID.
#[derive(Debug, Clone, PartialEq)]
pub struct Filters {
    /// Gyro lowpass chain (`gyro_lpf1`, `gyro_lpf2`), on every term.
    pub gyro: Vec<Lowpass>,
    /// D-term lowpass chain (`dterm_lpf1`, `dterm_lpf2`), on D after the gyro chain.
    pub dterm: Vec<Lowpass>,
    /// PID loop rate, Hz.
    pub loop_hz: f64,
    /// Ki multiplier on yaw ([`yaw_i_factor`]: 2.5 from 4.0 on, 1 on 3.x or with integrated yaw);
    /// not a filter, but a property of the version the loop runs, kept with its rate.
    pub yaw_i_factor: f64,
}

impl Default for Filters {
    /// Betaflight 4.4's defaults at a mid-throttle operating point: gyro PT1 at 250 Hz
    /// (dynamic 250–500 Hz) and PT1 at 500 Hz; D-term PT1 at 100 Hz (dynamic 75–150 Hz) and PT1 at
    /// 150 Hz; 4 kHz loop (8 kHz gyro, pid_process_denom 2).
    fn default() -> Self {
        Filters {
            gyro: vec![Lowpass::Pt1(250.0), Lowpass::Pt1(500.0)],
            dterm: vec![Lowpass::Pt1(100.0), Lowpass::Pt1(150.0)],
            loop_hz: 4000.0,
            yaw_i_factor: YAW_I_FACTOR,
        }
    }
}

/// Continuous gains in the plant's units: (Kp, Ki, Kd, Kf).
pub fn continuous(g: &Gains, axis: Axis, filters: &Filters) -> (f64, f64, f64, f64) {
    (
        PTERM_SCALE * g.p as f64,
        ITERM_SCALE * g.i as f64 * i_factor(axis, filters),
        DTERM_SCALE * g.d as f64,
        FTERM_SCALE * g.f as f64 / 100.0,
    )
}

/// The nearest integer gains for continuous (Kp, Ki, Kd) and a given F.
///
/// # Errors
/// A negative gain or one above Betaflight's `PID_GAIN_MAX` (250) once scaled, named.
pub fn from_continuous(kp: f64, ki: f64, kd: f64, f: u32, axis: Axis, filters: &Filters) -> Result<Gains> {
    let conv = |name: &str, k: f64, scale: f64| {
        super::integer_gain(
            &format!("Betaflight {name}_{}", axis.name()),
            k,
            k / scale,
            PID_GAIN_MAX,
        )
    };
    if f > F_GAIN_MAX {
        return Err(Error::Input(format!(
            "Betaflight f_{} = {f} is outside 0..={F_GAIN_MAX}",
            axis.name()
        )));
    }
    Ok(Gains {
        p: conv("p", kp, PTERM_SCALE)?,
        i: conv("i", ki, ITERM_SCALE * i_factor(axis, filters))?,
        d: conv("d", kd, DTERM_SCALE)?,
        f,
    })
}

/// The tunable structure: the two-path PID with the gyro chain on P and I, gyro and D-term
/// chains on D (a PT1 at a quarter of the loop rate when no filter is configured on D).
///
/// # Errors
/// Invalid filter cutoffs.
pub fn block(filters: &Filters) -> Result<Block> {
    let gyro = chain(&filters.gyro)?;
    let mut d_stages = filters.gyro.clone();
    d_stages.extend(filters.dterm.iter().copied());
    if d_stages.is_empty() {
        d_stages.push(derivative_rolloff(filters.loop_hz));
    }
    let d_filter = chain(&d_stages)?.ok_or("empty D filter chain")?;
    Ok(Block::PidFiltered {
        pi_filter: gyro,
        d_filter,
    })
}

/// C_fb(s) (y → u, plant units) of the gains with these filters.
///
/// # Errors
/// Invalid filter cutoffs.
pub fn feedback_controller(g: &Gains, axis: Axis, filters: &Filters) -> Result<StateSpace> {
    let (kp, ki, kd, _) = continuous(g, axis, filters);
    Ok(block(filters)?.realize(&[kp, ki, kd])?)
}

/// C_r(s) = Kp + Ki/s + Kf·s/(T·s + 1), T the loop period: the path from the setpoint to u.
///
/// # Errors
/// A loop rate that is not positive.
pub fn reference_path(g: &Gains, axis: Axis, filters: &Filters) -> Result<StateSpace> {
    let (kp, ki, _, kf) = continuous(g, axis, filters);
    let pi = StateSpace::from_rows(&[vec![0.0]], &[vec![1.0]], &[vec![ki]], &[vec![kp]], 0.0)?;
    let mut f = feedforward_unit(filters.loop_hz)?;
    f.c = &f.c * kf;
    f.d = &f.d * kf;
    Ok(skyloop_lti::interconnect::parallel(&pi, &f)?)
}

/// The feedforward's path per unit of continuous Kf: s/(T·s + 1) on the setpoint, T the loop
/// period (Betaflight differentiates the setpoint once per loop).
///
/// # Errors
/// A loop rate that is not positive.
pub fn feedforward_unit(loop_hz: f64) -> Result<StateSpace> {
    super::hold_delay_s(loop_hz)?;
    let t = 1.0 / loop_hz;
    // s/(T s + 1) = 1/T − (1/T²)/(s + 1/T).
    Ok(StateSpace::from_rows(
        &[vec![-1.0 / t]],
        &[vec![1.0]],
        &[vec![-1.0 / (t * t)]],
        &[vec![1.0 / t]],
        0.0,
    )?)
}

/// Betaflight's setpoint limit, deg/s (`SETPOINT_RATE_LIMIT`, and the default `rate_limit`).
pub const SETPOINT_RATE_LIMIT: f64 = 1998.0;

/// The setpoint in deg/s of a stick deflection `x` (−1..1) through the header's rate curve, before
/// the `rate_limit` clamp, as `rc.c` computes it for each `rates_type` (4.1–2025.12; checked
/// against the firmware's own functions in `tests/betaflight_filters.rs`). With the stored settings
/// rc = `rc_rates`, e = `rc_expo`, s = `rates` (super rate / max rate):
/// - BETAFLIGHT: x ← x·|x|³·e/100 + x·(1 − e/100); r = rc/100, + 14.54·(r − 2) above 2;
///   200·r·x / clamp(1 − |x|·s/100, 0.01, 1);
/// - RACEFLIGHT: x ← (1 + e/100·(x² − 1))·x; 10·rc·x·(1 + |x|·s/100);
/// - KISS: (x³·e/100 + x·(1 − e/100))·rc/1000 · 2000 / clamp(1 − |x|·s/100, 0.01, 1), within ±1998;
/// - ACTUAL: centre sensitivity c = 10·rc, max m = 10·s: c·x + max(0, m − c)·|x|·(x⁵·e/100 + x·(1 − e/100));
/// - QUICK: r = 2·rc (integer), m = max(10·s, r), k = (m/r − 1)/(m/r); the curve
///   x³·e/100 + x·(1 − e/100) on the stick (`quickrates_rc_expo`) or on |x| inside the super factor
///   1/clamp(1 − k·(·), 0.01, 1); within ±1998.
pub fn stick_rate_deg_s(x: f64, r: &Rates) -> f64 {
    let (rc, e, s) = (r.rc_rate, r.expo / 100.0, r.super_rate);
    let ax = x.abs();
    let lim = |v: f64| v.clamp(-SETPOINT_RATE_LIMIT, SETPOINT_RATE_LIMIT);
    let superf = |d: f64| 1.0 / (1.0 - d).clamp(0.01, 1.0);
    match r.rates_type.map_or(0, |t| t.round() as i64) {
        1 => {
            let x = (1.0 + e * (x * x - 1.0)) * x;
            10.0 * rc * x * (1.0 + ax * s * 0.01)
        }
        2 => {
            let c = (x.powi(3) * e + x * (1.0 - e)) * (rc / 1000.0);
            lim(2000.0 * superf(ax * s / 100.0) * c)
        }
        3 => {
            let expo = ax * (x.powi(5) * e + x * (1.0 - e));
            let centre = rc * 10.0;
            x * centre + (s * 10.0 - centre).max(0.0) * expo
        }
        4 => {
            let rate = (2.0 * rc).round();
            let max = (s * 10.0).max(rate);
            let k = (max / rate - 1.0) / (max / rate);
            if r.quick_rc_expo {
                let curve = x.powi(3) * e + x * (1.0 - e);
                lim(curve * rate * superf(ax * k))
            } else {
                let curve = ax.powi(3) * e + ax * (1.0 - e);
                lim(x * rate * superf(curve * k))
            }
        }
        _ => {
            let x = if e != 0.0 {
                x * ax.powi(3) * e + x * (1.0 - e)
            } else {
                x
            };
            let mut rate = rc / 100.0;
            if rate > 2.0 {
                rate += 14.54 * (rate - 2.0);
            }
            let out = 200.0 * rate * x;
            // The super factor reads the stick's own deflection, not the expo-curved one.
            if s != 0.0 {
                out * superf(ax * s / 100.0)
            } else {
                out
            }
        }
    }
}

/// The setpoint (deg/s) of a stick deflection `rc` in rcCommand units (−500..500 from centre)
/// through the header's rate curve ([`stick_rate_deg_s`]), limited to ±1998 deg/s (the default
/// `rate_limit`).
pub fn rate_curve_deg_s(rc: f64, r: &Rates) -> f64 {
    let x = (rc / 500.0).clamp(-1.0, 1.0);
    stick_rate_deg_s(x, r).clamp(-SETPOINT_RATE_LIMIT, SETPOINT_RATE_LIMIT)
}

/// Adds `setpoint[0..3]` (deg/s) to a Betaflight log that does not record it (3.x), computed from
/// `rcCommand[i]` through the header's rate curve ([`rate_curve_deg_s`]); returns a note saying so,
/// or None when the log has its setpoint or lacks rcCommand or rates.
pub fn add_setpoint_from_rc(log: &mut Log, rates: &[Rates]) -> Option<String> {
    if rates.len() < 3 {
        return None;
    }
    let g = log.groups.iter_mut().find(|g| {
        g.prefix.is_none()
            && g.channels.iter().any(|c| c.name == "rcCommand[0]")
            && !g.channels.iter().any(|c| c.name == "setpoint[0]")
    })?;
    for (i, r) in rates.iter().enumerate().take(3) {
        let rc = g.channels.iter().find(|c| c.name == format!("rcCommand[{i}]"))?;
        let values = rc.values.iter().map(|&v| rate_curve_deg_s(v, r)).collect();
        g.channels.push(Channel {
            name: format!("setpoint[{i}]"),
            values,
        });
    }
    Some(format!(
        "setpoint[0..3] computed from rcCommand through the header's rate curve (roll: rc rate {}, super rate {}, expo {}): this firmware does not log the setpoint",
        rates[0].rc_rate, rates[0].super_rate, rates[0].expo
    ))
}

/// Betaflight CLI lines that load the gains.
pub fn cli_lines(g: &Gains, axis: Axis) -> Vec<String> {
    let a = axis.name();
    vec![
        format!("set p_{a} = {}", g.p),
        format!("set i_{a} = {}", g.i),
        format!("set d_{a} = {}", g.d),
        format!("set f_{a} = {}", g.f),
        "save".to_string(),
    ]
}

/// True from Betaflight 4.3 on, which renamed the filter settings (`dterm_lpf1_static_hz` for
/// 4.0–4.2's `dterm_lowpass_hz`) and changed the dynamic lowpass curve.
fn names_4_3(b: &BetaflightTuning) -> bool {
    let minor = b
        .firmware_revision
        .split_whitespace()
        .find_map(|w| w.split('.').nth(1)?.parse::<u32>().ok())
        .unwrap_or(0);
    b.version_major.unwrap_or(4) > 4 || (b.version_major == Some(4) && minor >= 3)
}

/// The gyro and D-term lowpass cutoffs of a Betaflight header that `tune --tune-filters` may move,
/// with the CLI names of its version: 4.3's (`gyro_lpf1_static_hz`, `dterm_lpf1_dyn_min_hz`, ...)
/// or 4.0–4.2's and 3.x's (`gyro_lowpass_hz`, `dyn_lpf_dterm_min_hz`, ...). A throttle-following
/// lowpass moves by its range's two ends, a static one by its cutoff.
pub fn filter_settings(b: &BetaflightTuning) -> FilterSettings {
    let v43 = names_4_3(b);
    // (header stage, knob, static name, dynamic min name, dynamic max name)
    let table: [HeaderStage; 4] = if v43 {
        [
            (
                &b.gyro_lowpass,
                Knob::Gyro,
                "gyro_lpf1_static_hz",
                "gyro_lpf1_dyn_min_hz",
                "gyro_lpf1_dyn_max_hz",
            ),
            (&b.gyro_lowpass2, Knob::Gyro, "gyro_lpf2_static_hz", "", ""),
            (
                &b.dterm_lowpass,
                Knob::Dterm,
                "dterm_lpf1_static_hz",
                "dterm_lpf1_dyn_min_hz",
                "dterm_lpf1_dyn_max_hz",
            ),
            (&b.dterm_lowpass2, Knob::Dterm, "dterm_lpf2_static_hz", "", ""),
        ]
    } else {
        [
            (
                &b.gyro_lowpass,
                Knob::Gyro,
                "gyro_lowpass_hz",
                "dyn_lpf_gyro_min_hz",
                "dyn_lpf_gyro_max_hz",
            ),
            (&b.gyro_lowpass2, Knob::Gyro, "gyro_lowpass2_hz", "", ""),
            (
                &b.dterm_lowpass,
                Knob::Dterm,
                "dterm_lowpass_hz",
                "dyn_lpf_dterm_min_hz",
                "dyn_lpf_dterm_max_hz",
            ),
            (&b.dterm_lowpass2, Knob::Dterm, "dterm_lowpass2_hz", "", ""),
        ]
    };
    from_header_stages(&table)
}

/// The flown tune of one axis as a Betaflight header states it.
#[derive(Debug, Clone, PartialEq)]
pub struct FlownHeader {
    /// The gyro and D-term lowpass settings, with the CLI names of the header's version.
    pub filter_settings: FilterSettings,
    /// The controller's filters (the D-term chain; the gyro chain is inside a plant identified from
    /// the logged gyro) and the PID loop rate.
    pub filters: Filters,
    /// The header's gains and the D the firmware applies away from fast stick moves (d_min when
    /// active); None when the header has no gains for the axis.
    pub gains: Option<(Gains, u32)>,
    /// The filter settings as a report lists them.
    pub lines: Vec<String>,
    /// What the analysis assumes.
    pub notes: Vec<String>,
}

/// Reads the flown tune of `axis` from a Betaflight header (3.x and 4.x names).
pub fn flown_from_header(b: &BetaflightTuning, axis: Axis, log: &Log) -> FlownHeader {
    let (mut lines, mut notes) = (Vec::new(), Vec::new());
    let dterm = super::dterm_chain(
        &[
            (&b.dterm_lowpass, "dterm_lowpass"),
            (&b.dterm_lowpass2, "dterm_lowpass2"),
        ],
        b.dterm_notch,
        &mut lines,
        &mut notes,
    );
    for (l, name) in [(&b.gyro_lowpass, "gyro_lowpass"), (&b.gyro_lowpass2, "gyro_lowpass2")] {
        if let Some(l) = l {
            lines.push(format!(
                "{name}: {} at {} Hz{} (inside the identified plant: gyroADC is logged after it)",
                l.kind,
                l.cutoff_hz,
                l.dynamic_hz
                    .map(|(a, c)| format!(", dynamic {a}–{c} Hz"))
                    .unwrap_or_default()
            ));
        }
    }
    if b.dynamic_notch.is_some() || b.rpm_filter.is_some() {
        lines.push("dynamic notch / RPM filter: inside the identified plant (on the gyro)".into());
    }
    let loop_hz = b.pid_rate_hz.unwrap_or_else(|| {
        notes.push("the header has no loop time: a 4 kHz PID loop is assumed".into());
        4000.0
    });
    lines.push(format!("PID loop {loop_hz} Hz"));
    let filters = Filters {
        gyro: Vec::new(),
        dterm,
        loop_hz,
        yaw_i_factor: yaw_i_factor(b.version_major, b.integrated_yaw),
    };
    let mut gains = None;
    if let Some(p) = b.pidf.get(axis.index()) {
        let to_u = |v: f64| v.round().clamp(0.0, 1000.0) as u32;
        let g = Gains {
            p: to_u(p.p),
            i: to_u(p.i),
            d: to_u(p.d),
            f: to_u(p.f.unwrap_or(0.0)),
        };
        // With d_min active (0 < d_min < d) Betaflight applies d_min and raises D towards d
        // only in fast stick moves and prop wash: on the testdata acro flight the logged
        // axisD follows DTERM_SCALE·d_min from gyroADC (tests/betaflight_log_scales.rs),
        // 23 % below DTERM_SCALE·d. The flown tune is analysed with d_min.
        let d_applied = match p.d_min {
            Some(dm) if dm > 0.0 && dm < p.d => {
                notes.push(format!(
                    "d_min {dm} < d {}: the flown tune is analysed with D = d_min (what the firmware applies away from fast stick moves and prop wash; D rises towards d only there)",
                    p.d
                ));
                to_u(dm)
            }
            _ => g.d,
        };
        gains = Some((g, d_applied));
    }
    notes.push("not modelled: TPA, anti-gravity, I-term relax, d_min's boost towards d, feedforward smoothing".into());
    if let Some(w) = log
        .setting("dtermSetpointWeight")
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|w| *w > 0.0)
    {
        // Betaflight 3.x differentiates c·setpoint − gyro, c growing with stick deflection
        // up to dtermSetpointWeight/100: the setpoint path is faster than modelled here
        // (the margins, on the feedback path, are not affected).
        notes.push(format!(
            "dtermSetpointWeight {w}: the 3.x D term also acts on the setpoint (weighted by stick deflection), not modelled in the reference path; the predicted setpoint → gyro response is slower than flown above a few Hz"
        ));
    }
    FlownHeader {
        filter_settings: filter_settings(b),
        filters,
        gains,
        lines,
        notes,
    }
}

/// Betaflight's gyro and D-term filter chain from its header, at the PID loop rate (4.x filters the
/// gyro at the PID rate; 3.x's 8 kHz gyro filters differ from it only above a few hundred Hz):
/// gyro lowpass 1 (throttle-following where `gyro_lowpass_dyn_hz` is set: 4.0–4.2's curve, or
/// 4.3's `dyn_lpf_curve_expo`), lowpass 2, the static notches, the dynamic notch (`dyn_notch_count`
/// notches from 4.3; before it one, or two when `dyn_notch_width_percent` > 0), the RPM notches;
/// D-term lowpass 1 (dynamic likewise), lowpass 2 and notch. Returns notes on what is assumed.
pub fn filter_chain(b: &BetaflightTuning, log: &Log) -> (FilterChain, Vec<String>) {
    let mut notes = Vec::new();
    let one = |k: &str| {
        log.setting(k)
            .and_then(|v| v.split(',').next()?.trim().parse::<f64>().ok())
    };
    let v43 = names_4_3(b);
    let curve = if v43 {
        ThrottleCurve::Expo(one("dyn_lpf_curve_expo").unwrap_or(5.0) / 10.0)
    } else {
        ThrottleCurve::Betaflight40
    };
    let mut stages = Vec::new();
    let mut lowpass = |l: &Option<LowpassSetting>, name: &str, path: Path, type_key: Option<&str>| {
        let Some(l) = l else { return };
        // 3.x names the gyro lowpass type `gyro_soft_type`.
        let kind = type_key
            .and_then(&one)
            .map(|t| {
                match t as i64 {
                    1 => "BIQUAD",
                    _ => "PT1",
                }
                .to_string()
            })
            .unwrap_or_else(|| l.kind.clone());
        let shape = Shape::from_header(&kind).unwrap_or_else(|| {
            notes.push(format!("{name}: filter type {kind} is not modelled; taken as PT1"));
            Shape::Pt1
        });
        let kind = match l.dynamic_hz {
            Some((min_hz, max_hz)) => StageKind::DynamicLowpass {
                shape,
                min_hz,
                max_hz,
                curve,
            },
            None if l.cutoff_hz > 0.0 => StageKind::Lowpass { shape, hz: l.cutoff_hz },
            None => return,
        };
        stages.push(Stage {
            name: name.into(),
            path,
            kind,
        });
    };
    let v3 = b.version_major == Some(3);
    lowpass(&b.gyro_lowpass, "gyro_lpf1", Path::Gyro, v3.then_some("gyro_soft_type"));
    lowpass(&b.gyro_lowpass2, "gyro_lpf2", Path::Gyro, None);
    lowpass(&b.dterm_lowpass, "dterm_lpf1", Path::Dterm, None);
    lowpass(&b.dterm_lowpass2, "dterm_lpf2", Path::Dterm, None);
    stages.extend(static_notches(&b.gyro_notches, b.dterm_notch));
    if let Some(d) = b.dynamic_notch {
        let count = match d.count {
            Some(c) => c as usize,
            None if one("dyn_notch_width_percent").unwrap_or(0.0) > 0.0 => 2,
            None => 1,
        };
        if count > 0 {
            stages.push(Stage {
                name: "dyn_notch".into(),
                path: Path::Gyro,
                kind: StageKind::DynamicNotch {
                    count,
                    min_hz: d.min_hz,
                    max_hz: d.max_hz,
                    q: d.q.unwrap_or(3.0),
                },
            });
            notes.push("dyn_notch: centres tracked at the strongest gyro peaks of each 0.25 s frame (skyloop's spectrum, not the firmware's own FFT tracker)".into());
        }
    }
    if let Some(r) = b.rpm_filter {
        stages.push(Stage {
            name: "rpm".into(),
            path: Path::Gyro,
            kind: StageKind::Rpm {
                harmonics: r.harmonics as usize,
                q: r.q.unwrap_or(5.0),
                min_hz: r.min_hz.unwrap_or(100.0),
            },
        });
    }
    if one("dterm_rpm_notch_harmonics").unwrap_or(0.0) > 0.0 {
        notes.push("dterm_rpm_notch_harmonics: the D-term RPM notches are not modelled".into());
    }
    let loop_hz = b.pid_rate_hz.unwrap_or_else(|| {
        notes.push("the header has no loop time: a 4 kHz PID loop is assumed".into());
        4000.0
    });
    let mut chain = FilterChain { loop_hz, stages };
    // Signal order, as `with_changes` keeps it.
    chain
        .stages
        .sort_by_key(|s| (s.path == Path::Dterm, STAGE_NAMES.iter().position(|n| *n == s.name)));
    (chain, notes)
}

/// Where a Betaflight log holds the gyro before the firmware's filters (a `debug_mode` that logs it
/// into `debug[0..2]`), and which of the chain's stages the tapped signal has already been through:
/// 4.x `GYRO_SCALED` (mode 6: before every filter); 3.x `NOTCH` (mode 8: after the gyro lowpass,
/// before the notches; checked on PID-Analyzer's 3.1.5 log, where debug/gyroADC is flat to 100 Hz
/// under the 90 Hz PT1 and dips at the 220 Hz notch).
pub fn raw_gyro_tap(b: &BetaflightTuning, log: &Log) -> Option<RawGyroTap> {
    let mode = log.setting("debug_mode")?.trim().parse::<i64>().ok()?;
    let applied: Vec<String> = match (b.version_major?, mode) {
        (4, 6) => Vec::new(),
        (3, 8) => vec!["gyro_lpf1".into()],
        _ => return None,
    };
    let channels = ["debug[0]", "debug[1]", "debug[2]"].map(String::from);
    channels.iter().all(|c| log.channel(c).is_ok()).then(|| RawGyroTap {
        channels,
        applied,
        what: if mode == 6 {
            "debug GYRO_SCALED (gyro before every filter)"
        } else {
            "debug NOTCH (gyro after the lowpass, before the notches)"
        }
        .into(),
    })
}

/// The header's tuning as `log info` lists it: the PIDF of each axis, the filters, the loop rates, TPA and d_min.
pub fn header_lines(b: &BetaflightTuning) -> Vec<String> {
    let mut out = Vec::new();
    out.push(format!("tuning ({}):", b.firmware_revision));
    for (axis, g) in ["roll", "pitch", "yaw"].iter().zip(&b.pidf) {
        out.push(format!(
            "  {axis:<5} P {} I {} D {} F {} d_min {}",
            g.p,
            g.i,
            g.d,
            super::opt(g.f),
            super::opt(g.d_min)
        ));
    }
    let lp = |name: &str, l: &Option<LowpassSetting>| match l {
        Some(l) => format!(
            "  {name}: {} {} Hz{}",
            l.kind,
            l.cutoff_hz,
            l.dynamic_hz
                .map(|(a, b)| format!(" (dynamic {a}..{b} Hz)"))
                .unwrap_or_default()
        ),
        None => format!("  {name}: off"),
    };
    out.push(lp("gyro lowpass", &b.gyro_lowpass));
    out.push(lp("gyro lowpass 2", &b.gyro_lowpass2));
    out.push(lp("D-term lowpass", &b.dterm_lowpass));
    out.push(lp("D-term lowpass 2", &b.dterm_lowpass2));
    match &b.dynamic_notch {
        Some(n) => out.push(format!(
            "  dynamic notch: {}..{} Hz, Q {}",
            n.min_hz,
            n.max_hz,
            super::opt(n.q)
        )),
        None => out.push("  dynamic notch: off".into()),
    }
    match &b.rpm_filter {
        Some(r) => out.push(format!(
            "  RPM filter: {} harmonics, Q {}, min {} Hz",
            r.harmonics,
            super::opt(r.q),
            super::opt(r.min_hz)
        )),
        None => out.push("  RPM filter: off".into()),
    }
    out.push(format!(
        "  loop: gyro {} Hz, PID {} Hz; TPA {} % from {} us; d_min gain {}, advance {}",
        super::opt(b.gyro_rate_hz),
        super::opt(b.pid_rate_hz),
        super::opt(b.tpa_rate_percent),
        super::opt(b.tpa_breakpoint_us),
        super::opt(b.d_min_gain),
        super::opt(b.d_min_advance)
    ));
    out
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use skyloop_lti::c64;

    /// Well below every filter, C_fb(jω) = Kp + Ki/(jω) + Kd·jω with the printed integers times
    /// pid.h's scale factors.
    #[test]
    fn low_frequency_part_is_the_scaled_pid() {
        let g = Gains {
            p: 45,
            i: 80,
            d: 40,
            f: 120,
        };
        let c = feedback_controller(&g, Axis::Roll, &Filters::default()).unwrap();
        for w in [0.05, 0.5, 2.0] {
            let s = c64::new(0.0, w);
            let got = skyloop_lti::freqresp::evalfr(&c, s).unwrap()[(0, 0)];
            let want = 0.032029 * 45.0 + 0.244381 * 80.0 / s + 0.000529 * 40.0 * s;
            // The filters' first-order lag at ω: relative error ~ ω·Σ 1/ω_c.
            assert!((got - want).norm() < 2e-3 * want.norm(), "w {w}: {got} vs {want}");
        }
        let yaw = feedback_controller(&g, Axis::Yaw, &Filters::default()).unwrap();
        let s = c64::new(0.0, 0.01);
        let ki_yaw = (skyloop_lti::freqresp::evalfr(&yaw, s).unwrap()[(0, 0)] * s).re;
        assert!((ki_yaw - 2.5 * 0.244381 * 80.0).abs() < 1e-3 * ki_yaw);
        // Betaflight 3.x (and integrated yaw) has no ×2.5: yaw's I is scaled as the others'.
        let v3 = Filters {
            yaw_i_factor: yaw_i_factor(Some(3), false),
            ..Filters::default()
        };
        let yaw3 = feedback_controller(&g, Axis::Yaw, &v3).unwrap();
        let ki_yaw3 = (skyloop_lti::freqresp::evalfr(&yaw3, s).unwrap()[(0, 0)] * s).re;
        assert!((ki_yaw3 - 0.244381 * 80.0).abs() < 1e-3 * ki_yaw3, "{ki_yaw3}");
        assert_eq!(yaw_i_factor(Some(4), true), 1.0);
        assert_eq!(yaw_i_factor(None, false), YAW_I_FACTOR);
    }

    #[test]
    fn gains_round_trip_and_out_of_range_is_named() {
        let g = Gains {
            p: 45,
            i: 80,
            d: 40,
            f: 120,
        };
        let fl = Filters::default();
        let (kp, ki, kd, _) = continuous(&g, Axis::Pitch, &fl);
        assert_eq!(from_continuous(kp, ki, kd, 120, Axis::Pitch, &fl).unwrap(), g);
        let e = from_continuous(100.0, ki, kd, 0, Axis::Roll, &fl).unwrap_err();
        assert!(
            e.to_string().contains("p_roll") && e.to_string().contains("0..=250"),
            "{e}"
        );
        assert_eq!(cli_lines(&g, Axis::Roll)[0], "set p_roll = 45");
    }
}
