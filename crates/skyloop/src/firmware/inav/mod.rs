//! INAV's multicopter rate PID and its scale factors.
//!
//! Facts taken from INAV's `src/main/flight/pid.h` and `pid.c` (INAV 3 to 9; the code here is our
//! own): the integer gains a pilot sets (`mc_p_<axis>`, `mc_i_<axis>`, `mc_d_<axis>`,
//! `mc_cd_<axis>`) are divided by `FP_PID_RATE_P_MULTIPLIER` 31, `FP_PID_RATE_I_MULTIPLIER` 4,
//! `FP_PID_RATE_D_MULTIPLIER` 1905 and, for the multicopter feedforward (the "control derivative"),
//! `FP_PID_RATE_D_FF_MULTIPLIER` 7270 (the `FP_PID_RATE_FF_MULTIPLIER` 31 scales the fixed-wing FF,
//! not a multicopter's). Per loop at the PID rate, on the rate error e = target − gyro (deg/s, after
//! the gyro filters): P = Kp·e; I += Ki·e·dT; D = Kd·(gyro_prev − gyro)/dT after the D-term
//! lowpass (`dterm_lpf_hz`, `dterm_lpf_type`), D on the measurement; CD = Kcd·Δtarget/dT after a
//! lowpass on the target difference (`mc_cd_lpf_hz`, a PT2 on recent INAV). The PID sum
//! P + I + D + CD goes to the mixer (limited to ±`pidsum_limit`, 500), as Betaflight's does.
//! There is no yaw I factor.
//!
//! In the plant's units (input the PID sum, output gyro deg/s):
//! C_fb(s) = Kp + Ki/s + Kd·s·F_dterm(s) and C_r(s) = Kp + Ki/s + Kcd·s·F_cd(s).
//! Not modelled: TPA (P and D on roll and pitch scaled down above the breakpoint), anti-gravity,
//! I-term relax, D-boost, the yaw P lowpass (`yaw_lpf_hz`), the Smith predictor and the gyro filters
//! (inside a plant identified from the logged gyro).

use super::filter_settings::{from_header_stages, FilterSettings, HeaderStage, Knob};
use super::filters::{static_notches, FilterChain, Path, Shape, Stage, StageKind};
use super::lowpass::{chain, derivative_rolloff, Lowpass};
use crate::error::{Error, Result};
use crate::firmware::vocab::{Axis, LowpassSetting};
use serde::Serialize;
use skyloop_lti::StateSpace;
use skyloop_robust::structured::blocks::Block;
pub mod flight;
pub mod header;

pub use header::InavTuning;

/// `FP_PID_RATE_P_MULTIPLIER`: Kp = P/31.
pub const P_MULTIPLIER: f64 = 31.0;
/// `FP_PID_RATE_I_MULTIPLIER`: Ki = I/4.
pub const I_MULTIPLIER: f64 = 4.0;
/// `FP_PID_RATE_D_MULTIPLIER`: Kd = D/1905.
pub const D_MULTIPLIER: f64 = 1905.0;
/// `FP_PID_RATE_D_FF_MULTIPLIER`: the multicopter control derivative Kcd = CD/7270.
pub const CD_MULTIPLIER: f64 = 7270.0;
/// Largest gain INAV accepts for `mc_p/i/d/cd_<axis>` (0..255).
pub const GAIN_MAX: u32 = 255;
/// The `mc_cd_lpf_hz` default, Hz.
pub const CD_LPF_DEFAULT_HZ: f64 = 30.0;

/// INAV's integer gains of one axis (default: all 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct Gains {
    /// `mc_p_<axis>`.
    pub p: u32,
    /// `mc_i_<axis>`.
    pub i: u32,
    /// `mc_d_<axis>`.
    pub d: u32,
    /// `mc_cd_<axis>` (control derivative: the multicopter feedforward).
    pub cd: u32,
}

/// The controller's filters and loop rate.
#[derive(Debug, Clone, PartialEq)]
pub struct Filters {
    /// D-term lowpass chain (`dterm_lpf_hz`, older INAV's `dterm_lpf2_hz` and D-term notch).
    pub dterm: Vec<Lowpass>,
    /// `mc_cd_lpf_hz`: the lowpass on the control derivative's target difference (0: none).
    pub cd_lpf_hz: f64,
    /// PID loop rate, Hz.
    pub loop_hz: f64,
}

