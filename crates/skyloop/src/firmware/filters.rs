//! A flight controller's gyro and D-term filter chain as the firmware runs it: named stages (static
//! and throttle-following lowpasses, static notches, the dynamic notch that follows the strongest
//! gyro peaks, the RPM notches at the motors' harmonics) at the loop rate, each stage's exact
//! discrete response from [`skyloop_control::filter`], and a pilot's change to the chain
//! (`gyro_lpf1=pt1:150,dterm_lpf1=pt2:90,dyn_notch=2x:150-600`).
//!
//! Which stages a firmware has, what its header calls them and how its dynamic stages move is read
//! by the firmware's own module (`betaflight::filter_chain`, ...); this module only knows
//! what a stage is.

use super::vocab::NotchSetting;
use crate::error::{Error, Result};
use num_complex::Complex64;
use serde::Serialize;
use skyloop_control::filter::{notch_q, FilterKind};

/// The shape of a lowpass stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Shape {
    /// First-order lag.
    Pt1,
    /// Two lags, cutoff-corrected.
    Pt2,
    /// Three lags, cutoff-corrected.
    Pt3,
    /// Butterworth biquad.
    Biquad,
}

impl Shape {
    /// The shape a header's filter type names ("PT1", "BIQUAD", ...); None for an unknown one.
    pub fn from_header(kind: &str) -> Option<Shape> {
        Some(match kind.to_ascii_uppercase().as_str() {
            "PT1" => Shape::Pt1,
            "PT2" => Shape::Pt2,
            "PT3" => Shape::Pt3,
            "BIQUAD" => Shape::Biquad,
            _ => return None,
        })
    }

    fn kind(self, hz: f64) -> FilterKind {
        match self {
            Shape::Pt1 => FilterKind::Pt1(hz),
            Shape::Pt2 => FilterKind::Pt2(hz),
            Shape::Pt3 => FilterKind::Pt3(hz),
            Shape::Biquad => FilterKind::BiquadLowpass(hz),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Shape::Pt1 => "pt1",
            Shape::Pt2 => "pt2",
            Shape::Pt3 => "pt3",
            Shape::Biquad => "biquad",
        }
    }
}

/// How a dynamic lowpass's cutoff follows the throttle t ∈ [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum ThrottleCurve {
    /// Betaflight 4.0–4.2: cutoff = max(min, max·1.5·t·(1 − t²/3)).
    Betaflight40,
    /// Betaflight 4.3 and later: cutoff = min + (max − min)·(t + e·t·(1 − t)), e = `dyn_lpf_curve_expo`/10.
    Expo(f64),
}

impl ThrottleCurve {
    /// The cutoff, Hz, at throttle `t` (clamped to [0, 1]) for the range `min_hz`..`max_hz`.
    pub fn cutoff_hz(&self, t: f64, min_hz: f64, max_hz: f64) -> f64 {
        let t = t.clamp(0.0, 1.0);
        match *self {
            ThrottleCurve::Betaflight40 => (max_hz * 1.5 * t * (1.0 - t * t / 3.0)).max(min_hz),
            ThrottleCurve::Expo(e) => min_hz + (max_hz - min_hz) * (t + e * t * (1.0 - t)),
        }
    }
}

/// What a stage does.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum StageKind {
    /// A lowpass at a fixed cutoff, Hz.
    Lowpass {
        /// Shape.
        shape: Shape,
        /// Cutoff, Hz.
        hz: f64,
    },
    /// A lowpass whose cutoff follows the throttle, Hz.
    DynamicLowpass {
        /// Shape.
        shape: Shape,
        /// Cutoff at low throttle, Hz.
        min_hz: f64,
        /// Cutoff at full throttle, Hz.
        max_hz: f64,
        /// How the cutoff moves between them.
        curve: ThrottleCurve,
    },
    /// A notch at a fixed centre, Hz, with quality factor `q`.
    Notch {
        /// Centre, Hz.
        center_hz: f64,
        /// Quality factor.
        q: f64,
    },
    /// `count` notches at the strongest gyro peaks within `min_hz..max_hz` (tracked frame by frame).
    DynamicNotch {
        /// Number of notches.
        count: usize,
        /// Lowest centre, Hz.
        min_hz: f64,
        /// Highest centre, Hz.
        max_hz: f64,
        /// Quality factor.
        q: f64,
    },
    /// Notches at `harmonics` harmonics of every motor's rotation frequency (from eRPM telemetry).
    Rpm {
        /// Harmonics per motor.
        harmonics: usize,
        /// Quality factor.
        q: f64,
        /// Notches below this frequency are off, Hz.
        min_hz: f64,
    },
}

