//! ArduPilot's multicopter rate controller (ArduCopter and QuadPlane VTOL, `AC_AttitudeControl`'s
//! rate loops, each an `AC_PID`).
//!
//! Source: ArduPilot's parameter documentation (`ATC_RAT_RLL_*`, `ATC_RAT_PIT_*`,
//! `ATC_RAT_YAW_*`) and its maintainers' description of the filters: FLTT lowpasses the rate
//! target; FLTE lowpasses the error (target − gyro) used by P, I and D; FLTD lowpasses the error
//! again on the way into D only; FF multiplies the (FLTT-filtered) target. Each filter is a
//! first-order lowpass, disabled by 0. D acts on the error, not on the measurement. Units: rad/s
//! in, the motor mixer's normalized command (−1..1) out, as PX4's. The loop runs at
//! `SCHED_LOOP_RATE` (400 Hz on a copter by default).
//!
//! So C_fb(s) = F_E(s)·[P + I/s + D·s·F_D(s)] and C_r(s) = F_T(s)·[C_fb(s) + FF].
//!
//! Not modelled: IMAX (the integrator limit), SMAX (the slew-rate limiter, which lowers the gains
//! while the output oscillates), D_FF, the notch filters of INS_HNTCH_* (inside an identified
//! plant when the gyro is logged after them).

use super::filter_settings::{FilterSetting, FilterSettings, Knob, LineStyle};
use super::filters::{FilterChain, Path, Shape, Stage, StageKind};
use super::lowpass::{derivative_rolloff, Lowpass};
use crate::error::{Error, Result};
use crate::firmware::vocab::Axis;
use serde::Serialize;
use skyloop_lti::interconnect::series;
use skyloop_lti::StateSpace;
use skyloop_robust::structured::blocks::Block;
pub mod flight;
pub mod header;

pub use header::ArduPilotTuning;

/// rad/s per unit of the rates a DataFlash log records (`RATE.R`, `RATE.RDes`: deg/s), which is
/// the unit of a plant identified from a log; the gains act on rad/s.
pub const LOG_RATE_UNIT_RAD_S: f64 = std::f64::consts::PI / 180.0;

/// `ATC_RAT_<AXIS>_{P,I,D,FF}` (default: all 0).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Gains {
    /// P, command per rad/s.
    pub p: f64,
    /// I, command per rad.
    pub i: f64,
    /// D, command per rad/s².
    pub d: f64,
    /// Feedforward on the rate target, command per rad/s.
    pub ff: f64,
}

impl Gains {
    /// The same controller acting on a rate measured in units of `unit_rad_s` rad/s (e.g. a log's
    /// deg/s: [`LOG_RATE_UNIT_RAD_S`]): every gain × `unit_rad_s` (command per unit, per unit·s,
    /// per unit/s, per unit).
    pub fn in_plant_units(&self, unit_rad_s: f64) -> Gains {
        let u = unit_rad_s;
        Gains {
            p: self.p * u,
            i: self.i * u,
            d: self.d * u,
            ff: self.ff * u,
        }
    }
}

/// Filters and loop rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Filters {
    /// `ATC_RAT_<AXIS>_FLTT`, Hz (0 disables).
    pub fltt_hz: f64,
    /// `ATC_RAT_<AXIS>_FLTE`, Hz (0 disables).
    pub flte_hz: f64,
    /// `ATC_RAT_<AXIS>_FLTD`, Hz (0 disables).
    pub fltd_hz: f64,
    /// `SCHED_LOOP_RATE`, Hz.
    pub loop_hz: f64,
}

impl Default for Filters {
    /// ArduCopter's roll and pitch defaults: FLTT 20 Hz, FLTE 0 (off), FLTD 20 Hz, 400 Hz loop.
    fn default() -> Self {
        Filters {
            fltt_hz: 20.0,
            flte_hz: 0.0,
            fltd_hz: 20.0,
            loop_hz: 400.0,
        }
    }
}

/// The documented ranges of the gains (the ground station's, not enforced by the firmware), in
/// the order P, I, D, FF.
pub const GAIN_RANGES: [(f64, f64); 4] = [(0.01, 0.5), (0.01, 2.0), (0.0, 0.05), (0.0, 0.5)];

/// The parameter names of an axis, in the order P, I, D, FF.
pub fn param_names(axis: Axis) -> [String; 4] {
    let a = match axis {
        Axis::Roll => "RLL",
        Axis::Pitch => "PIT",
        Axis::Yaw => "YAW",
    };
    ["P", "I", "D", "FF"].map(|s| format!("ATC_RAT_{a}_{s}"))
}

