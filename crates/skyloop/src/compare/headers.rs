//! The tuning recorded in two logs' headers, compared key by key: the firmware model of each log
//! ([`FirmwareTuning`], as `log info` prints it) flattened to named settings (`pidf.roll.p`,
//! `gyro_lowpass.cutoff_hz`, `harmonic_notch.INS_HNTCH_FREQ`), and only the keys that differ kept.
//! ArduPilot's logging rates are measured, not set, and are left out.

use crate::firmware::FirmwareTuning;
use serde::Serialize;
use serde_json::Value;
use std::collections::BTreeMap;

/// One setting that differs between the logs (None: the log does not state it).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeaderDiff {
    /// The setting, e.g. `pidf.roll.p` or `dterm_lowpass.cutoff_hz`.
    pub key: String,
    /// Its value in log A.
    pub a: Option<String>,
    /// Its value in log B.
    pub b: Option<String>,
}

/// Keys of per-axis arrays (roll, pitch, yaw).
const PER_AXIS: [&str; 4] = ["pidf", "pid", "rate", "rates"];
/// Keys that are measured from the log rather than set.
const MEASURED: [&str; 1] = ["log_rates_hz"];

/// The tuning flattened to `key → value` (numbers as written, null as "off").
pub fn flatten(t: &FirmwareTuning) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    if let Ok(v) = serde_json::to_value(t) {
        walk("", &v, &mut out);
    }
    out
}

fn walk(prefix: &str, v: &Value, out: &mut BTreeMap<String, String>) {
    let join = |k: &str| {
        if prefix.is_empty() {
            k.to_string()
        } else {
            format!("{prefix}.{k}")
        }
    };
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                if !MEASURED.contains(&k.as_str()) {
                    walk(&join(k), x, out);
                }
            }
        }
        Value::Array(items) => {
            let named = items
                .iter()
                .all(|x| x.get("name").is_some_and(Value::is_string) && x.get("value").is_some());
            let per_axis = PER_AXIS.iter().any(|k| prefix.ends_with(k)) && items.len() == 3;
            let numbers = items.iter().all(|x| !x.is_object() && !x.is_array());
            if named && !items.is_empty() {
                for x in items {
                    let name = x.get("name").and_then(Value::as_str).unwrap_or("?");
                    walk(&join(name), &x["value"], out);
                }
            } else if numbers && !items.is_empty() {
                let s: Vec<String> = items.iter().map(scalar).collect();
                out.insert(prefix.to_string(), s.join(".."));
            } else if items.is_empty() {
                out.insert(prefix.to_string(), "none".into());
            } else {
                for (i, x) in items.iter().enumerate() {
                    let k = if per_axis {
                        ["roll", "pitch", "yaw"][i].to_string()
                    } else {
                        (i + 1).to_string()
                    };
                    walk(&join(&k), x, out);
                }
            }
        }
        other => {
            out.insert(prefix.to_string(), scalar(other));
        }
    }
}

fn scalar(v: &Value) -> String {
    match v {
        Value::Null => "off".into(),
        Value::String(s) => s.clone(),
        // Whole numbers as a pilot types them (45, not 45.0).
        Value::Number(n) => match n.as_f64() {
            Some(x) if x.fract() == 0.0 && x.abs() < 1e15 => format!("{}", x as i64),
            Some(x) => format!("{x}"),
            None => n.to_string(),
        },
        other => other.to_string(),
    }
}

/// The value of `key` in `m`, or "off" when a setting that holds it is off in `m` (a filter that
/// is off has no cutoff).
fn lookup(m: &BTreeMap<String, String>, key: &str) -> Option<String> {
    if let Some(v) = m.get(key) {
        return Some(v.clone());
    }
    let mut k = key;
    while let Some(i) = k.rfind('.') {
        k = &k[..i];
        if m.get(k).is_some_and(|v| v == "off" || v == "none") {
            return Some("off".into());
        }
    }
    None
}

/// The settings that differ between `a` and `b`, in key order. Logs of different firmware families
/// give one line, the firmware, since their settings do not correspond.
pub fn diff(a: Option<&FirmwareTuning>, b: Option<&FirmwareTuning>) -> Vec<HeaderDiff> {
    let (fa, fb) = (a.map(flatten).unwrap_or_default(), b.map(flatten).unwrap_or_default());
    diff_flat(&fa, &fb)
}