/// The signal a stage filters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Path {
    /// The gyro (before P, I and D).
    Gyro,
    /// The D term only.
    Dterm,
}

/// One named stage ("gyro_lpf1", "dterm_notch", "dyn_notch", "rpm", ...).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stage {
    /// The stage's name in `--filters`.
    pub name: String,
    /// Gyro or D-term path.
    pub path: Path,
    /// What it does.
    #[serde(flatten)]
    pub kind: StageKind,
}

/// The state a flight is in during one stretch: what the dynamic stages follow.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OperatingPoint {
    /// Throttle in [0, 1] (None: not logged; a dynamic lowpass then sits at its minimum).
    pub throttle: Option<f64>,
    /// Every motor's rotation frequency, Hz (empty: no eRPM logged; RPM notches are then left out).
    pub motor_hz: Vec<f64>,
    /// The strongest gyro peaks, Hz, strongest first (what a dynamic notch locks onto).
    pub peaks_hz: Vec<f64>,
}

impl Stage {
    /// The stage's discrete filters at an operating point.
    pub fn filters(&self, op: &OperatingPoint) -> Vec<FilterKind> {
        match &self.kind {
            StageKind::Lowpass { shape, hz } => vec![shape.kind(*hz)],
            StageKind::DynamicLowpass {
                shape,
                min_hz,
                max_hz,
                curve,
            } => {
                let hz = op.throttle.map_or(*min_hz, |t| curve.cutoff_hz(t, *min_hz, *max_hz));
                vec![shape.kind(hz)]
            }
            StageKind::Notch { center_hz, q } => vec![FilterKind::Notch {
                center: *center_hz,
                q: *q,
            }],
            StageKind::DynamicNotch {
                count,
                min_hz,
                max_hz,
                q,
            } => op
                .peaks_hz
                .iter()
                .filter(|f| **f >= *min_hz && **f <= *max_hz)
                .take(*count)
                .map(|&center| FilterKind::Notch { center, q: *q })
                .collect(),
            StageKind::Rpm { harmonics, q, min_hz } => op
                .motor_hz
                .iter()
                .flat_map(|m| (1..=*harmonics).map(move |h| m * h as f64))
                .filter(|f| *f >= *min_hz)
                .map(|center| FilterKind::Notch { center, q: *q })
                .collect(),
        }
    }

    /// The stage as a pilot reads it, e.g. "gyro_lpf1 pt1 200–500 Hz (throttle)".
    pub fn describe(&self) -> String {
        let what = match &self.kind {
            StageKind::Lowpass { shape, hz } => format!("{} {hz} Hz", shape.name()),
            StageKind::DynamicLowpass {
                shape, min_hz, max_hz, ..
            } => {
                format!("{} {min_hz}–{max_hz} Hz (follows throttle)", shape.name())
            }
            StageKind::Notch { center_hz, q } => format!("notch {center_hz} Hz, Q {q:.2}"),
            StageKind::DynamicNotch {
                count,
                min_hz,
                max_hz,
                q,
            } => {
                format!("{count} dynamic notch(es) {min_hz}–{max_hz} Hz, Q {q:.2}")
            }
            StageKind::Rpm { harmonics, q, min_hz } => {
                format!("RPM notches, {harmonics} harmonics per motor, Q {q:.2}, from {min_hz} Hz")
            }
        };
        format!("{}: {what}", self.name)
    }
}