fn pt1(name: &str, hz: f64) -> Result<Option<StateSpace>> {
    if !(hz.is_finite() && hz >= 0.0) {
        return Err(Error::Input(format!("{name} must be >= 0 Hz (0 disables), got {hz}")));
    }
    Ok(if hz > 0.0 {
        Some(Lowpass::Pt1(hz).model()?)
    } else {
        None
    })
}

/// The tunable structure (continuous P, I, D on the filtered error).
///
/// # Errors
/// Negative or non-finite cutoffs.
pub fn block(f: &Filters) -> Result<Block> {
    let e = pt1("FLTE", f.flte_hz)?;
    pt1("FLTT", f.fltt_hz)?;
    let d = match pt1("FLTD", f.fltd_hz)? {
        Some(d) => d,
        None => derivative_rolloff(f.loop_hz).model()?,
    };
    let d_filter = match &e {
        Some(e) => series(e, &d)?,
        None => d,
    };
    Ok(Block::PidFiltered { pi_filter: e, d_filter })
}

/// C_fb(s) of the gains.
///
/// # Errors
/// As [`block`].
pub fn feedback_controller(g: &Gains, f: &Filters) -> Result<StateSpace> {
    Ok(block(f)?.realize(&[g.p, g.i, g.d])?)
}

/// C_r(s) = F_T(s)·[C_fb(s) + FF]: the target passes FLTT, then enters the error and the
/// feedforward.
///
/// # Errors
/// As [`block`].
pub fn reference_path(g: &Gains, f: &Filters) -> Result<StateSpace> {
    let mut c = feedback_controller(g, f)?;
    c.d[(0, 0)] += g.ff;
    Ok(match pt1("FLTT", f.fltt_hz)? {
        Some(t) => series(&t, &c)?,
        None => c,
    })
}

/// The feedforward's path per unit FF: F_T(s).
///
/// # Errors
/// As [`block`].
pub fn feedforward_unit(f: &Filters) -> Result<StateSpace> {
    Ok(match pt1("FLTT", f.fltt_hz)? {
        Some(t) => t,
        None => super::static_gain(1.0)?,
    })
}

/// Notes for gains outside the documented ranges (the firmware accepts them; a ground station
/// warns).
pub fn range_notes(g: &Gains, axis: Axis) -> Vec<String> {
    param_names(axis)
        .iter()
        .zip([g.p, g.i, g.d, g.ff])
        .zip(GAIN_RANGES)
        .filter(|((_, v), (lo, hi))| v < lo || v > hi)
        .map(|((n, v), (lo, hi))| format!("{n} = {v} lies outside its documented range {lo}..{hi}; the plant's units may not be mixer command per rad/s"))
        .collect()
}

/// MAVProxy / ground-station `param set` lines.
pub fn cli_lines(g: &Gains, axis: Axis) -> Vec<String> {
    param_names(axis)
        .iter()
        .zip([g.p, g.i, g.d, g.ff])
        .map(|(n, v)| format!("param set {n} {v}"))
        .collect()
}

/// ArduCopter's default `ATC_ACCEL_{R,P,Y}_MAX`, centidegrees/s² (roll, pitch, yaw).
pub const ACCEL_MAX_DEFAULT_CDEG_S2: [f64; 3] = [110_000.0, 110_000.0, 27_000.0];

/// The attitude controller's limit on the rate target's acceleration for `axis`, deg/s²
/// (`ATC_ACCEL_<R|P|Y>_MAX` / 100, ArduCopter's default where the log lacks it); None when the
/// parameter is 0 (no limit).
pub fn setpoint_accel_deg_s2(t: &ArduPilotTuning, axis: Axis) -> Option<f64> {
    let v = t
        .rate
        .get(axis.index())
        .and_then(|r| r.accel_max_cdeg_s2)
        .unwrap_or(ACCEL_MAX_DEFAULT_CDEG_S2[axis.index()]);
    (v.is_finite() && v > 0.0).then_some(v / 100.0)
}

