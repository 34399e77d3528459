//! Firmware rate-controller structures and their gain mappings: the gains a pilot types into the
//! flight controller ↔ the loop's feedback controller C_fb(s) (y → u, what margins use) and the
//! reference path, in the plant's units.
//!
//! - [`betaflight`]: Betaflight's PIDF (P and I on the error, D on the measurement, F on the
//!   setpoint derivative) with its scale factors from `pid.h` and the gyro / D-term lowpass chain.
//! - [`inav`]: INAV's multicopter rate PID (P and I on the error, D on the measurement through the
//!   D-term lowpass, the control derivative `mc_cd` on the target) with its `FP_PID_RATE_*`
//!   multipliers.
//! - [`px4`]: PX4's multicopter rate PID `MC_{ROLL,PITCH,YAW}RATE_{K,P,I,D,FF}` (parallel form,
//!   K scales P, I and D), D on the measurement through `IMU_DGYRO_CUTOFF`, P and I through
//!   `IMU_GYRO_CUTOFF`.
//!
//! Both are continuous models of discrete firmware: the filters are their continuous prototypes at
//! the configured (for dynamic filters: the given operating-point) cutoff, and the loop's sample
//! and hold is a delay of half a loop period added to the plant (`hold_delay_s`); the discrete
//! controller at the loop rate is C_fb mapped by Tustin ([`discrete`]).

pub mod ardupilot;
pub mod betaflight;
pub mod channels;
pub mod filter_settings;
pub mod filters;
pub mod flown;
pub mod inav;
mod knobs;
mod optimum;
pub mod px4;
pub mod rate_gains;

use crate::error::{Error, Result};
use skyloop_lti::discretize::{c2d, Method};
use skyloop_lti::interconnect::series;
use skyloop_lti::{Mat, StateSpace};
use std::f64::consts::PI;

/// The flight-control firmware whose controller structure, gains and pasteable lines a tune uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Firmware {
    /// Betaflight PIDF (integers p, i, d, f).
    Betaflight,
    /// INAV multicopter rate PID (integers mc_p, mc_i, mc_d, mc_cd).
    Inav,
    /// PX4 multicopter rate PID (MC_*RATE_*).
    Px4,
    /// ArduPilot multicopter rate PID (ATC_RAT_*).
    Ardupilot,
    /// C = kp + ki/s + kd·s/(tf·s + 1) in the plant's units.
    Generic,
}

impl Firmware {
    /// Parses "betaflight", "inav", "px4", "ardupilot" or "generic".
    ///
    /// # Errors
    /// Any other text.
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "betaflight" => Ok(Firmware::Betaflight),
            "inav" => Ok(Firmware::Inav),
            "px4" => Ok(Firmware::Px4),
            "ardupilot" => Ok(Firmware::Ardupilot),
            "generic" => Ok(Firmware::Generic),
            _ => Err(Error::Input(format!(
                "--firmware must be betaflight, inav, px4, ardupilot or generic, got `{s}`"
            ))),
        }
    }

    /// The name `--firmware` takes.
    pub fn name(&self) -> &'static str {
        match self {
            Firmware::Betaflight => "betaflight",
            Firmware::Inav => "inav",
            Firmware::Px4 => "px4",
            Firmware::Ardupilot => "ardupilot",
            Firmware::Generic => "generic",
        }
    }

    /// The name a pilot knows it by ("Betaflight", "PX4", ...).
    pub fn display_name(&self) -> &'static str {
        match self {
            Firmware::Betaflight => "Betaflight",
            Firmware::Inav => "INAV",
            Firmware::Px4 => "PX4",
            Firmware::Ardupilot => "ArduPilot",
            Firmware::Generic => "generic",
        }
    }

    /// The firmware that wrote `log` (None: a CSV file, which names none).
    pub fn of_log(log: &skyloop_sysid::logs::Log) -> Option<Firmware> {
        use skyloop_sysid::logs::flight::FlightFirmware;
        match FlightFirmware::of(log).ok()? {
            FlightFirmware::Betaflight => Some(Firmware::Betaflight),
            FlightFirmware::Inav => Some(Firmware::Inav),
            FlightFirmware::Px4 => Some(Firmware::Px4),
            FlightFirmware::Ardupilot => Some(Firmware::Ardupilot),
        }
    }

    /// The units of its logged rate loop, for the 6-DOF check: (gyro unit in rad/s, largest
    /// controller output), None for a firmware whose log units are not known.
    pub fn flight_units(&self) -> Option<(f64, f64)> {
        match self {
            // gyroADC in deg/s; the PID sum is limited to ±500 (pidsum_limit; INAV's too).
            Firmware::Betaflight | Firmware::Inav => Some((PI / 180.0, 500.0)),
            // rad/s; normalized torque in [−1, 1].
            Firmware::Px4 => Some((1.0, 1.0)),
            // RATE.R in deg/s; RATE.ROut, the mixer's command, in [−1, 1].
            Firmware::Ardupilot => Some((ardupilot::LOG_RATE_UNIT_RAD_S, 1.0)),
            Firmware::Generic => None,
        }
    }
}

