//! The lowpass cutoffs `tune --tune-filters` may move, as each firmware names them: the gyro
//! lowpass (on every term, before the logged gyro) and the D-term lowpass (on D only). Each
//! firmware's module says which settings it has and what they are called
//! ([`super::betaflight::filter_settings`], [`super::inav::filter_settings`],
//! [`super::px4::filter_settings`], [`super::ardupilot::filter_settings`]); this module scales
//! them and writes the lines that load them.
//!
//! Why the gyro lowpass needs more than the D-term's: the logged gyro is after it, so the plant
//! identified from the log already contains it. A candidate gyro lowpass G_new is put in the loop
//! by de-embedding the flown one: P_new = P·G_new/G_flown ([`gyro_ratio`]), and the gyro noise the
//! controller sees becomes S_gyro·|G_new/G_flown|².

use super::Lowpass;
use crate::error::Result;
use serde_json::{json, Value};
use skyloop_lti::{c64, zpk::Zpk, StateSpace};

/// Which lowpass a setting moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Knob {
    /// The gyro lowpass (every term sees it).
    Gyro,
    /// The D-term lowpass.
    Dterm,
}

impl Knob {
    /// "gyro" or "dterm" (the JSON's `filter`).
    pub fn name(&self) -> &'static str {
        match self {
            Knob::Gyro => "gyro",
            Knob::Dterm => "dterm",
        }
    }
}

/// One firmware setting holding a cutoff, Hz.
#[derive(Debug, Clone, PartialEq)]
pub struct FilterSetting {
    /// The firmware's name, e.g. `gyro_lpf1_static_hz`, `IMU_DGYRO_CUTOFF`, `ATC_RAT_RLL_FLTD`.
    pub name: String,
    /// The lowpass it belongs to.
    pub knob: Knob,
    /// The flown value, Hz.
    pub flown_hz: f64,
    /// True for a setting of every axis (all but ArduPilot's per-axis `FLTD`): a change tuned on
    /// one axis moves the others' loops too.
    pub shared: bool,
}

impl FilterSetting {
    /// The value at factors `scale`, whole Hz (the firmwares store integers).
    pub fn at(&self, scale: Scale) -> f64 {
        let k = scale.of(self.knob);
        if k == 1.0 {
            self.flown_hz
        } else {
            super::scaled_cutoff_hz(self.flown_hz, k)
        }
    }
}

/// The factors the gyro and the D-term lowpass cutoffs are scaled by (1: as flown).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scale {
    /// Gyro lowpass factor.
    pub gyro: f64,
    /// D-term lowpass factor.
    pub dterm: f64,
}

impl Scale {
    /// The flown filters.
    pub const FLOWN: Scale = Scale { gyro: 1.0, dterm: 1.0 };

    /// The factor of `knob`.
    pub fn of(&self, knob: Knob) -> f64 {
        match knob {
            Knob::Gyro => self.gyro,
            Knob::Dterm => self.dterm,
        }
    }

    /// True when neither lowpass moves.
    pub fn is_flown(&self) -> bool {
        self.gyro == 1.0 && self.dterm == 1.0
    }
}

/// How a firmware's configurator takes a setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineStyle {
    /// Betaflight and INAV CLI: `set name = value`.
    Set,
    /// PX4's shell and ArduPilot's MAVProxy: `param set NAME value`.
    Param,
}

/// The tunable lowpass settings of a flown tune.
#[derive(Debug, Clone, PartialEq)]
pub struct FilterSettings {
    /// Every cutoff setting that is on, gyro first.
    pub settings: Vec<FilterSetting>,
    /// The flown gyro lowpass stages as the loop model sees them (a dynamic one at the low end of
    /// its range): what the identified plant is de-embedded from.
    pub gyro: Vec<Lowpass>,
    /// How the lines are written.
    pub style: LineStyle,
}