/// Reads the flown tune of `axis` from a DataFlash log's parameters: the controller's filters
/// (FLTT, FLTE, FLTD; ArduCopter's defaults where a parameter is missing) and loop rate
/// (`SCHED_LOOP_RATE`), the gains (None when P, I or D is missing) and the filter lines for a
/// report. `INS_GYRO_FILTER` and the harmonic notches act before `RATE.R` is logged, so they are
/// inside a plant identified from the log.
pub fn flown_from_header(t: &ArduPilotTuning, axis: Axis) -> (Filters, Option<Gains>, Vec<String>) {
    let d = Filters::default();
    let r = t.rate.get(axis.index());
    let pick = |v: Option<f64>, default: f64| v.filter(|x| x.is_finite() && *x >= 0.0).unwrap_or(default);
    let filters = Filters {
        fltt_hz: pick(r.and_then(|r| r.fltt_hz), d.fltt_hz),
        flte_hz: pick(r.and_then(|r| r.flte_hz), d.flte_hz),
        fltd_hz: pick(r.and_then(|r| r.fltd_hz), d.fltd_hz),
        loop_hz: t
            .loop_rate_hz
            .filter(|x| x.is_finite() && *x > 0.0)
            .unwrap_or(d.loop_hz),
    };
    let a = param_names(axis)[0].trim_end_matches("_P").to_string();
    let hz = |v: f64| if v > 0.0 { format!("{v} Hz") } else { "off".into() };
    let mut lines = vec![
        format!("{a}_FLTT {} (target lowpass, in the controller)", hz(filters.fltt_hz)),
        format!("{a}_FLTE {} (error lowpass, in the controller)", hz(filters.flte_hz)),
        format!("{a}_FLTD {} (D-term lowpass, in the controller)", hz(filters.fltd_hz)),
    ];
    if let Some(g) = t.gyro_filter_hz {
        lines.push(format!(
            "INS_GYRO_FILTER {g} Hz (inside the identified plant: RATE.R is logged after it)"
        ));
    }
    lines.push(format!("rate loop {} Hz (SCHED_LOOP_RATE)", filters.loop_hz));
    let gains = r.and_then(|r| match (r.p, r.i, r.d) {
        (Some(p), Some(i), Some(d)) => Some(Gains {
            p,
            i,
            d,
            ff: r.ff.unwrap_or(0.0),
        }),
        _ => None,
    });
    (filters, gains, lines)
}

/// The lowpass cutoffs `tune --tune-filters` may move for `axis`: `INS_GYRO_FILTER` (a biquad on
/// the gyro, before `RATE` is logged) and `ATC_RAT_<AXIS>_FLTD` (first order, on the D term),
/// where on (FLTD at ArduCopter's 20 Hz default where not logged, as the controller assumes).
pub fn filter_settings(t: &ArduPilotTuning, axis: Axis) -> FilterSettings {
    let mut settings = Vec::new();
    let mut gyro = Vec::new();
    if let Some(g) = t.gyro_filter_hz.filter(|x| x.is_finite() && *x > 0.0) {
        settings.push(FilterSetting {
            name: "INS_GYRO_FILTER".into(),
            knob: Knob::Gyro,
            flown_hz: g,
            shared: true,
        });
        gyro.push(Lowpass::Biquad(g));
    }
    let (filters, _, _) = flown_from_header(t, axis);
    if filters.fltd_hz > 0.0 {
        let a = param_names(axis)[0].trim_end_matches("_P").to_string();
        settings.push(FilterSetting {
            name: format!("{a}_FLTD"),
            knob: Knob::Dterm,
            flown_hz: filters.fltd_hz,
            shared: false,
        });
    }
    FilterSettings {
        settings,
        gyro,
        style: LineStyle::Param,
    }
}