/// A firmware's filter chain at its loop rate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FilterChain {
    /// The rate the filters run at, Hz.
    pub loop_hz: f64,
    /// Stages in signal order (gyro stages, then D-term stages).
    pub stages: Vec<Stage>,
}

impl FilterChain {
    /// H(e^{j2πf/loop_hz}) of the stages on `path` at each of `freq_hz` (the D-term path's
    /// response excludes the gyro stages it also sees).
    ///
    /// # Errors
    /// A stage with a frequency or Q that is not a finite positive number.
    pub fn response(&self, path: Path, freq_hz: &[f64], op: &OperatingPoint) -> Result<Vec<Complex64>> {
        let dt = 1.0 / self.loop_hz;
        let mut h = vec![Complex64::new(1.0, 0.0); freq_hz.len()];
        for stage in self.stages.iter().filter(|s| s.path == path) {
            for k in stage.filters(op) {
                for (hi, &f) in h.iter_mut().zip(freq_hz) {
                    let (re, im) = k
                        .response(f, dt)
                        .map_err(|e| Error::Input(format!("{}: {e}", stage.describe())))?;
                    *hi *= Complex64::new(re, im);
                }
            }
        }
        Ok(h)
    }

    /// The chain with the stages a `--filters` spec names replaced, added or removed
    /// (`name=off`); returns it with one line per change ("gyro_lpf1: pt1 200 Hz → pt1 150 Hz").
    ///
    /// Grammar (comma-separated `name=value`): lowpass `pt1:150`, `pt2:90`, `pt3:..`, `biquad:..`,
    /// throttle-following `pt1:200-500`; notch `notch:CENTER/CUTOFF` (Hz; Q = f₀·f_c/(f₀² − f_c²));
    /// dynamic notch `2x:150-600` (optionally `@q3.5`); RPM `3h` (optionally `@q5`); `off`.
    /// Names: `gyro_lpf1`, `gyro_lpf2`, `gyro_notch1`, `gyro_notch2`, `dyn_notch`, `rpm`,
    /// `dterm_lpf1`, `dterm_lpf2`, `dterm_notch`.
    ///
    /// # Errors
    /// An unknown stage name or a value outside the grammar or the loop's Nyquist frequency.
    pub fn with_changes(&self, spec: &str) -> Result<(FilterChain, Vec<String>)> {
        let mut out = self.clone();
        let mut changes = Vec::new();
        let mut named: Vec<&str> = Vec::new();
        for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (name, value) = item.split_once('=').ok_or_else(|| {
                Error::Input(format!(
                    "--filters: `{item}` is not name=value (e.g. gyro_lpf1=pt1:150)"
                ))
            })?;
            let (name, value) = (name.trim(), value.trim().to_ascii_lowercase());
            let path = stage_path(name)?;
            // A stage named twice has no one meaning (the firmware has one setting per stage).
            if named.contains(&name) {
                return Err(Error::Input(format!(
                    "--filters: {name} is given twice; name each stage once"
                )));
            }
            named.push(name);
            let before = out.stages.iter().position(|s| s.name == name);
            // The flown stage's description without its name.
            let old = before.map(|i| {
                out.stages[i]
                    .describe()
                    .trim_start_matches(&format!("{name}: "))
                    .to_string()
            });
            if value == "off" {
                if let Some(i) = before {
                    out.stages.remove(i);
                }
                changes.push(format!("{name}: {} → off", old.unwrap_or_else(|| "off".into())));
                continue;
            }
            let prior = before.map(|i| out.stages[i].kind.clone());
            let kind = parse_stage(name, &value, prior.as_ref(), self.loop_hz)?;
            let stage = Stage {
                name: name.to_string(),
                path,
                kind,
            };
            let new = stage.describe().trim_start_matches(&format!("{name}: ")).to_string();
            changes.push(match old {
                Some(o) if o == new => format!("{name}: {o} (unchanged)"),
                o => format!("{name}: {} → {new}", o.unwrap_or_else(|| "off".into())),
            });
            match before {
                Some(i) => out.stages[i] = stage,
                None => out.stages.push(stage),
            }
        }
        // Gyro stages first, then the D term's, each in the order the firmware names them.
        out.stages
            .sort_by_key(|s| (s.path == Path::Dterm, STAGE_NAMES.iter().position(|n| *n == s.name)));
        Ok((out, changes))
    }
}