impl Default for Filters {
    /// INAV's multicopter defaults: D-term PT1 at 110 Hz, control derivative lowpass 30 Hz, 1 kHz
    /// PID loop.
    fn default() -> Self {
        Filters {
            dterm: vec![Lowpass::Pt1(110.0)],
            cd_lpf_hz: CD_LPF_DEFAULT_HZ,
            loop_hz: 1000.0,
        }
    }
}

/// Continuous gains in the plant's units: (Kp, Ki, Kd, Kcd).
pub fn continuous(g: &Gains) -> (f64, f64, f64, f64) {
    (
        g.p as f64 / P_MULTIPLIER,
        g.i as f64 / I_MULTIPLIER,
        g.d as f64 / D_MULTIPLIER,
        g.cd as f64 / CD_MULTIPLIER,
    )
}

/// The nearest integer gains for continuous (Kp, Ki, Kd) and a given CD.
///
/// # Errors
/// A negative gain or one above 255 once scaled, named.
pub fn from_continuous(kp: f64, ki: f64, kd: f64, cd: u32, axis: Axis) -> Result<Gains> {
    let conv = |name: &str, k: f64, m: f64| {
        super::integer_gain(&format!("INAV mc_{name}_{}", axis.name()), k, k * m, GAIN_MAX)
    };
    if cd > GAIN_MAX {
        return Err(Error::Input(format!(
            "INAV mc_cd_{} = {cd} is outside 0..={GAIN_MAX}",
            axis.name()
        )));
    }
    Ok(Gains {
        p: conv("p", kp, P_MULTIPLIER)?,
        i: conv("i", ki, I_MULTIPLIER)?,
        d: conv("d", kd, D_MULTIPLIER)?,
        cd,
    })
}

/// The tunable structure: P and I on the error as the gyro arrives (no filter in the
/// controller), D on the measurement through the D-term chain (a PT1 at a quarter of the loop
/// rate when none is configured).
///
/// # Errors
/// Invalid filter cutoffs.
pub fn block(filters: &Filters) -> Result<Block> {
    let mut d_stages = filters.dterm.clone();
    if d_stages.is_empty() {
        d_stages.push(derivative_rolloff(filters.loop_hz));
    }
    let d_filter = chain(&d_stages)?.ok_or("empty D filter chain")?;
    Ok(Block::PidFiltered {
        pi_filter: None,
        d_filter,
    })
}

/// C_fb(s) (y → u, plant units) of the gains with these filters.
///
/// # Errors
/// Invalid filter cutoffs.
pub fn feedback_controller(g: &Gains, filters: &Filters) -> Result<StateSpace> {
    let (kp, ki, kd, _) = continuous(g);
    Ok(block(filters)?.realize(&[kp, ki, kd])?)
}

/// The control derivative's path per unit of continuous Kcd: s·F_cd(s), F_cd a PT2 at
/// `cd_lpf_hz` (with none configured, the backward difference's s/(T·s + 1), T the loop period).
///
/// # Errors
/// A loop rate or cutoff that is not positive.
pub fn feedforward_unit(filters: &Filters) -> Result<StateSpace> {
    if !(filters.cd_lpf_hz > 0.0) {
        return super::betaflight::feedforward_unit(filters.loop_hz);
    }
    super::hold_delay_s(filters.loop_hz)?;
    let lp = Lowpass::Pt2(filters.cd_lpf_hz).model()?;
    // s·C(sI − A)⁻¹B = C·A·(sI − A)⁻¹B + C·B (F_cd strictly proper).
    let c = &lp.c * &lp.a;
    let d = &lp.c * &lp.b;
    Ok(StateSpace::new(lp.a.clone(), lp.b.clone(), c, d, 0.0)?)
}

/// C_r(s) = Kp + Ki/s + Kcd·s·F_cd(s): the path from the rate target to u.
///
/// # Errors
/// As [`feedforward_unit`].
pub fn reference_path(g: &Gains, filters: &Filters) -> Result<StateSpace> {
    let (kp, ki, _, kcd) = continuous(g);
    let pi = StateSpace::from_rows(&[vec![0.0]], &[vec![1.0]], &[vec![ki]], &[vec![kp]], 0.0)?;
    let mut f = feedforward_unit(filters)?;
    f.c = &f.c * kcd;
    f.d = &f.d * kcd;
    Ok(skyloop_lti::interconnect::parallel(&pi, &f)?)
}