/// The parameters as `log info` lists them, each under its own name (DataFlash PARM messages): the rate PIDs and filters, the gyro filter and loop rate, the harmonic notches and the rate-loop messages' logging rates.
pub fn header_lines(a: &ArduPilotTuning) -> Vec<String> {
    let mut out = Vec::new();
    let named = |name: String, v: Option<f64>, unit: &str| match v {
        Some(x) => format!("{name} = {x}{unit}"),
        None => format!("{name} not in the log"),
    };
    let firmware = match (&a.vehicle, &a.version) {
        (Some(v), Some(n)) => format!("{v} {n}"),
        _ if a.firmware_revision.is_empty() => "ArduPilot, version not in the log".to_string(),
        _ => a.firmware_revision.clone(),
    };
    let frame = a.frame.as_ref().map(|f| format!(", frame {f}")).unwrap_or_default();
    out.push(format!("tuning ({firmware}{frame}; ArduPilot parameters):"));
    if !a.firmware_revision.is_empty() {
        out.push(format!("  firmware: {}", a.firmware_revision));
    }
    for ((axis, x), g) in [("RLL", 'R'), ("PIT", 'P'), ("YAW", 'Y')].iter().zip(&a.rate) {
        let mut items: Vec<String> = [("P", g.p, ""), ("I", g.i, ""), ("D", g.d, ""), ("FF", g.ff, "")]
            .into_iter()
            .chain([
                ("FLTT", g.fltt_hz, " Hz"),
                ("FLTE", g.flte_hz, " Hz"),
                ("FLTD", g.fltd_hz, " Hz"),
            ])
            .map(|(k, v, unit)| named(format!("ATC_RAT_{axis}_{k}"), v, unit))
            .collect();
        items.push(named(format!("ATC_ACCEL_{x}_MAX"), g.accel_max_cdeg_s2, " cdeg/s²"));
        out.push(format!("  {}", items.join(", ")));
    }
    out.push(format!(
        "  {}, {}",
        named("INS_GYRO_FILTER".into(), a.gyro_filter_hz, " Hz"),
        named("SCHED_LOOP_RATE".into(), a.loop_rate_hz, " Hz")
    ));
    if a.harmonic_notch.is_empty() {
        out.push("  harmonic notch: no INS_HNTCH_* parameters in the log".into());
    } else {
        let items: Vec<String> = a
            .harmonic_notch
            .iter()
            .map(|n| format!("{} = {}", n.name, n.value))
            .collect();
        out.push(format!("  harmonic notch: {}", items.join(", ")));
    }
    if a.log_rates_hz.is_empty() {
        out.push("  logging rates: no RATE, PIDR/PIDP/PIDY, IMU, GYR or RCOU messages".into());
    } else {
        let items: Vec<String> = a
            .log_rates_hz
            .iter()
            .map(|n| format!("{} {:.1} Hz", n.name, n.value))
            .collect();
        out.push(format!("  logging rates: {}", items.join(", ")));
    }
    out
}

/// The gyro filter chain ArduPilot's parameters state, at `SCHED_LOOP_RATE` (400 Hz when not
/// logged): `INS_GYRO_FILTER` (a second-order Butterworth lowpass, `LowPassFilter2p`, a biquad)
/// and, for a fixed harmonic notch (`INS_HNTCH_MODE` 0), a notch at `INS_HNTCH_FREQ` times each of
/// the first two harmonics `INS_HNTCH_HMNCS` enables, Q = FREQ/BW. With notes on what is assumed:
/// the IMU filters run at the sensor's own rate (modelled at the loop rate, which bends the phase
/// near the loop's Nyquist frequency, not in the 10–100 Hz a rate loop lives in); the notch is
/// full depth where ArduPilot's stops at `INS_HNTCH_ATT` dB; a tracking notch (throttle, RPM, ESC
/// or FFT) and the second notch `INS_HNTC2_*` are not modelled; the per-axis `ATC_RAT_*_FLTE`/
/// `FLTD` lowpasses are in the rate controller's model (`tune`), not in this chain.
pub fn filter_chain(t: &ArduPilotTuning) -> (FilterChain, Vec<String>) {
    let mut notes = Vec::new();
    let loop_hz = t.loop_rate_hz.filter(|&r| r > 0.0).unwrap_or_else(|| {
        notes.push("SCHED_LOOP_RATE not logged: a 400 Hz filter rate is assumed".into());
        400.0
    });
    notes.push(format!(
        "INS_GYRO_FILTER and the harmonic notch run at the IMU's sample rate; modelled at SCHED_LOOP_RATE {loop_hz} Hz (the phase differs near {:.0} Hz, not in a rate loop's band)",
        0.5 * loop_hz
    ));
    let mut stages = Vec::new();
    match t.gyro_filter_hz {
        Some(hz) if hz > 0.0 && hz < 0.5 * loop_hz => stages.push(Stage {
            name: "gyro_lpf1".into(),
            path: Path::Gyro,
            kind: StageKind::Lowpass {
                shape: Shape::Biquad,
                hz,
            },
        }),
        Some(hz) if hz > 0.0 => notes.push(format!(
            "INS_GYRO_FILTER {hz} Hz is at or above the loop's Nyquist frequency: left out"
        )),
        Some(_) => {}
        None => notes.push("INS_GYRO_FILTER not logged: no gyro lowpass in the chain".into()),
    }
    let (notches, more) = harmonic_notch(t, loop_hz);
    stages.extend(notches);
    notes.extend(more);
    notes.push("ATC_RAT_*_FLTE/FLTD (per axis) are in the rate controller's model, not in this chain".into());
    (FilterChain { loop_hz, stages }, notes)
}