/// Reads a log (blackbox `session` counted from 1; None: the longest) and prepares it for its
/// firmware ([`prepare_log`]); returns it with the notes of what was derived.
///
/// # Errors
/// An unreadable or unrecognised file.
pub fn open_log(path: &std::path::Path, session: Option<usize>) -> Result<(skyloop_sysid::logs::Log, Vec<String>)> {
    let mut log = skyloop_sysid::logs::Log::open(
        path,
        &skyloop_sysid::logs::OpenOptions {
            session,
            ..Default::default()
        },
    )?;
    let notes = prepare_log(&mut log);
    Ok((log, notes))
}

/// [`open_log`] on a log's bytes already in memory (a browser's dropped file); `name` names it in
/// messages.
///
/// # Errors
/// A file that is not a log the readers know, or a session that is not in it.
pub fn open_log_bytes(
    bytes: &[u8],
    name: &str,
    session: Option<usize>,
) -> Result<(skyloop_sysid::logs::Log, Vec<String>)> {
    let mut log = skyloop_sysid::logs::Log::from_bytes(
        bytes,
        name,
        &skyloop_sysid::logs::OpenOptions {
            session,
            ..Default::default()
        },
    )?;
    let notes = prepare_log(&mut log);
    Ok((log, notes))
}

/// Interprets a freshly read log for the firmware that wrote it: channels the firmware computes but
/// does not record are derived (Betaflight 3.x: the setpoint from rcCommand through the rate
/// curve). Returns notes saying what was derived.
pub fn prepare_log(log: &mut skyloop_sysid::logs::Log) -> Vec<String> {
    use skyloop_sysid::logs::tuning::FirmwareTuning;
    let mut notes = Vec::new();
    if let Some(FirmwareTuning::Betaflight(b)) = FirmwareTuning::from_log(log) {
        notes.extend(betaflight::add_setpoint_from_rc(log, &b.rates));
    }
    notes
}

/// The D-term chain a blackbox header states (Betaflight, INAV): its lowpass stages, named as the
/// header names them, then its static notch, modelled; a report line per stage goes to `lines`.
pub(crate) fn dterm_chain(
    stages: &[(&Option<skyloop_sysid::logs::tuning::Lowpass>, &str)],
    notch: Option<skyloop_sysid::logs::tuning::Notch>,
    lines: &mut Vec<String>,
    notes: &mut Vec<String>,
) -> Vec<Lowpass> {
    let mut dterm = Vec::new();
    for (l, name) in stages {
        if let Some(l) = l {
            if let Some(lp) = header_lowpass(l, notes, name) {
                lines.push(format!(
                    "{name}: {} at {} Hz (in the controller)",
                    l.kind,
                    lp.cutoff_hz()
                ));
                dterm.push(lp);
            }
        }
    }
    if let Some(n) = notch {
        lines.push(format!(
            "dterm_notch: {} Hz, cutoff {} Hz (in the controller)",
            n.center_hz, n.cutoff_hz
        ));
        dterm.push(Lowpass::Notch(n.center_hz, n.cutoff_hz));
    }
    dterm
}