/// INAV CLI lines that load the gains.
pub fn cli_lines(g: &Gains, axis: Axis) -> Vec<String> {
    let a = axis.name();
    vec![
        format!("set mc_p_{a} = {}", g.p),
        format!("set mc_i_{a} = {}", g.i),
        format!("set mc_d_{a} = {}", g.d),
        format!("set mc_cd_{a} = {}", g.cd),
        "save".to_string(),
    ]
}

/// The flown tune of one axis as an INAV header states it.
#[derive(Debug, Clone, PartialEq)]
pub struct FlownHeader {
    /// The controller's filters (the gyro filters are inside the identified plant) and loop rate.
    pub filters: Filters,
    /// The header's gains; None when the header has none for the axis.
    pub gains: Option<Gains>,
    /// The filter settings as a report lists them.
    pub lines: Vec<String>,
    /// What the analysis assumes.
    pub notes: Vec<String>,
}

/// The lowpass cutoffs `tune --tune-filters` may move: the gyro main lowpass (`gyro_main_lpf_hz`,
/// or older INAV's `gyro_lpf_hz`, whichever the header holds; throttle-following:
/// `gyro_dyn_lpf_min_hz`/`gyro_dyn_lpf_max_hz`) and the D-term lowpasses (`dterm_lpf_hz`,
/// `dterm_lpf2_hz`), where on.
pub fn filter_settings(t: &InavTuning, log: &skyloop_sysid::logs::Log) -> FilterSettings {
    let gyro_name = if log.setting("gyro_main_lpf_hz").is_some() {
        "gyro_main_lpf_hz"
    } else {
        "gyro_lpf_hz"
    };
    let table: [HeaderStage; 3] = [
        (
            &t.gyro_lowpass,
            Knob::Gyro,
            gyro_name,
            "gyro_dyn_lpf_min_hz",
            "gyro_dyn_lpf_max_hz",
        ),
        (&t.dterm_lowpass, Knob::Dterm, "dterm_lpf_hz", "", ""),
        (&t.dterm_lowpass2, Knob::Dterm, "dterm_lpf2_hz", "", ""),
    ];
    from_header_stages(&table)
}

/// Reads the flown tune of `axis` from an INAV header.
pub fn flown_from_header(t: &InavTuning, axis: Axis) -> FlownHeader {
    let (mut lines, mut notes) = (Vec::new(), Vec::new());
    let dterm = super::dterm_chain(
        &[(&t.dterm_lowpass, "dterm_lpf"), (&t.dterm_lowpass2, "dterm_lpf2")],
        t.dterm_notch,
        &mut lines,
        &mut notes,
    );
    if let Some(g) = &t.gyro_lowpass {
        lines.push(format!(
            "gyro main lowpass: {} at {} Hz (inside the identified plant: gyroADC is logged after it)",
            g.kind, g.cutoff_hz
        ));
    }
    for n in &t.gyro_notches {
        lines.push(format!(
            "gyro notch {} Hz, cutoff {} Hz (inside the identified plant)",
            n.center_hz, n.cutoff_hz
        ));
    }
    let cd_lpf_hz = t.cd_lpf_hz.unwrap_or_else(|| {
        notes.push(format!(
            "the header has no mc_cd_lpf_hz: INAV's default {CD_LPF_DEFAULT_HZ} Hz is assumed for the control derivative"
        ));
        CD_LPF_DEFAULT_HZ
    });
    lines.push(format!(
        "mc_cd_lpf_hz: {cd_lpf_hz} Hz (control derivative, reference path)"
    ));
    let loop_hz = t.pid_rate_hz.unwrap_or_else(|| {
        notes.push("the header has no looptime: a 1 kHz PID loop is assumed".into());
        1000.0
    });
    lines.push(format!("PID loop {loop_hz:.0} Hz"));
    if axis == Axis::Yaw {
        if let Some(y) = t.yaw_lpf_hz.filter(|y| *y > 0.0) {
            notes.push(format!("yaw_lpf_hz {y}: the lowpass on yaw's P term is not modelled"));
        }
    }
    let gains = t.pid.get(axis.index()).map(|p| {
        let to_u = |v: f64| v.round().clamp(0.0, f64::from(GAIN_MAX)) as u32;
        Gains {
            p: to_u(p.p),
            i: to_u(p.i),
            d: to_u(p.d),
            cd: to_u(p.cd.unwrap_or(0.0)),
        }
    });
    notes.push("not modelled: TPA, anti-gravity, I-term relax, D-boost, Smith predictor".into());
    FlownHeader {
        filters: Filters {
            dterm,
            cd_lpf_hz,
            loop_hz,
        },
        gains,
        lines,
        notes,
    }
}