/// The first harmonic notch (`INS_HNTCH_*`) as fixed notch stages when its mode is fixed (0),
/// with notes on what is not modelled.
fn harmonic_notch(t: &ArduPilotTuning, loop_hz: f64) -> (Vec<Stage>, Vec<String>) {
    let get = |n: &str| t.harmonic_notch.iter().find(|v| v.name == n).map(|v| v.value);
    let mut notes = Vec::new();
    if get("INS_HNTC2_ENABLE").is_some_and(|e| e > 0.0) {
        notes.push("the second harmonic notch INS_HNTC2_* is enabled: not modelled".into());
    }
    if !get("INS_HNTCH_ENABLE").is_some_and(|e| e > 0.0) {
        return (Vec::new(), notes);
    }
    let mode = get("INS_HNTCH_MODE").unwrap_or(0.0);
    let (Some(freq), Some(bw)) = (get("INS_HNTCH_FREQ"), get("INS_HNTCH_BW")) else {
        notes.push("INS_HNTCH_ENABLE is set but FREQ or BW is not logged: the notch is not modelled".into());
        return (Vec::new(), notes);
    };
    if mode != 0.0 || freq <= 0.0 || bw <= 0.0 {
        let what = match mode as i64 {
            1 => "throttle",
            2 => "RPM sensor",
            3 => "ESC telemetry",
            4 => "in-flight FFT",
            _ => "an unknown mode",
        };
        notes.push(format!(
            "the harmonic notch tracks {what} (INS_HNTCH_MODE {mode}, base {freq} Hz, bandwidth {bw} Hz): not modelled in this chain; the logged gyro is already after it"
        ));
        return (Vec::new(), notes);
    }
    // HMNCS is a bitmask: bit k enables harmonic k + 1 (1 when not logged).
    let mask = get("INS_HNTCH_HMNCS").map_or(1, |m| m.max(0.0) as u32);
    let harmonics: Vec<u32> = (0..16).filter(|k| mask & (1 << k) != 0).map(|k| k + 1).collect();
    let mut stages = Vec::new();
    for (name, h) in ["gyro_notch1", "gyro_notch2"].into_iter().zip(&harmonics) {
        let center_hz = freq * f64::from(*h);
        if center_hz >= 0.5 * loop_hz {
            notes.push(format!(
                "harmonic {h} of the notch ({center_hz} Hz) is above the loop's Nyquist frequency: left out"
            ));
            continue;
        }
        stages.push(Stage {
            name: name.into(),
            path: Path::Gyro,
            kind: StageKind::Notch {
                center_hz,
                q: center_hz / bw,
            },
        });
    }
    if harmonics.len() > 2 {
        notes.push(format!(
            "INS_HNTCH_HMNCS enables {} harmonics: the first two are modelled",
            harmonics.len()
        ));
    }
    notes.push(match get("INS_HNTCH_ATT") {
        Some(att) => format!(
            "the fixed harmonic notch is modelled at full depth (ArduPilot's stops at INS_HNTCH_ATT = {att} dB)"
        ),
        None => {
            "the fixed harmonic notch is modelled at full depth (INS_HNTCH_ATT, its depth in dB, is not logged)".into()
        }
    });
    (stages, notes)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use skyloop_lti::c64;
    use skyloop_lti::freqresp::evalfr;

    /// Well below the filters, C_fb(jω) = P + I/(jω) + D·jω with the parameters as printed;
    /// C_r adds FF; with FLTE set, the error filter multiplies every term.
    #[test]
    fn low_frequency_part_is_the_printed_pid() {
        let g = Gains {
            p: 0.135,
            i: 0.135,
            d: 0.0036,
            ff: 0.05,
        };
        for flte in [0.0, 80.0] {
            let f = Filters {
                flte_hz: flte,
                ..Filters::default()
            };
            let c = feedback_controller(&g, &f).unwrap();
            let cr = reference_path(&g, &f).unwrap();
            for w in [0.05, 0.3] {
                let s = c64::new(0.0, w);
                let want = 0.135 + 0.135 / s + 0.0036 * s;
                let got = evalfr(&c, s).unwrap()[(0, 0)];
                assert!((got - want).norm() < 2e-3 * want.norm(), "w {w}: {got} vs {want}");
                let got_r = evalfr(&cr, s).unwrap()[(0, 0)];
                // FLTT's first-order lag at ω: relative error ~ ω/ω_T (2.4e-3 at 0.3 rad/s).
                assert!((got_r - want - 0.05).norm() < 5e-3 * want.norm(), "w {w}: {got_r}");
            }
            // At the FLTT corner the target path is 3 dB down relative to the feedback path.
            let s = c64::new(0.0, 2.0 * std::f64::consts::PI * 20.0);
            let ratio = (evalfr(&cr, s).unwrap()[(0, 0)]
                - 0.05 * evalfr(&feedforward_unit(&f).unwrap(), s).unwrap()[(0, 0)])
                / evalfr(&c, s).unwrap()[(0, 0)];
            assert!((ratio.norm() - 0.5f64.sqrt()).abs() < 1e-9, "{ratio}");
        }
    }

    #[test]
    fn names_lines_and_ranges() {
        let g = Gains {
            p: 0.9,
            i: 0.1,
            d: 0.004,
            ff: 0.0,
        };
        assert_eq!(param_names(Axis::Pitch)[0], "ATC_RAT_PIT_P");
        assert_eq!(cli_lines(&g, Axis::Yaw)[3], "param set ATC_RAT_YAW_FF 0");
        let n = range_notes(&g, Axis::Roll);
        assert_eq!(n.len(), 1);
        assert!(
            n[0].contains("ATC_RAT_RLL_P = 0.9") && n[0].contains("0.01..0.5"),
            "{n:?}"
        );
        let e = block(&Filters {
            fltd_hz: -1.0,
            ..Filters::default()
        })
        .unwrap_err();
        assert!(e.to_string().contains("FLTD"), "{e}");
    }

    fn tuning(notch: &[(&str, f64)]) -> ArduPilotTuning {
        ArduPilotTuning {
            firmware_revision: String::new(),
            vehicle: None,
            version: None,
            frame: None,
            rate: Vec::new(),
            gyro_filter_hz: Some(40.0),
            loop_rate_hz: Some(400.0),
            harmonic_notch: notch
                .iter()
                .map(|(n, v)| header::NamedValue {
                    name: (*n).into(),
                    value: *v,
                })
                .collect(),
            log_rates_hz: Vec::new(),
        }
    }

    /// INS_GYRO_FILTER is a biquad at the loop rate: −3 dB at its cutoff (Butterworth, the
    /// bilinear transform prewarped at the cutoff), and a fixed harmonic notch removes its centre
    /// and its second harmonic; a tracking notch is named, not modelled.
    #[test]
    fn gyro_chain_from_the_parameters() {
        use crate::firmware::filters::OperatingPoint;
        let fixed = [
            ("INS_HNTCH_ENABLE", 1.0),
            ("INS_HNTCH_MODE", 0.0),
            ("INS_HNTCH_FREQ", 60.0),
            ("INS_HNTCH_BW", 15.0),
            ("INS_HNTCH_HMNCS", 3.0),
        ];
        let (chain, notes) = filter_chain(&tuning(&fixed));
        assert_eq!(chain.loop_hz, 400.0);
        let names: Vec<&str> = chain.stages.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["gyro_lpf1", "gyro_notch1", "gyro_notch2"]);
        let op = OperatingPoint::default();
        let h = chain.response(Path::Gyro, &[1.0, 60.0, 120.0], &op).unwrap();
        assert!((h[0].norm() - 1.0).abs() < 1e-2, "{}", h[0]);
        assert!(
            h[1].norm() < 1e-6 && h[2].norm() < 1e-6,
            "{} {} {:?}",
            h[1],
            h[2],
            chain.stages
        );
        let lp = FilterChain {
            loop_hz: 400.0,
            stages: chain.stages[..1].to_vec(),
        };
        let at_cut = lp.response(Path::Gyro, &[40.0], &op).unwrap()[0].norm();
        assert!((20.0 * at_cut.log10() + 3.01).abs() < 0.1, "{at_cut}");
        assert!(notes.iter().any(|n| n.contains("full depth")), "{notes:?}");

        let fft = [
            ("INS_HNTCH_ENABLE", 1.0),
            ("INS_HNTCH_MODE", 4.0),
            ("INS_HNTCH_FREQ", 60.0),
            ("INS_HNTCH_BW", 15.0),
        ];
        let (chain, notes) = filter_chain(&tuning(&fft));
        assert_eq!(chain.stages.len(), 1);
        assert!(
            notes
                .iter()
                .any(|n| n.contains("in-flight FFT") && n.contains("not modelled")),
            "{notes:?}"
        );
    }
}
