//! What changed between the flights, in plain words with numbers, and never more than the estimates
//! support: a curve (the tracking response, the step) counts as changed only where A and B differ
//! by more than twice their combined standard error at [`MIN_SIGNIFICANT_POINTS`] or more of the
//! compared points; a plant parameter only beyond two combined standard errors; a noise band only
//! from [`NOISE_DB_MIN`] on.

use super::headers::{is_gain, pilot_name, HeaderDiff};
use super::{AxisSide, Plant, Tracking};
use serde::Serialize;

/// Points beyond 2σ needed to call two curves different (one or two are expected by chance among
/// 80 frequencies or 250 step samples whose errors are correlated).
pub const MIN_SIGNIFICANT_POINTS: usize = 3;
/// Smallest change of a gyro noise band called a change, dB. The statistical error of a band power
/// averaged over hundreds of frames is far below it; what differs between two flights of one tune
/// is how they were flown (throttle, manoeuvres), which no error bar of one flight shows.
pub const NOISE_DB_MIN: f64 = 1.0;
/// Standard errors between two plant parameters that count as a difference.
pub const PARAM_Z: f64 = 2.0;

/// Two curves on one grid, compared point by point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CurveDiff {
    /// Points compared (both estimates trusted there).
    pub compared: usize,
    /// Points where |A − B| exceeds twice the combined standard error.
    pub significant: usize,
    /// The largest |A − B| over the compared points (dB for a response, per unit for a step).
    pub max_abs: f64,
    /// Where it is (Hz or s).
    pub max_at: f64,
}

impl CurveDiff {
    /// The curves differ by more than their uncertainty.
    pub fn distinguishable(&self) -> bool {
        self.significant >= MIN_SIGNIFICANT_POINTS
    }
}

/// Compares `a` and `b` (values with standard errors at abscissae `x`) where `use_point` holds.
pub fn curve_diff(x: &[f64], a: (&[f64], &[f64]), b: (&[f64], &[f64]), use_point: impl Fn(usize) -> bool) -> CurveDiff {
    let mut d = CurveDiff {
        compared: 0,
        significant: 0,
        max_abs: 0.0,
        max_at: f64::NAN,
    };
    let n = x.len().min(a.0.len()).min(b.0.len()).min(a.1.len()).min(b.1.len());
    for k in (0..n).filter(|&k| use_point(k)) {
        let delta = (a.0[k] - b.0[k]).abs();
        if !delta.is_finite() {
            continue;
        }
        d.compared += 1;
        let sigma = a.1[k].hypot(b.1[k]);
        // A zero difference is no change whatever the error (a log compared with itself).
        if delta > 0.0 && !(delta <= 2.0 * sigma) {
            d.significant += 1;
        }
        if delta > d.max_abs || d.max_at.is_nan() {
            d.max_abs = delta;
            d.max_at = x[k];
        }
    }
    d
}

/// The tracking responses compared in magnitude (dB) and phase (deg) where both are coherent; None
/// when the grids differ.
pub fn tracking_diff(a: &Tracking, b: &Tracking) -> Option<(CurveDiff, CurveDiff)> {
    if a.freq_hz.len() != b.freq_hz.len()
        || a.freq_hz
            .iter()
            .zip(&b.freq_hz)
            .any(|(x, y)| (x - y).abs() > 1e-9 * x.abs().max(1.0))
    {
        return None;
    }
    let ok = |k: usize| super::side::coherent(a.coherence[k]) && super::side::coherent(b.coherence[k]);
    Some((
        curve_diff(&a.freq_hz, (&a.mag_db, &a.std_db), (&b.mag_db, &b.std_db), ok),
        curve_diff(&a.freq_hz, (&a.phase_deg, &a.std_deg), (&b.phase_deg, &b.std_deg), ok),
    ))
}

/// "38 → 45 Hz" style: `a → b unit` with `digits` decimals, or "38 Hz (unchanged)".
pub fn arrow(a: f64, b: f64, digits: usize, unit: &str) -> String {
    let (sa, sb) = (format!("{a:.digits$}"), format!("{b:.digits$}"));
    let space = if unit.is_empty() || unit == "%" { "" } else { " " };
    if sa == sb {
        format!("{sa}{space}{unit} (unchanged)")
    } else {
        format!("{sa} → {sb}{space}{unit}")
    }
}

/// The signed difference `b − a` in dB with a real minus sign.
fn signed_db(d: f64) -> String {
    if d < 0.0 {
        format!("−{:.1} dB", -d)
    } else {
        format!("+{d:.1} dB")
    }
}