impl FilterSettings {
    /// True when some setting of `knob` is on.
    pub fn has(&self, knob: Knob) -> bool {
        self.settings.iter().any(|s| s.knob == knob)
    }

    /// The same settings less those every axis shares (only a per-axis cutoff stays: ArduPilot's
    /// `FLTD`); the gyro lowpass, always shared, is then not tunable.
    pub fn per_axis_only(&self) -> FilterSettings {
        FilterSettings {
            settings: self.settings.iter().filter(|s| !s.shared).cloned().collect(),
            gyro: Vec::new(),
            style: self.style,
        }
    }

    /// The lines that load the settings `scale` changes.
    pub fn cli_lines(&self, scale: Scale) -> Vec<String> {
        self.settings
            .iter()
            .filter(|s| s.at(scale) != s.flown_hz)
            .map(|s| match self.style {
                LineStyle::Set => format!("set {} = {:.0}", s.name, s.at(scale)),
                LineStyle::Param => format!("param set {} {:.0}", s.name, s.at(scale)),
            })
            .collect()
    }

    /// The gyro lowpass stages with their cutoffs scaled by `k` (whole Hz).
    pub fn gyro_at(&self, k: f64) -> Vec<Lowpass> {
        if k == 1.0 {
            return self.gyro.clone();
        }
        super::scale_lowpasses(&self.gyro, k)
    }

    /// The lowest gyro lowpass cutoff at factor `k`, Hz (None without one).
    pub fn lowest_gyro_cutoff_hz(&self, k: f64) -> Option<f64> {
        super::lowest_cutoff_hz(&self.gyro_at(k))
    }
}

/// One header lowpass stage and the names that set it: (stage, knob, static-cutoff name, dynamic
/// min name, dynamic max name; the dynamic names empty when the firmware has none for it).
pub(crate) type HeaderStage<'a> = (
    &'a Option<super::vocab::LowpassSetting>,
    Knob,
    &'a str,
    &'a str,
    &'a str,
);

/// The settings of a header's lowpass stages (Betaflight's and INAV's `set` names): a stage that is
/// on is set by its static cutoff, or by its range's two ends when it follows throttle.
pub(crate) fn from_header_stages(table: &[HeaderStage]) -> FilterSettings {
    let mut settings = Vec::new();
    let mut gyro = Vec::new();
    for &(l, knob, stat, dmin, dmax) in table {
        let Some(l) = l.as_ref().filter(|l| l.cutoff_hz > 0.0 || l.dynamic_hz.is_some()) else {
            continue;
        };
        let set = |name: &str, flown_hz: f64| FilterSetting {
            name: name.to_string(),
            knob,
            flown_hz,
            shared: true,
        };
        match l.dynamic_hz {
            Some((lo, hi)) if !dmin.is_empty() => {
                settings.push(set(dmin, lo));
                settings.push(set(dmax, hi));
            }
            _ => settings.push(set(stat, l.cutoff_hz)),
        }
        if knob == Knob::Gyro {
            gyro.extend(super::header_lowpass(l, &mut Vec::new(), stat));
        }
    }
    FilterSettings {
        settings,
        gyro,
        style: LineStyle::Set,
    }
}

/// G_new(s)/G_flown(s) of two lowpass chains whose stages pair up kind for kind (the same chain
/// with other cutoffs): biproper, unit gain at DC; None when they are the same.
///
/// # Errors
/// Chains of different shape, or a cutoff that is not a positive number of Hz.
pub fn gyro_ratio(flown: &[Lowpass], new: &[Lowpass]) -> Result<Option<StateSpace>> {
    if flown == new {
        return Ok(None);
    }
    let (mut z, mut p) = (Vec::new(), Vec::new());
    for (a, b) in flown.iter().zip(new) {
        if std::mem::discriminant(a) != std::mem::discriminant(b) {
            return Err(crate::error::Error::Input(format!(
                "gyro lowpass {a:?} and {b:?} are not the same kind of stage"
            )));
        }
        z.extend(a.poles()?);
        p.extend(b.poles()?);
    }
    if flown.len() != new.len() {
        return Err(crate::error::Error::Input(
            "gyro lowpass chains of different lengths".into(),
        ));
    }
    // Unit DC gain: k·Π(−z)/Π(−p) = 1.
    let prod = |v: &[c64]| v.iter().fold(c64::new(1.0, 0.0), |acc, x| acc * (-x));
    let k = (prod(&p) / prod(&z)).re;
    Ok(Some(Zpk::siso(z, p, k, 0.0).to_ss()?))
}