/// INAV's filter chain from its header at the PID loop rate: the gyro main lowpass and static
/// notches, the D-term lowpass(es) and notch (INAV's dynamic gyro notch is not read).
pub fn filter_chain(t: &InavTuning) -> (FilterChain, Vec<String>) {
    let mut notes = Vec::new();
    let mut stages = Vec::new();
    let mut lowpass = |l: &Option<LowpassSetting>, name: &str, path: Path| {
        if let Some(l) = l.as_ref().filter(|l| l.cutoff_hz > 0.0) {
            let shape = Shape::from_header(&l.kind).unwrap_or_else(|| {
                notes.push(format!("{name}: filter type {} is not modelled; taken as PT1", l.kind));
                Shape::Pt1
            });
            stages.push(Stage {
                name: name.into(),
                path,
                kind: StageKind::Lowpass { shape, hz: l.cutoff_hz },
            });
        }
    };
    lowpass(&t.gyro_lowpass, "gyro_lpf1", Path::Gyro);
    lowpass(&t.dterm_lowpass, "dterm_lpf1", Path::Dterm);
    lowpass(&t.dterm_lowpass2, "dterm_lpf2", Path::Dterm);
    stages.extend(static_notches(&t.gyro_notches, t.dterm_notch));
    notes.push("INAV's dynamic gyro notch and its Kalman gyro filter are not modelled".into());
    let loop_hz = t.pid_rate_hz.unwrap_or_else(|| {
        notes.push("the header has no loop time: a 1 kHz PID loop is assumed".into());
        1000.0
    });
    (FilterChain { loop_hz, stages }, notes)
}