/// Where a log holds the gyro before (some of) the firmware's filters.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RawGyroTap {
    /// Roll, pitch and yaw channels.
    pub channels: [String; 3],
    /// Stages of the chain the tapped signal has already passed.
    pub applied: Vec<String>,
    /// What the channel is, for a report.
    pub what: String,
}

/// A blackbox header's static notches as stages: up to two gyro notches (`gyro_notch1`, `gyro_notch2`)
/// and the D-term notch, each given by its centre and lower cutoff (Betaflight and INAV alike).
pub(crate) fn static_notches(gyro: &[NotchSetting], dterm: Option<NotchSetting>) -> Vec<Stage> {
    let stage = |name: String, path: Path, n: &NotchSetting| Stage {
        name,
        path,
        kind: StageKind::Notch {
            center_hz: n.center_hz,
            q: notch_q(n.center_hz, n.cutoff_hz),
        },
    };
    let mut out: Vec<Stage> = gyro
        .iter()
        .take(2)
        .enumerate()
        .map(|(k, n)| stage(format!("gyro_notch{}", k + 1), Path::Gyro, n))
        .collect();
    out.extend(dterm.iter().map(|n| stage("dterm_notch".into(), Path::Dterm, n)));
    out
}

/// The stage names `--filters` knows, in signal order.
pub const STAGE_NAMES: [&str; 9] = [
    "rpm",
    "dyn_notch",
    "gyro_notch1",
    "gyro_notch2",
    "gyro_lpf1",
    "gyro_lpf2",
    "dterm_notch",
    "dterm_lpf1",
    "dterm_lpf2",
];

fn stage_path(name: &str) -> Result<Path> {
    if !STAGE_NAMES.contains(&name) {
        return Err(Error::Input(format!(
            "--filters: unknown stage `{name}`; the stages are {}",
            STAGE_NAMES.join(", ")
        )));
    }
    Ok(if name.starts_with("dterm") {
        Path::Dterm
    } else {
        Path::Gyro
    })
}

/// Smallest cutoff or centre frequency `--filters` accepts, Hz.
const MIN_CUTOFF_HZ: f64 = 1.0;

/// `MIN-MAX` split at its range dash: not a leading sign and not an exponent's sign (`1e-3`).
fn split_range(s: &str) -> Option<(&str, &str)> {
    let b = s.as_bytes();
    let i = (1..b.len()).find(|&i| b[i] == b'-' && !matches!(b[i - 1], b'e' | b'E'))?;
    Some((&s[..i], &s[i + 1..]))
}