/// The model of a header's lowpass stage (a dynamic one at the low end of its range: hover
/// throttle, the most lag); None when it is off.
pub(crate) fn header_lowpass(
    l: &skyloop_sysid::logs::tuning::Lowpass,
    notes: &mut Vec<String>,
    name: &str,
) -> Option<Lowpass> {
    let f = match l.dynamic_hz {
        Some((lo, _)) => lo,
        None => l.cutoff_hz,
    };
    if !(f > 0.0) {
        return None;
    }
    Some(match l.kind.as_str() {
        "PT1" => Lowpass::Pt1(f),
        "PT2" => Lowpass::Pt2(f),
        "PT3" => Lowpass::Pt3(f),
        "BIQUAD" => Lowpass::Biquad(f),
        other => {
            notes.push(format!(
                "{name}: filter type {other} is not modelled; taken as PT1 at {f} Hz"
            ));
            Lowpass::Pt1(f)
        }
    })
}

/// A lowpass stage, cutoff in Hz, as the firmware defines it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Lowpass {
    /// First order ω/(s + ω).
    Pt1(f64),
    /// Two PT1 stages, each at f/√(2^{1/2} − 1) so the pair is −3 dB at f (Betaflight `pt2FilterGain`).
    Pt2(f64),
    /// Three PT1 stages, each at f/√(2^{1/3} − 1) (Betaflight `pt3FilterGain`).
    Pt3(f64),
    /// Second-order Butterworth ω²/(s² + √2·ω·s + ω²) (Betaflight BIQUAD, PX4's LowPassFilter2p).
    Biquad(f64),
    /// A notch (centre, lower cutoff), Hz: (s² + ω₀²)/(s² + (ω₀/Q)·s + ω₀²) with Betaflight's
    /// Q = f₀·f_c/(f₀² − f_c²) (`filterGetNotchQ`).
    Notch(f64, f64),
}

impl Lowpass {
    /// The cutoff in Hz.
    pub fn cutoff_hz(&self) -> f64 {
        match *self {
            Lowpass::Pt1(f) | Lowpass::Pt2(f) | Lowpass::Pt3(f) | Lowpass::Biquad(f) | Lowpass::Notch(f, _) => f,
        }
    }

    /// The same kind of stage at cutoff `f_hz`; a notch is returned unchanged (it sits on a
    /// resonance, not at a cutoff one moves).
    pub fn with_cutoff(self, f_hz: f64) -> Lowpass {
        match self {
            Lowpass::Pt1(_) => Lowpass::Pt1(f_hz),
            Lowpass::Pt2(_) => Lowpass::Pt2(f_hz),
            Lowpass::Pt3(_) => Lowpass::Pt3(f_hz),
            Lowpass::Biquad(_) => Lowpass::Biquad(f_hz),
            n @ Lowpass::Notch(..) => n,
        }
    }

    /// The same stage with its cutoff scaled by `k` and rounded to whole Hz (the firmware's
    /// settings are integers); a notch is returned unchanged.
    pub fn scaled(self, k: f64) -> Lowpass {
        self.with_cutoff(scaled_cutoff_hz(self.cutoff_hz(), k))
    }

    /// True for a lowpass (not a notch).
    pub fn is_lowpass(&self) -> bool {
        !matches!(self, Lowpass::Notch(..))
    }

    /// The continuous filter's poles, rad/s (a notch's too: its zeros are not returned).
    ///
    /// # Errors
    /// A cutoff that is not a finite positive number.
    pub fn poles(&self) -> Result<Vec<skyloop_lti::c64>> {
        use skyloop_lti::c64;
        // Written out, not computed as eigenvalues: PT2's and PT3's repeated poles would come
        // back perturbed by ~eps^(1/n), and a de-embedding ratio must cancel them exactly.
        self.model()?;
        let w = 2.0 * PI * self.cutoff_hz();
        let pt = |n: i32| vec![c64::new(-w / (2f64.powf(1.0 / f64::from(n)) - 1.0).sqrt(), 0.0); n as usize];
        Ok(match *self {
            Lowpass::Pt1(_) => vec![c64::new(-w, 0.0)],
            Lowpass::Pt2(_) => pt(2),
            Lowpass::Pt3(_) => pt(3),
            Lowpass::Biquad(_) => {
                let h = w * std::f64::consts::FRAC_1_SQRT_2;
                vec![c64::new(-h, h), c64::new(-h, -h)]
            }
            Lowpass::Notch(f0, fc) => {
                let w0 = 2.0 * PI * f0;
                let b = w0 / (f0 * fc / (f0 * f0 - fc * fc));
                let disc = b * b - 4.0 * w0 * w0;
                if disc >= 0.0 {
                    vec![
                        c64::new((-b + disc.sqrt()) / 2.0, 0.0),
                        c64::new((-b - disc.sqrt()) / 2.0, 0.0),
                    ]
                } else {
                    let im = (-disc).sqrt() / 2.0;
                    vec![c64::new(-b / 2.0, im), c64::new(-b / 2.0, -im)]
                }
            }
        })
    }