/// The header's tuning as `log info` lists it, in INAV's names: the PID of each axis, the filters, the loop rate, TPA and the motor range.
pub fn header_lines(t: &InavTuning) -> Vec<String> {
    let mut out = Vec::new();
    out.push(format!("tuning (INAV: {}):", t.firmware_revision));
    for (axis, g) in ["roll", "pitch", "yaw"].iter().zip(&t.pid) {
        out.push(format!(
            "  {axis:<5} mc_p {} mc_i {} mc_d {} mc_cd {}",
            g.p,
            g.i,
            g.d,
            super::opt(g.cd)
        ));
    }
    let lp = |name: &str, l: &Option<LowpassSetting>| match l {
        Some(l) => format!("  {name}: {} {} Hz", l.kind, l.cutoff_hz),
        None => format!("  {name}: off"),
    };
    out.push(lp("gyro main lowpass", &t.gyro_lowpass));
    out.push(lp("D-term lowpass (dterm_lpf)", &t.dterm_lowpass));
    if t.dterm_lowpass2.is_some() {
        out.push(lp("D-term lowpass 2 (dterm_lpf2)", &t.dterm_lowpass2));
    }
    if let Some(n) = &t.dterm_notch {
        out.push(format!("  D-term notch: {} Hz, cutoff {} Hz", n.center_hz, n.cutoff_hz));
    }
    for n in &t.gyro_notches {
        out.push(format!("  gyro notch: {} Hz, cutoff {} Hz", n.center_hz, n.cutoff_hz));
    }
    out.push(format!(
        "  yaw_lpf_hz {}, mc_cd_lpf_hz {}; loop: PID {} Hz; TPA {} % from {} us",
        super::opt(t.yaw_lpf_hz),
        super::opt(t.cd_lpf_hz),
        super::opt(t.pid_rate_hz.map(|h| (h * 10.0).round() / 10.0)),
        super::opt(t.tpa_rate_percent),
        super::opt(t.tpa_breakpoint_us)
    ));
    out.push(format!(
        "  motorOutput {}, minthrottle {}, maxthrottle {}",
        t.motor_output.map_or("-".into(), |(a, b)| format!("{a}..{b}")),
        super::opt(t.min_throttle),
        super::opt(t.max_throttle)
    ));
    out
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::header::InavPid;
    use super::*;
    use crate::firmware::vocab::LowpassSetting as HL;
    use skyloop_lti::c64;

    /// Well below the D-term filter C_fb(jω) = P/31 + (I/4)/(jω) + (D/1905)·jω (pid.h's multipliers).
    #[test]
    fn low_frequency_part_is_the_scaled_pid() {
        let g = Gains {
            p: 40,
            i: 30,
            d: 23,
            cd: 60,
        };
        let (kp, ki, kd, kcd) = continuous(&g);
        assert!((kp - 40.0 / 31.0).abs() < 1e-12);
        assert!((ki - 7.5).abs() < 1e-12);
        assert!((kd - 23.0 / 1905.0).abs() < 1e-12);
        assert!((kcd - 60.0 / 7270.0).abs() < 1e-12);
        let f = Filters::default();
        let c = feedback_controller(&g, &f).unwrap();
        for w in [0.05, 0.5, 2.0] {
            let s = c64::new(0.0, w);
            let got = skyloop_lti::freqresp::evalfr(&c, s).unwrap()[(0, 0)];
            let want = kp + ki / s + kd * s;
            assert!((got - want).norm() < 2e-3 * want.norm(), "w {w}: {got} vs {want}");
        }
        // The reference path: Kp + Ki/s + Kcd·s at low frequency.
        let r = reference_path(&g, &f).unwrap();
        let s = c64::new(0.0, 1.0);
        let got = skyloop_lti::freqresp::evalfr(&r, s).unwrap()[(0, 0)];
        let want = kp + ki / s + kcd * s;
        assert!((got - want).norm() < 1e-3 * want.norm(), "{got} vs {want}");
        // Rounding round trip, the range named, the CLI lines.
        assert_eq!(from_continuous(kp, ki, kd, 60, Axis::Roll).unwrap(), g);
        let e = from_continuous(100.0, ki, kd, 0, Axis::Pitch).unwrap_err().to_string();
        assert!(e.contains("mc_p_pitch") && e.contains("0..=255"), "{e}");
        assert_eq!(
            cli_lines(&g, Axis::Roll),
            [
                "set mc_p_roll = 40",
                "set mc_i_roll = 30",
                "set mc_d_roll = 23",
                "set mc_cd_roll = 60",
                "save"
            ]
        );
    }

    #[test]
    fn flown_tune_from_an_inav_header() {
        let t = InavTuning {
            firmware_revision: "INAV 9.0.1 (abc) IFLIGHT_BLITZ_F722".into(),
            version_major: Some(9),
            pid: vec![
                InavPid {
                    p: 44.0,
                    i: 75.0,
                    d: 25.0,
                    cd: Some(60.0),
                },
                InavPid {
                    p: 46.0,
                    i: 80.0,
                    d: 26.0,
                    cd: Some(60.0),
                },
            ],
            gyro_lowpass: Some(HL {
                kind: "PT1".into(),
                cutoff_hz: 110.0,
                dynamic_hz: None,
            }),
            dterm_lowpass: Some(HL {
                kind: "PT3".into(),
                cutoff_hz: 110.0,
                dynamic_hz: None,
            }),
            dterm_lowpass2: None,
            dterm_notch: None,
            gyro_notches: vec![],
            yaw_lpf_hz: Some(30.0),
            cd_lpf_hz: None,
            pid_rate_hz: Some(1e6 / 1022.0),
            motor_output: Some((1000.0, 2000.0)),
            min_throttle: Some(1000.0),
            max_throttle: Some(2000.0),
            tpa_rate_percent: Some(0.0),
            tpa_breakpoint_us: Some(1500.0),
        };
        let h = flown_from_header(&t, Axis::Pitch);
        assert_eq!(
            h.gains,
            Some(Gains {
                p: 46,
                i: 80,
                d: 26,
                cd: 60
            })
        );
        assert_eq!(h.filters.dterm, vec![Lowpass::Pt3(110.0)]);
        assert_eq!(h.filters.cd_lpf_hz, CD_LPF_DEFAULT_HZ);
        assert!((h.filters.loop_hz - 978.47).abs() < 0.01, "{}", h.filters.loop_hz);
        assert!(
            h.lines.iter().any(|l| l.contains("gyro main lowpass: PT1 at 110 Hz")),
            "{:?}",
            h.lines
        );
        assert!(flown_from_header(&t, Axis::Yaw).gains.is_none());
    }
}