/// A lowpass chain as JSON: `[{type, hz}]` (`type` one of pt1, pt2, pt3, biquad, notch).
pub fn chain_json(stages: &[Lowpass]) -> Value {
    json!(stages
        .iter()
        .map(|l| match *l {
            Lowpass::Pt1(f) => json!({"type": "pt1", "hz": f}),
            Lowpass::Pt2(f) => json!({"type": "pt2", "hz": f}),
            Lowpass::Pt3(f) => json!({"type": "pt3", "hz": f}),
            Lowpass::Biquad(f) => json!({"type": "biquad", "hz": f}),
            Lowpass::Notch(f, c) => json!({"type": "notch", "hz": f, "cutoff_hz": c}),
        })
        .collect::<Vec<_>>())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use skyloop_lti::freqresp::FreqEvaluator;
    use std::f64::consts::PI;

    /// G_new/G_flown evaluated as one system equals the two chains' responses divided, for every
    /// kind of stage (an independent path: each chain's own state-space model).
    #[test]
    fn the_ratio_is_the_quotient_of_the_two_chains() {
        let flown = [
            Lowpass::Pt1(250.0),
            Lowpass::Biquad(400.0),
            Lowpass::Pt2(300.0),
            Lowpass::Pt3(500.0),
        ];
        let new: Vec<Lowpass> = flown.iter().map(|l| l.scaled(1.3)).collect();
        let r = gyro_ratio(&flown, &new).unwrap().unwrap();
        let resp = |m: &StateSpace, f: f64| {
            FreqEvaluator::new(m)
                .unwrap()
                .eval(c64::new(0.0, 2.0 * PI * f))
                .unwrap()[(0, 0)]
        };
        let g0 = super::super::chain(&flown).unwrap().unwrap();
        let g1 = super::super::chain(&new).unwrap().unwrap();
        for f in [0.0, 10.0, 80.0, 300.0, 900.0] {
            let want = resp(&g1, f) / resp(&g0, f);
            let got = resp(&r, f);
            assert!(
                (got - want).norm() < 1e-9 * want.norm().max(1.0),
                "{f} Hz: {got} vs {want}"
            );
        }
        assert!(gyro_ratio(&flown, &flown).unwrap().is_none());
        assert!(gyro_ratio(&[Lowpass::Pt1(100.0)], &[Lowpass::Pt2(100.0)]).is_err());
    }

    #[test]
    fn lines_name_only_what_changes() {
        let s = FilterSettings {
            settings: vec![
                FilterSetting {
                    name: "IMU_GYRO_CUTOFF".into(),
                    knob: Knob::Gyro,
                    flown_hz: 40.0,
                    shared: true,
                },
                FilterSetting {
                    name: "IMU_DGYRO_CUTOFF".into(),
                    knob: Knob::Dterm,
                    flown_hz: 30.0,
                    shared: true,
                },
            ],
            gyro: vec![Lowpass::Biquad(40.0)],
            style: LineStyle::Param,
        };
        let sc = Scale { gyro: 1.25, dterm: 1.0 };
        assert_eq!(s.cli_lines(sc), vec!["param set IMU_GYRO_CUTOFF 50".to_string()]);
        assert_eq!(s.gyro_at(1.25), vec![Lowpass::Biquad(50.0)]);
        assert_eq!(s.lowest_gyro_cutoff_hz(0.8), Some(32.0));
    }
}