    /// The continuous filter.
    ///
    /// # Errors
    /// A cutoff that is not a finite positive number.
    pub fn model(&self) -> Result<StateSpace> {
        let f = self.cutoff_hz();
        if !(f.is_finite() && f > 0.0) {
            return Err(Error::Input(format!(
                "lowpass cutoff must be a positive number of Hz, got {f}"
            )));
        }
        let w = 2.0 * PI * f;
        let pt = |n: i32| -> Result<StateSpace> {
            let ws = w / (2f64.powf(1.0 / n as f64) - 1.0).sqrt();
            let one = StateSpace::new(m1(-ws), m1(ws), m1(1.0), m1(0.0), 0.0)?;
            let mut acc = one.clone();
            for _ in 1..n {
                acc = series(&acc, &one)?;
            }
            Ok(acc)
        };
        Ok(match self {
            Lowpass::Pt1(_) => StateSpace::new(m1(-w), m1(w), m1(1.0), m1(0.0), 0.0)?,
            Lowpass::Pt2(_) => pt(2)?,
            Lowpass::Pt3(_) => pt(3)?,
            Lowpass::Notch(f0, fc) => notch(*f0, *fc)?,
            Lowpass::Biquad(_) => StateSpace::from_rows(
                &[vec![0.0, 1.0], vec![-w * w, -std::f64::consts::SQRT_2 * w]],
                &[vec![0.0], vec![w * w]],
                &[vec![1.0, 0.0]],
                &[vec![0.0]],
                0.0,
            )?,
        })
    }
}

/// Betaflight's notch at centre `f0` with lower cutoff `fc`, Hz.
fn notch(f0: f64, fc: f64) -> Result<StateSpace> {
    if !(fc.is_finite() && fc > 0.0 && fc < f0) {
        return Err(Error::Input(format!(
            "notch cutoff must lie in (0, {f0}) Hz (below its centre), got {fc}"
        )));
    }
    let w = 2.0 * PI * f0;
    let q = f0 * fc / (f0 * f0 - fc * fc);
    // (s² + w²)/(s² + (w/Q)s + w²) = 1 + (−(w/Q)s)/(s² + (w/Q)s + w²).
    Ok(StateSpace::from_rows(
        &[vec![0.0, 1.0], vec![-w * w, -w / q]],
        &[vec![0.0], vec![1.0]],
        &[vec![0.0, -w / q]],
        &[vec![1.0]],
        0.0,
    )?)
}

fn m1(v: f64) -> Mat<f64> {
    Mat::from_fn(1, 1, |_, _| v)
}

/// The SISO static gain `v` (a controller path without states).
///
/// # Errors
/// A non-finite gain.
pub(crate) fn static_gain(v: f64) -> Result<StateSpace> {
    Ok(StateSpace::gain(m1(v), 0.0)?)
}

/// A cutoff `hz` scaled by `k` and rounded to whole Hz (the firmwares store integers), at least 1.
pub fn scaled_cutoff_hz(hz: f64, k: f64) -> f64 {
    (hz * k).round().max(1.0)
}

/// `stages` with every lowpass cutoff scaled by `k` ([`Lowpass::scaled`]; notches kept).
pub fn scale_lowpasses(stages: &[Lowpass], k: f64) -> Vec<Lowpass> {
    stages
        .iter()
        .map(|l| if l.is_lowpass() { l.scaled(k) } else { *l })
        .collect()
}

/// The lowest lowpass cutoff of `stages`, Hz (None without a lowpass).
pub fn lowest_cutoff_hz(stages: &[Lowpass]) -> Option<f64> {
    stages
        .iter()
        .filter(|l| l.is_lowpass())
        .map(Lowpass::cutoff_hz)
        .min_by(f64::total_cmp)
}

