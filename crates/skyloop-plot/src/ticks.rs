//! Tick positions and tick labels: "nice" linear steps (1, 2, 5 × 10ᵏ), degree steps (multiples of
//! 15°, 45°, 90°, ...), log axes labelled at decades (with 2 and 5 when the axis spans few decades,
//! as MATLAB does), and labels in engineering notation without trailing zeros ("10k", "0.5", "20").

/// One tick on an axis: a grid line at `value`, labelled when `label` is `Some`.
#[derive(Debug, Clone, PartialEq)]
pub struct Tick {
    /// Position, in the axis' data unit.
    pub value: f64,
    /// Text under (x) or beside (y) the tick; `None` for a minor grid line only.
    pub label: Option<String>,
}

/// SI prefixes from 10⁻¹² to 10¹², indexed by (exponent / 3 + 4).
const PREFIXES: [&str; 9] = ["p", "n", "µ", "m", "", "k", "M", "G", "T"];

/// Formats a tick value in engineering notation with no more digits than the tick spacing `step`
/// needs: `format_tick(1e10, 1e10)` is "10G", `format_tick(0.5, 0.1)` is "0.5",
/// `format_tick(20.0, 10.0)` is "20", `format_tick(1500.0, 500.0)` is "1.5k".
///
/// Values from 0.001 up to (not including) 1000 are written as plain decimals (an axis reading
/// 0.01, 0.1, 1, 10, 100 needs no prefix); outside that range an SI prefix (p n µ m k M G T) is
/// used, and beyond 10¹⁵ or below 10⁻¹² an exponent ("1e18"). A value within a millionth of a step
/// of zero is "0", so float noise never prints as "-1.2e-17".
pub fn format_tick(value: f64, step: f64) -> String {
    if !value.is_finite() {
        return String::new();
    }
    let step = if step.is_finite() && step > 0.0 {
        step
    } else {
        value.abs().max(f64::MIN_POSITIVE)
    };
    if value.abs() < 1e-6 * step {
        return "0".into();
    }
    let mag = value.abs();
    let exp3 = if (1e-3..1e3).contains(&mag) {
        0
    } else {
        // Engineering exponent: a multiple of 3, so the mantissa is in [1, 1000).
        ((mag.log10() + 1e-9).floor() / 3.0).floor() as i32 * 3
    };
    if !(-12..=12).contains(&exp3) {
        let digits = ((mag.log10() - step.log10()).round().max(0.0) as usize).min(15);
        let s = format!("{:.*e}", digits, value);
        return trim_exponent(&s);
    }
    let scale = 10f64.powi(exp3);
    let scaled = value / scale;
    let scaled_step = step / scale;
    // Decimals so that neighbouring ticks differ
    // (the fewest decimals that write the step exactly: 2.5 needs one, 0.25 two, 20 none).
    let decimals = (0..12usize)
        .find(|d| {
            let v = scaled_step * 10f64.powi(*d as i32);
            (v - v.round()).abs() <= 1e-6 * v.abs().max(1.0)
        })
        .unwrap_or(12);
    let mut s = format!("{:.*}", decimals, scaled);
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if s == "-0" {
        s = "0".into();
    }
    let prefix = PREFIXES[(exp3 / 3 + 4) as usize];
    s.push_str(prefix);
    s
}

/// A tick value of a dimensionless log axis (Hankel singular values, μ): plain from 0.001 to 1000,
/// else mantissa and power of ten ("1e-6", "2e5") — SI prefixes belong to quantities with units.
pub fn format_tick_exp(value: f64, step: f64) -> String {
    let mag = value.abs();
    if value == 0.0 || !value.is_finite() || (1e-3..1e4).contains(&mag) {
        return format_tick(value, step);
    }
    let e = (mag.log10() + 1e-9).floor() as i32;
    let m = value / 10f64.powi(e);
    let digits = ((mag.log10() - step.abs().max(f64::MIN_POSITIVE).log10())
        .round()
        .max(0.0) as usize)
        .min(6);
    let mut s = format!("{m:.digits$}");
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    format!("{s}e{e}")
}

/// "1.50e18" → "1.5e18".
fn trim_exponent(s: &str) -> String {
    match s.split_once('e') {
        Some((m, e)) => {
            let mut m = m.to_string();
            if m.contains('.') {
                while m.ends_with('0') {
                    m.pop();
                }
                if m.ends_with('.') {
                    m.pop();
                }
            }
            format!("{m}e{e}")
        }
        None => s.to_string(),
    }
}