/// Plant parameters whose difference exceeds [`PARAM_Z`] combined standard errors, as text.
pub fn plant_changes(a: &Plant, b: &Plant) -> Vec<String> {
    let mut out = Vec::new();
    if a.gain_unit != b.gain_unit {
        out.push(format!(
            "K in different units ({}, {}), not compared",
            a.gain_unit, b.gain_unit
        ));
    }
    // A yaw fitted with the reaction-torque zero on one log and without it on the other: K and τ
    // mean different things in the two models (the zero shifts the gain above 1/Tz), so only Td,
    // which both models share, is compared.
    let same_model = a.tz_s.is_some() == b.tz_s.is_some();
    if !same_model {
        out.push("the yaw models differ (one has the reaction-torque zero Tz): K and tau not compared".into());
    }
    let none = (f64::NAN, f64::NAN);
    let items = [
        ("K", a.k, b.k, 1.0, 0usize, ""),
        ("tau", a.tau_s, b.tau_s, 1e3, 1, "ms"),
        ("Td", a.td_s, b.td_s, 1e3, 1, "ms"),
        ("Tz", a.tz_s.unwrap_or(none), b.tz_s.unwrap_or(none), 1e3, 1, "ms"),
    ];
    for (name, (va, sa), (vb, sb), scale, digits, unit) in items {
        if (name == "K" && a.gain_unit != b.gain_unit) || (!same_model && (name == "K" || name == "tau")) {
            continue;
        }
        let se = sa.hypot(sb);
        if (va - vb).abs() > PARAM_Z * se && se.is_finite() {
            out.push(format!("{name} {}", arrow(scale * va, scale * vb, digits, unit)));
        }
    }
    out
}

/// One axis' verdict line from its two sides and the comparisons of their curves, and whether it
/// names a change beyond the uncertainty.
pub fn axis_verdict(
    axis: &str,
    a: &AxisSide,
    b: &AxisSide,
    tracking: Option<&(CurveDiff, CurveDiff)>,
    step: Option<&CurveDiff>,
) -> (String, bool) {
    let mut parts: Vec<String> = Vec::new();
    let mut changed = false;
    let mut same: Vec<&str> = Vec::new();
    match (&a.tracking, &b.tracking, tracking) {
        (Ok(ta), Ok(tb), Some((m, p))) if m.distinguishable() || p.distinguishable() => {
            let mut s = Vec::new();
            if let (Some(x), Some(y)) = (ta.bandwidth_hz, tb.bandwidth_hz) {
                s.push(format!("bandwidth {}", arrow(x, y, 0, "Hz")));
            }
            if let (Some(x), Some(y)) = (ta.peak, tb.peak) {
                s.push(format!("peak {}", arrow(x.0, y.0, 1, "dB")));
            }
            s.push(format!("largest change {:.1} dB at {:.0} Hz", m.max_abs, m.max_at));
            parts.push(format!("tracking {}", s.join(", ")));
            changed = true;
        }
        (Ok(_), Ok(_), Some(_)) => same.push("tracking"),
        (Err(_), _, _) => parts.push("tracking not measured in A".into()),
        (_, Err(_), _) => parts.push("tracking not measured in B".into()),
        _ => parts.push("tracking grids differ, not compared".into()),
    }
    match (&a.step, &b.step, step) {
        (Ok(sa), Ok(sb), Some(d)) if d.distinguishable() => {
            let mut s = Vec::new();
            if let (Some(x), Some(y)) = (sa.overshoot_pct, sb.overshoot_pct) {
                s.push(format!("overshoot {}", arrow(x, y, 0, "%")));
            }
            if let (Some(x), Some(y)) = (sa.rise_time_ms, sb.rise_time_ms) {
                s.push(format!("rise {}", arrow(x, y, 1, "ms")));
            }
            parts.push(format!("step {}", s.join(", ")));
            changed = true;
        }
        (Ok(_), Ok(_), Some(_)) => same.push("step"),
        (Err(_), _, _) => parts.push("step not measured in A".into()),
        (_, Err(_), _) => parts.push("step not measured in B".into()),
        _ => {}
    }
    match (&a.plant, &b.plant) {
        (Ok(pa), Ok(pb)) => {
            let c = plant_changes(pa, pb);
            if c.is_empty() {
                same.push("plant");
            } else {
                parts.push(format!("plant {}", c.join(", ")));
                changed = true;
            }
        }
        (Err(_), Err(_)) => parts.push("plant not identified in either log".into()),
        (Err(_), _) => parts.push("plant not identified in A".into()),
        (_, Err(_)) => parts.push("plant not identified in B".into()),
    }
    match (&a.noise, &b.noise) {
        (Ok(na), Ok(nb)) if na.unit != nb.unit => {
            parts.push(format!(
                "gyro noise in different units ({}, {}), not compared",
                na.unit, nb.unit
            ));
        }
        (Ok(na), Ok(nb)) => {
            let mut s = Vec::new();
            for (name, x, y) in [("below", na.low_db, nb.low_db), ("above", na.high_db, nb.high_db)] {
                if let (Some(x), Some(y)) = (x, y) {
                    if (y - x).abs() >= NOISE_DB_MIN {
                        let band = if name == "below" {
                            format!("{:.0}–{:.0} Hz", super::side::NOISE_LOW_HZ, super::side::NOISE_SPLIT_HZ)
                        } else {
                            format!("{:.0}–{:.0} Hz", super::side::NOISE_SPLIT_HZ, na.high_top_hz)
                        };
                        let what = if s.is_empty() { "gyro noise " } else { "" };
                        s.push(format!("{what}{band} {}", signed_db(y - x)));
                    }
                }
            }
            if s.is_empty() {
                same.push("gyro noise");
            } else {
                parts.push(s.join(", "));
                changed = true;
            }
        }
        (Err(_), _) | (_, Err(_)) => parts.push("gyro noise not compared (no noise picture of one log)".into()),
    }
    let mut line = format!("{axis}: ");
    if parts.is_empty() {
        line.push_str("no change beyond the estimates' uncertainty");
    } else {
        line.push_str(&parts.join("; "));
        if !same.is_empty() {
            line.push_str(&format!("; not distinguishable: {}", same.join(", ")));
        }
    }
    (line, changed)
}