/// One `--filters` value for stage `name` (`prior`: the flown stage, whose Q and curve a change
/// keeps where the value does not name them).
fn parse_stage(name: &str, v: &str, prior: Option<&StageKind>, loop_hz: f64) -> Result<StageKind> {
    let nyq = 0.5 * loop_hz;
    let bad = |why: &str| Error::Input(format!("--filters: {name}={v}: {why}"));
    let hz = |s: &str| -> Result<f64> {
        let f: f64 = s
            .trim()
            .parse()
            .map_err(|_| bad(&format!("`{s}` is not a frequency in Hz")))?;
        // Firmware cutoffs are whole hertz from 1 up; a cutoff of 1e-300 Hz would leave
        // coefficients that underflow.
        if f.is_finite() && (MIN_CUTOFF_HZ..nyq).contains(&f) {
            Ok(f)
        } else {
            Err(bad(&format!(
                "{} Hz is outside [{MIN_CUTOFF_HZ}, {nyq}) Hz (from 1 Hz up to the loop's Nyquist frequency)",
                s.trim()
            )))
        }
    };
    let (body, q) = match v.split_once("@q") {
        Some((b, q)) => {
            let q: f64 = q.parse().map_err(|_| bad("Q after @q must be a number"))?;
            if !(q.is_finite() && q > 0.0 && q <= 100.0) {
                return Err(bad("Q must lie in (0, 100]"));
            }
            (b, Some(q))
        }
        None => (v, None),
    };
    let range = |s: &str| -> Result<(f64, f64)> {
        let (a, b) = split_range(s).ok_or_else(|| bad("a range is MIN-MAX in Hz"))?;
        let (a, b) = (hz(a)?, hz(b)?);
        if a < b {
            Ok((a, b))
        } else {
            Err(bad("a range's MIN must be below its MAX"))
        }
    };
    if name == "dyn_notch" {
        let (n, r) = body
            .split_once("x:")
            .ok_or_else(|| bad("a dynamic notch is COUNTx:MIN-MAX, e.g. 2x:150-600"))?;
        let count: usize = n
            .parse()
            .ok()
            .filter(|c| (1..=5).contains(c))
            .ok_or_else(|| bad("the notch count must be 1..=5"))?;
        let (min_hz, max_hz) = range(r)?;
        let q = q.or(match prior {
            Some(StageKind::DynamicNotch { q, .. }) => Some(*q),
            _ => None,
        });
        return Ok(StageKind::DynamicNotch {
            count,
            min_hz,
            max_hz,
            q: q.unwrap_or(3.0),
        });
    }
    if name == "rpm" {
        let h: usize = body
            .strip_suffix('h')
            .and_then(|h| h.parse().ok())
            .filter(|h| (1..=3).contains(h))
            .ok_or_else(|| bad("RPM notches are Nh with N harmonics in 1..=3, e.g. 3h"))?;
        let (pq, pmin) = match prior {
            Some(StageKind::Rpm { q, min_hz, .. }) => (*q, *min_hz),
            _ => (5.0, 100.0),
        };
        return Ok(StageKind::Rpm {
            harmonics: h,
            q: q.unwrap_or(pq),
            min_hz: pmin,
        });
    }
    let (kind, arg) = body
        .split_once(':')
        .ok_or_else(|| bad("expected TYPE:HZ, e.g. pt1:150 or notch:240/160"))?;
    if kind == "notch" {
        let (c, k) = arg
            .split_once('/')
            .ok_or_else(|| bad("a notch is notch:CENTER/CUTOFF in Hz"))?;
        let (c, k) = (hz(c)?, hz(k)?);
        if k >= c {
            return Err(bad("a notch's cutoff must lie below its centre"));
        }
        return Ok(StageKind::Notch {
            center_hz: c,
            q: q.unwrap_or_else(|| notch_q(c, k)),
        });
    }
    let shape = Shape::from_header(kind).ok_or_else(|| bad("the lowpass types are pt1, pt2, pt3 and biquad"))?;
    if split_range(arg).is_some() {
        let (min_hz, max_hz) = range(arg)?;
        let curve = match prior {
            Some(StageKind::DynamicLowpass { curve, .. }) => *curve,
            _ => ThrottleCurve::Expo(0.5),
        };
        return Ok(StageKind::DynamicLowpass {
            shape,
            min_hz,
            max_hz,
            curve,
        });
    }
    Ok(StageKind::Lowpass { shape, hz: hz(arg)? })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn chain() -> FilterChain {
        FilterChain {
            loop_hz: 8000.0,
            stages: vec![
                Stage {
                    name: "gyro_lpf1".into(),
                    path: Path::Gyro,
                    kind: StageKind::Lowpass {
                        shape: Shape::Pt1,
                        hz: 200.0,
                    },
                },
                Stage {
                    name: "dterm_lpf1".into(),
                    path: Path::Dterm,
                    kind: StageKind::Lowpass {
                        shape: Shape::Pt1,
                        hz: 150.0,
                    },
                },
            ],
        }
    }

    #[test]
    fn changes_replace_add_and_remove_stages() {
        let (c, lines) = chain()
            .with_changes("gyro_lpf1=pt2:150, dterm_lpf1=off, dyn_notch=2x:150-600@q3.5, gyro_notch1=notch:240/160")
            .unwrap();
        assert_eq!(c.stages.len(), 3);
        assert_eq!(c.stages[0].name, "dyn_notch");
        assert_eq!(
            c.stages[2].kind,
            StageKind::Lowpass {
                shape: Shape::Pt2,
                hz: 150.0
            }
        );
        assert!(lines[0].contains("pt1 200 Hz → pt2 150 Hz"), "{lines:?}");
        assert!(lines[1].contains("→ off"));
        let op = OperatingPoint {
            peaks_hz: vec![300.0, 100.0, 450.0],
            ..Default::default()
        };
        // Two notches, only at the peaks inside the range.
        let n = c.stages[0].filters(&op);
        assert_eq!(
            n,
            vec![
                FilterKind::Notch { center: 300.0, q: 3.5 },
                FilterKind::Notch { center: 450.0, q: 3.5 }
            ]
        );
        let h = c.response(Path::Gyro, &[300.0, 450.0, 0.0], &op).unwrap();
        assert!(h[0].norm() < 1e-9 && h[1].norm() < 1e-9 && (h[2].norm() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_specs_name_the_stage_and_the_range() {
        for (spec, want) in [
            ("gyro_lpf9=pt1:100", "unknown stage"),
            ("gyro_lpf1=pt1:5000", "Nyquist"),
            ("gyro_lpf1=pt7:100", "lowpass types"),
            ("dyn_notch=9x:100-200", "1..=5"),
            ("gyro_notch1=notch:100/200", "below its centre"),
            ("gyro_lpf1", "name=value"),
            ("rpm=3h@q-1", "Q must"),
            // Found by the campaign: an exponent's sign was read as a range dash, a negative
            // cutoff was named as an empty frequency, and a stage given twice was taken silently.
            ("gyro_lpf1=biquad:1e-300", "outside [1, 4000)"),
            ("gyro_lpf1=pt1:-5", "-5 Hz is outside"),
            ("gyro_lpf1=pt1:0.5", "outside [1, 4000)"),
            ("dterm_lpf1=pt2:90,dterm_lpf1=pt3:80", "given twice"),
        ] {
            let e = chain().with_changes(spec).unwrap_err().to_string();
            assert!(e.contains(want), "{spec}: {e}");
        }
    }

    #[test]
    fn exponents_are_frequencies_not_ranges() {
        let (c, _) = chain()
            .with_changes("gyro_lpf1=pt1:1.5e2,dterm_lpf1=pt2:8e1-1.2e2")
            .unwrap();
        assert_eq!(
            c.stages[0].kind,
            StageKind::Lowpass {
                shape: Shape::Pt1,
                hz: 150.0
            }
        );
        assert!(matches!(
            c.stages[1].kind,
            StageKind::DynamicLowpass { min_hz, max_hz, .. } if min_hz == 80.0 && max_hz == 120.0
        ));
        assert_eq!(split_range("1e-3"), None);
        assert_eq!(split_range("100-200"), Some(("100", "200")));
    }

    #[test]
    fn betaflight_throttle_curves() {
        // 4.0–4.2 reaches max only above t = 1/√... and never drops below min.
        let c = ThrottleCurve::Betaflight40;
        assert_eq!(c.cutoff_hz(0.0, 200.0, 500.0), 200.0);
        assert!((c.cutoff_hz(1.0, 200.0, 500.0) - 500.0).abs() < 1e-9);
        let e = ThrottleCurve::Expo(0.5);
        assert!((e.cutoff_hz(0.5, 200.0, 500.0) - (200.0 + 300.0 * (0.5 + 0.125))).abs() < 1e-9);
    }
}