/// The smallest "nice" step (1, 2 or 5 × 10ᵏ) that puts at most `max_ticks` ticks in `[lo, hi]`.
pub fn nice_step(lo: f64, hi: f64, max_ticks: usize) -> f64 {
    let span = (hi - lo).abs();
    if !(span.is_finite() && span > 0.0) {
        return 1.0;
    }
    let raw = span / max_ticks.max(2) as f64;
    let p = 10f64.powf(raw.log10().floor());
    for m in [1.0, 2.0, 5.0, 10.0] {
        if m * p >= raw {
            return m * p;
        }
    }
    10.0 * p
}

/// Labelled ticks at multiples of a nice step in `[lo, hi]`, at most `max_ticks` of them.
pub fn linear_ticks(lo: f64, hi: f64, max_ticks: usize) -> Vec<Tick> {
    let step = nice_step(lo, hi, max_ticks);
    multiples(lo, hi, step)
}

/// Labelled ticks for an axis in degrees: multiples of 15°, 30°, 45°, 90°, 180°, 360°, ... (so a
/// phase axis reads −180, −90, 0 and the critical −180° is always a grid line when in range); spans
/// under 60° fall back to nice decimal steps.
pub fn degree_ticks(lo: f64, hi: f64, max_ticks: usize) -> Vec<Tick> {
    let span = (hi - lo).abs();
    if span < 60.0 {
        return linear_ticks(lo, hi, max_ticks);
    }
    let raw = (span / max_ticks.max(2) as f64).max(15.0);
    let mut step = 15.0;
    for s in [15.0, 30.0, 45.0, 90.0, 180.0, 360.0, 720.0] {
        step = s;
        if s >= raw {
            break;
        }
    }
    while step < raw {
        step *= 2.0;
    }
    multiples_with(lo, hi, step, format_degrees)
}

/// Every multiple of `step` in `[lo, hi]` (inclusive up to a part in 10⁹ of a step), labelled.
fn multiples(lo: f64, hi: f64, step: f64) -> Vec<Tick> {
    multiples_with(lo, hi, step, format_tick)
}

/// Degrees are written out in full ("-1440", not "-1.44k"): an angle is not a quantity with a prefix.
fn format_degrees(v: f64, step: f64) -> String {
    if v.abs() < 1e6 && (v / step).round() * step == v && step >= 1.0 {
        format!("{}", v.round() as i64)
    } else {
        format_tick(v, step)
    }
}

fn multiples_with(lo: f64, hi: f64, step: f64, fmt: fn(f64, f64) -> String) -> Vec<Tick> {
    let (lo, hi) = if lo <= hi { (lo, hi) } else { (hi, lo) };
    let eps = 1e-9 * step;
    let first = ((lo - eps) / step).ceil() as i64;
    let last = ((hi + eps) / step).floor() as i64;
    if last < first || last - first > 10_000 {
        return Vec::new();
    }
    (first..=last)
        .map(|i| {
            // Multiplying the integer index (not accumulating) keeps 0.1·3 from becoming 0.30000000000000004.
            let v = i as f64 * step;
            Tick {
                value: v,
                label: Some(fmt(v, step)),
            }
        })
        .collect()
}