/// The header's verdict lines: the gains that changed, then the other settings (a count past five).
pub fn header_verdict(diffs: &[HeaderDiff]) -> Vec<String> {
    let show = |d: &HeaderDiff| {
        format!(
            "{} {} → {}",
            pilot_name(&d.key),
            d.a.as_deref().unwrap_or("not set"),
            d.b.as_deref().unwrap_or("not set")
        )
    };
    if diffs.is_empty() {
        return vec!["settings: the headers' tuning is identical".into()];
    }
    if let [d] = diffs {
        if d.key == "firmware" {
            return vec![format!(
                "settings: different firmware ({} → {}), not comparable key by key",
                d.a.as_deref().unwrap_or("unknown"),
                d.b.as_deref().unwrap_or("unknown")
            )];
        }
    }
    let gains: Vec<String> = diffs.iter().filter(|d| is_gain(&d.key)).map(show).collect();
    let other: Vec<String> = diffs.iter().filter(|d| !is_gain(&d.key)).map(show).collect();
    let mut out = Vec::new();
    if !gains.is_empty() {
        out.push(format!("PIDs changed: {}", gains.join(", ")));
    }
    if !other.is_empty() {
        let n = other.len();
        let mut shown: Vec<String> = other.into_iter().take(5).collect();
        if n > 5 {
            shown.push(format!("and {} more (see the list above)", n - 5));
        }
        out.push(format!("other settings changed: {}", shown.join(", ")));
    }
    out
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::super::{NoiseBands, StepSummary};
    use super::*;

    fn tracking(shift_db: f64, std_db: f64) -> Tracking {
        let f: Vec<f64> = (1..=20).map(|k| 5.0 * f64::from(k)).collect();
        let mag: Vec<f64> = f.iter().map(|x| -((x / 40.0).powi(2)) + shift_db).collect();
        Tracking::new(
            f.clone(),
            mag,
            f.iter().map(|x| -x).collect(),
            vec![std_db; 20],
            vec![1.0; 20],
            vec![0.9; 20],
        )
    }

    fn side(t: Tracking, low_db: f64) -> AxisSide {
        AxisSide {
            tracking: Ok(t),
            plant: Err("not identified: test".into()),
            step: Ok(StepSummary {
                t_s: vec![0.0, 0.01, 0.02],
                y: vec![0.0, 1.1, 1.0],
                y_std: vec![0.01; 3],
                rise_time_ms: Some(8.0),
                overshoot_pct: Some(10.0),
                overshoot_std_pct: 1.0,
                final_value: 1.0,
                acausal_fraction: 0.0,
            }),
            noise: Ok(NoiseBands {
                freq_hz: vec![],
                psd_db: vec![],
                low_db: Some(low_db),
                high_db: Some(-10.0),
                high_top_hz: 500.0,
                nyquist_hz: 500.0,
                unit: "deg/s",
                frames: 100,
            }),
        }
    }

    #[test]
    fn identical_sides_give_no_change() {
        let (a, b) = (side(tracking(0.0, 0.5), 3.0), side(tracking(0.0, 0.5), 3.0));
        let d = tracking_diff(a.tracking.as_ref().unwrap(), b.tracking.as_ref().unwrap()).unwrap();
        assert_eq!(d.0.significant, 0);
        assert_eq!(d.0.compared, 20);
        let s = a.step.as_ref().unwrap();
        let sd = curve_diff(&s.t_s, (&s.y, &s.y_std), (&s.y, &s.y_std), |_| true);
        let (v, changed) = axis_verdict("roll", &a, &b, Some(&d), Some(&sd));
        assert!(!changed);
        assert!(v.contains("not distinguishable: tracking, step, gyro noise"), "{v}");
        assert!(v.contains("plant not identified in either log"), "{v}");
        assert!(!v.contains("→"), "{v}");
    }

    #[test]
    fn a_shift_within_the_error_is_not_distinguishable() {
        // 1 dB apart, each ±1 dB (1σ): 2σ combined is 2.8 dB.
        let (a, b) = (side(tracking(0.0, 1.0), 3.0), side(tracking(1.0, 1.0), 3.0));
        let d = tracking_diff(a.tracking.as_ref().unwrap(), b.tracking.as_ref().unwrap()).unwrap();
        assert!(!d.0.distinguishable());
        assert!((d.0.max_abs - 1.0).abs() < 1e-12);
        let (v, changed) = axis_verdict("pitch", &a, &b, Some(&d), None);
        assert!(!changed);
        assert!(v.contains("not distinguishable: tracking"), "{v}");
    }

    #[test]
    fn a_real_shift_and_a_noise_change_are_named_with_numbers() {
        let (a, b) = (side(tracking(0.0, 0.2), 3.0), side(tracking(2.0, 0.2), -1.5));
        let d = tracking_diff(a.tracking.as_ref().unwrap(), b.tracking.as_ref().unwrap()).unwrap();
        assert!(d.0.distinguishable());
        let (v, changed) = axis_verdict("yaw", &a, &b, Some(&d), None);
        assert!(changed);
        assert!(v.starts_with("yaw: tracking bandwidth"), "{v}");
        assert!(v.contains("largest change 2.0 dB"), "{v}");
        assert!(v.contains("gyro noise 20–100 Hz −4.5 dB"), "{v}");
        assert!(!v.contains("100–500 Hz"), "{v}");
    }

    #[test]
    fn header_lines_put_gains_first() {
        let d = |k: &str, a: &str, b: &str| HeaderDiff {
            key: k.into(),
            a: Some(a.into()),
            b: Some(b.into()),
        };
        let v = header_verdict(&[d("dterm_lowpass.cutoff_hz", "100", "120"), d("pidf.roll.p", "45", "52")]);
        assert_eq!(v[0], "PIDs changed: roll P 45 → 52");
        assert_eq!(v[1], "other settings changed: dterm_lowpass.cutoff_hz 100 → 120");
        assert_eq!(header_verdict(&[]), vec!["settings: the headers' tuning is identical"]);
        assert_eq!(arrow(38.2, 45.0, 0, "Hz"), "38 → 45 Hz");
        assert_eq!(arrow(12.0, 12.2, 0, "%"), "12% (unchanged)");
    }

    fn plant(k: f64, tz: Option<f64>) -> Plant {
        Plant {
            freq_hz: vec![],
            mag_db: vec![],
            phase_deg: vec![],
            std_db: vec![],
            coherence: vec![],
            k: (k, 1.0),
            tau_s: (0.01, 0.0005),
            td_s: (0.004, 0.0001),
            tz_s: tz.map(|t| (t, 0.002)),
            fit_percent: 80.0,
            gain_unit: "deg/s² per PID unit".into(),
            fit_band_hz: None,
        }
    }

    #[test]
    fn yaw_models_with_and_without_the_zero_compare_only_what_they_share() {
        // Both with the zero: K and Tz changes beyond 3 standard errors are named.
        let c = plant_changes(&plant(27.0, Some(0.055)), &plant(40.0, Some(0.080)));
        assert!(
            c.iter().any(|l| l.starts_with("K ")) && c.iter().any(|l| l.starts_with("Tz ")),
            "{c:?}"
        );
        // One with, one without: K and tau mean different things; only Td is compared, and it says so.
        let c = plant_changes(&plant(27.0, Some(0.055)), &plant(60.0, None));
        assert!(c[0].contains("the yaw models differ"), "{c:?}");
        assert!(!c.iter().any(|l| l.starts_with("K ") || l.starts_with("tau ")), "{c:?}");
    }
}