/// [`diff`] of two flattened tunings.
fn diff_flat(fa: &BTreeMap<String, String>, fb: &BTreeMap<String, String>) -> Vec<HeaderDiff> {
    let family = |m: &BTreeMap<String, String>| m.get("firmware").cloned();
    if family(fa) != family(fb) {
        return vec![HeaderDiff {
            key: "firmware".into(),
            a: family(fa),
            b: family(fb),
        }];
    }
    let mut keys: Vec<&String> = fa.keys().chain(fb.keys()).collect();
    keys.sort();
    keys.dedup();
    // A setting that is off on one side and has parts on the other is compared by its parts.
    let has_parts = |k: &str| {
        let p = format!("{k}.");
        fa.keys().chain(fb.keys()).any(|x| x.starts_with(&p))
    };
    keys.into_iter()
        .filter(|k| !has_parts(k))
        .map(|k| (k, lookup(fa, k), lookup(fb, k)))
        .filter(|(_, a, b)| a != b)
        .map(|(k, a, b)| HeaderDiff { key: k.clone(), a, b })
        .collect()
}

/// A key as a pilot reads it: `pidf.roll.p` → `roll P`, `pid.pitch.d` → `pitch D`; other keys as
/// they are.
pub fn pilot_name(key: &str) -> String {
    let parts: Vec<&str> = key.split('.').collect();
    match parts.as_slice() {
        [group, axis, term] if PER_AXIS[..3].contains(group) && ["roll", "pitch", "yaw"].contains(axis) => {
            let t = match *term {
                "p" | "i" | "d" | "f" | "k" | "ff" => term.to_uppercase(),
                other => other.to_string(),
            };
            format!("{axis} {t}")
        }
        _ => key.to_string(),
    }
}

/// True for a gain of the rate PID (`pidf.*`, `pid.*`, `rate.*` with an axis).
pub fn is_gain(key: &str) -> bool {
    let parts: Vec<&str> = key.split('.').collect();
    parts.len() == 3 && PER_AXIS[..3].contains(&parts[0])
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use serde_json::json;

    #[test]
    fn flattens_axes_ranges_and_named_values() {
        let mut out = BTreeMap::new();
        walk(
            "",
            &json!({"firmware": "betaflight", "pidf": [{"p": 45.0, "f": null}, {"p": 47.0, "f": 90.0}, {"p": 45.0, "f": 0.0}],
                    "gyro_lowpass": {"kind": "PT1", "dynamic_hz": [250.0, 500.0]}, "gyro_notches": [],
                    "harmonic_notch": [{"name": "INS_HNTCH_FREQ", "value": 80.0}], "log_rates_hz": [{"name": "RATE", "value": 400.0}]}),
            &mut out,
        );
        assert_eq!(out["pidf.roll.p"], "45");
        assert_eq!(out["pidf.roll.f"], "off");
        assert_eq!(out["pidf.yaw.f"], "0");
        assert_eq!(out["gyro_lowpass.dynamic_hz"], "250..500");
        assert_eq!(out["gyro_notches"], "none");
        assert_eq!(out["harmonic_notch.INS_HNTCH_FREQ"], "80");
        assert!(!out.keys().any(|k| k.starts_with("log_rates")));
        assert_eq!(pilot_name("pidf.roll.p"), "roll P");
        assert_eq!(pilot_name("pidf.roll.d_min"), "roll d_min");
        assert_eq!(pilot_name("dterm_lowpass.cutoff_hz"), "dterm_lowpass.cutoff_hz");
        assert!(is_gain("pid.yaw.d") && !is_gain("gyro_lowpass.kind"));
    }

    #[test]
    fn a_filter_switched_off_is_compared_by_its_parts() {
        let m = |v: Value| {
            let mut out = BTreeMap::new();
            walk("", &v, &mut out);
            out
        };
        let a = m(json!({"firmware": "x", "dterm_notch": null, "tpa": 10.0}));
        let b = m(json!({"firmware": "x", "dterm_notch": {"center_hz": 240.0, "cutoff_hz": 160.0}, "tpa": 10.0}));
        assert_eq!(lookup(&a, "dterm_notch.center_hz").as_deref(), Some("off"));
        let d = diff_flat(&a, &b);
        let keys: Vec<&str> = d.iter().map(|x| x.key.as_str()).collect();
        assert_eq!(keys, ["dterm_notch.center_hz", "dterm_notch.cutoff_hz"]);
        assert_eq!(d[0].a.as_deref(), Some("off"));
        assert_eq!(d[0].b.as_deref(), Some("240"));
        assert!(diff_flat(&a, &a).is_empty());
    }
}