/// Ticks for a logarithmic axis over `[lo, hi]` (both > 0): a grid line at every 1…9 × 10ᵏ, labels at
/// the decades; at 2 and 5 too when the axis spans at most two decades; every other (or every n-th)
/// decade when there are more than `max_labels` decades.
pub fn log_ticks(lo: f64, hi: f64, max_labels: usize) -> Vec<Tick> {
    if !(lo > 0.0 && hi > lo && lo.is_finite() && hi.is_finite()) {
        return Vec::new();
    }
    let d0 = (lo.log10() - 1e-9).floor() as i32;
    let d1 = (hi.log10() + 1e-9).ceil() as i32;
    let decades = (hi / lo).log10();
    let label_125 = decades <= 2.0 + 1e-9;
    let every = ((decades / max_labels.max(1) as f64).ceil() as i32).max(1);
    let in_range = |v: f64| v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9);
    let mut out = Vec::new();
    for d in d0..=d1 {
        let p = 10f64.powi(d);
        for m in 1..=9 {
            let v = m as f64 * p;
            if !in_range(v) {
                continue;
            }
            let labelled = if m == 1 {
                d.rem_euclid(every) == 0
            } else {
                label_125 && (m == 2 || m == 5)
            };
            // Each tick value is exact m·10ᵈ, so it formats from its own decade.
            out.push(Tick {
                value: v,
                label: labelled.then(|| format_tick(v, p)),
            });
        }
    }
    // Less than a decade with no labelled tick at all: label every grid line instead.
    if out.iter().filter(|t| t.label.is_some()).count() < 2 {
        for t in &mut out {
            let p = 10f64.powf(t.value.log10().floor());
            t.label = Some(format_tick(t.value, p));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_like_an_engineer() {
        assert_eq!(format_tick(1e10, 1e10), "10G");
        assert_eq!(format_tick(9982376960.0, 1e9), "10G");
        assert_eq!(format_tick(0.5, 0.1), "0.5");
        assert_eq!(format_tick(20.0, 10.0), "20");
        assert_eq!(format_tick(-180.0, 45.0), "-180");
        assert_eq!(format_tick(1500.0, 500.0), "1.5k");
        assert_eq!(format_tick(1000.0, 1000.0), "1k");
        assert_eq!(format_tick(0.001, 0.001), "0.001");
        assert_eq!(format_tick(2e-4, 1e-4), "200µ");
        assert_eq!(format_tick(0.3, 0.1), "0.3");
        assert_eq!(format_tick(1e-17, 0.5), "0");
        assert_eq!(format_tick(2.5, 2.5), "2.5");
        assert_eq!(format_tick(0.25, 0.05), "0.25");
        assert_eq!(format_tick(1e18, 1e18), "1e18");
        assert_eq!(format_tick_exp(1e-6, 1e-6), "1e-6");
        assert_eq!(format_tick_exp(2e5, 1e5), "2e5");
        assert_eq!(format_tick_exp(0.01, 0.01), "0.01");
        assert_eq!(format_tick_exp(1e10, 1e10), "1e10");
        assert_eq!(format_tick(100.0, 100.0), "100");
        assert!(!format_tick(123.0, 1.0).ends_with(".0"));
    }

    #[test]
    fn linear_ticks_are_nice_and_inside() {
        let t = linear_ticks(-0.13, 1.07, 8);
        let v: Vec<f64> = t.iter().map(|t| t.value).collect();
        assert_eq!(v.first(), Some(&0.0));
        assert!((v[1] - 0.2).abs() < 1e-12, "{v:?}");
        let labels: Vec<String> = t.iter().filter_map(|t| t.label.clone()).collect();
        assert_eq!(labels, ["0", "0.2", "0.4", "0.6", "0.8", "1"]);
    }

    #[test]
    fn degree_ticks_hit_minus_180() {
        let t = degree_ticks(-290.0, 10.0, 8);
        assert!(t.iter().any(|t| t.value == -180.0));
        assert!(t.iter().all(|t| (t.value / 45.0).fract() == 0.0));
        let t = degree_ticks(-95.0, 5.0, 10);
        assert!(t.iter().all(|t| (t.value / 15.0).fract() == 0.0), "{t:?}");
        let t = degree_ticks(-5760.0, 0.0, 5);
        assert!(t.iter().any(|t| t.label.as_deref() == Some("-1440")), "{t:?}");
    }

    #[test]
    fn log_ticks_label_decades_and_125_when_few() {
        let t = log_ticks(0.01, 1000.0, 10);
        let labels: Vec<String> = t.iter().filter_map(|t| t.label.clone()).collect();
        assert_eq!(labels, ["0.01", "0.1", "1", "10", "100", "1k"]);
        assert_eq!(t.len(), 5 * 9 + 1);
        let t = log_ticks(1.0, 100.0, 10);
        let labels: Vec<String> = t.iter().filter_map(|t| t.label.clone()).collect();
        assert_eq!(labels, ["1", "2", "5", "10", "20", "50", "100"]);
        let t = log_ticks(1e-6, 1e10, 8);
        let labels: Vec<String> = t.iter().filter_map(|t| t.label.clone()).collect();
        assert_eq!(labels, ["1µ", "100µ", "0.01", "1", "100", "10k", "1M", "100M", "10G"]);
    }
}