/// The series connection of `stages` (None when empty: no filter).
///
/// # Errors
/// As [`Lowpass::model`].
pub fn chain(stages: &[Lowpass]) -> Result<Option<StateSpace>> {
    let mut acc: Option<StateSpace> = None;
    for s in stages {
        let m = s.model()?;
        acc = Some(match acc {
            None => m,
            Some(a) => series(&a, &m)?,
        });
    }
    Ok(acc)
}

/// The integer a firmware stores for continuous gain `k`, `scaled` being k in the firmware's units
/// (rounded here), checked against 0..=`max`; `label` names the parameter in the error
/// ("Betaflight p_roll", "INAV mc_p_roll").
///
/// # Errors
/// A rounded value outside 0..=`max` (negative, too large or NaN).
pub(crate) fn integer_gain(label: &str, k: f64, scaled: f64, max: u32) -> Result<u32> {
    let v = scaled.round();
    if !(v >= 0.0 && v <= max as f64) {
        return Err(Error::Input(format!(
            "{label} = {v} is outside 0..={max} (continuous gain {k:.6e}); the plant's units may not be PID sum per deg/s"
        )));
    }
    Ok(v as u32)
}

/// The loop rate's sample and hold as a delay: half a period (the zero-order hold's average lag).
///
/// # Errors
/// A loop rate that is not a finite positive number.
pub fn hold_delay_s(loop_hz: f64) -> Result<f64> {
    if !(loop_hz.is_finite() && loop_hz > 0.0) {
        return Err(Error::Input(format!(
            "the loop rate must be a positive number of Hz, got {loop_hz}"
        )));
    }
    Ok(0.5 / loop_hz)
}

/// Six significant digits: PX4 and ArduPilot store floats, and D ~ 0.003 at four decimals would
/// move by 3 %.
pub(crate) fn round6(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let e = 10f64.powi(5 - x.abs().log10().floor() as i32);
    (x * e).round() / e
}

/// C_fb at the loop rate (Tustin), the discrete form the firmware runs to first order.
///
/// # Errors
/// As [`hold_delay_s`], or a discretization failure.
pub fn discrete(c_fb: &StateSpace, loop_hz: f64) -> Result<StateSpace> {
    hold_delay_s(loop_hz)?;
    Ok(c2d(c_fb, 1.0 / loop_hz, Method::Tustin { prewarp_rad_s: None })?)
}

/// The D-path filter of a PID with no D filter configured: a lowpass at half the loop's Nyquist
/// rate stands in for the discrete derivative's own roll-off (a continuous kd·s is improper).
pub(crate) fn derivative_rolloff(loop_hz: f64) -> Lowpass {
    Lowpass::Pt1(loop_hz / 4.0)
}

/// An optional header number as text ("-" when the log has none).
pub(crate) fn opt(x: Option<f64>) -> String {
    x.map_or("-".to_string(), |v| format!("{v}"))
}

/// The tuning a log's header states, as `log info` lists it, in the firmware's own names.
pub fn header_lines(t: &skyloop_sysid::logs::tuning::FirmwareTuning) -> Vec<String> {
    use skyloop_sysid::logs::tuning::FirmwareTuning;
    match t {
        FirmwareTuning::Betaflight(b) => betaflight::header_lines(b),
        FirmwareTuning::Inav(t) => inav::header_lines(t),
        FirmwareTuning::Px4(p) => px4::header_lines(p),
        FirmwareTuning::ArduPilot(a) => ardupilot::header_lines(a),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use skyloop_lti::c64;

    #[test]
    fn every_lowpass_is_minus_3_db_at_its_cutoff() {
        for lp in [
            Lowpass::Pt1(100.0),
            Lowpass::Pt2(100.0),
            Lowpass::Pt3(100.0),
            Lowpass::Biquad(100.0),
        ] {
            let g =
                skyloop_lti::freqresp::evalfr(&lp.model().unwrap(), c64::new(0.0, 2.0 * PI * 100.0)).unwrap()[(0, 0)];
            assert!((g.norm() - 0.5f64.sqrt()).abs() < 1e-9, "{lp:?}: {}", g.norm());
        }
        assert!(Lowpass::Pt1(-1.0).model().is_err());
    }
}
