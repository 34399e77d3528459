//! The noise picture as JSON and as text.

use super::{AxisNoise, ChainResponse, Heat, NoiseAnalysis};
use serde_json::{json, Value};

/// Two decimals (dB, Hz): the JSON carries thousands of spectrum points.
fn r2(v: f64) -> Value {
    if v.is_finite() {
        json!((v * 100.0).round() / 100.0)
    } else {
        Value::Null
    }
}

fn list(v: &[f64]) -> Value {
    Value::Array(v.iter().map(|x| r2(*x)).collect())
}

fn chain_json(c: &ChainResponse) -> Value {
    json!({
        "freq_hz": list(&c.freq_hz),
        "gain_db": list(&c.gain_db),
        "phase_deg": list(&c.phase_deg),
        "delay_ms_at": c.delay_ms_at.iter().map(|(f, d)| (format!("{f}"), r2(*d))).collect::<serde_json::Map<_, _>>(),
    })
}

fn heat_json(h: &Heat, x_name: &str) -> Value {
    json!({
        x_name: list(&h.x),
        "freq_hz": list(&h.freq_hz),
        "psd_db": h.psd_db.iter().map(|r| list(r)).collect::<Vec<_>>(),
        "frames": h.frames,
        "motor_hz": h.motor_hz.iter().map(|m| m.map_or(Value::Null, r2)).collect::<Vec<_>>(),
    })
}

fn axis_json(a: &AxisNoise) -> Value {
    let mut spectra = serde_json::Map::new();
    spectra.insert("freq_hz".into(), list(&a.freq_hz));
    for (name, v) in &a.spectra {
        spectra.insert((*name).into(), list(v));
    }
    json!({
        "axis": a.axis.name(),
        "spectra": spectra,
        "peaks": a.peaks.iter().map(|p| json!({
            "freq_hz": r2(p.freq_hz), "db": r2(p.db), "prominence_db": r2(p.prominence_db),
            "kind": p.kind, "reason": p.reason,
        })).collect::<Vec<_>>(),
        "gyro_chain": chain_json(&a.gyro_chain),
        "what_if_chain": a.what_if_chain.as_ref().map(chain_json),
        "validation": a.validation.as_ref().map(|v| json!({
            "band_hz": [r2(v.band_hz.0), r2(v.band_hz.1)], "rms_db": r2(v.rms_db), "mean_db": r2(v.mean_db),
            "max_abs_db": r2(v.max_abs_db), "bins": v.bins, "floor_db": r2(v.floor_db),
        })),
        "spectrogram_throttle": heat_json(&a.by_throttle, "throttle_pct"),
        "spectrogram_time": heat_json(&a.by_time, "time_s"),
    })
}

impl NoiseAnalysis {
    /// The analysis as the JSON `skyloop noise --json` prints.
    pub fn to_json(&self) -> Value {
        let stages = |c: &crate::firmware::filters::FilterChain| {
            c.stages
                .iter()
                .map(|s| {
                    let mut v = serde_json::to_value(s).unwrap_or(Value::Null);
                    if let Value::Object(m) = &mut v {
                        m.insert("describe".into(), json!(s.describe()));
                    }
                    v
                })
                .collect::<Vec<_>>()
        };
        json!({
            "source": self.source,
            "firmware": self.firmware,
            "log_rate_hz": r2(self.log_rate_hz),
            "loop_rate_hz": r2(self.loop_hz),
            "frame_s": self.frame_s,
            "frames": self.frames,
            "airborne_s": r2(self.airborne_s),
            "units": {
                "gyro": self.units[0], "dterm": self.units[1], "motors": self.units[2],
                "psd": "dB re 1 (signal unit)²/Hz",
            },
            "flown_chain": stages(&self.flown),
            "what_if": self.what_if.as_ref().map(|(c, ch)| json!({"chain": stages(c), "changes": ch})),
            "raw_gyro": self.raw_gyro.as_ref().map(|t| json!({"channels": t.channels, "applied": t.applied, "what": t.what})),
            "axes": self.axes.iter().map(axis_json).collect::<Vec<_>>(),
            "notes": self.notes,
        })
    }

    /// The analysis as text: the chain, and per axis the peaks, the chain's delay, the noise per
    /// band and the what-if's change.
    pub fn to_text(&self) -> String {
        let mut s = format!(
            "{}: {}\n{:.1} s airborne, {} frames of {:.3} s at {:.0} Hz; filters at {:.0} Hz\n",
            self.source, self.firmware, self.airborne_s, self.frames, self.frame_s, self.log_rate_hz, self.loop_hz
        );
        s += "flown filters:\n";
        for st in &self.flown.stages {
            s += &format!("  {}\n", st.describe());
        }
        if let Some(t) = &self.raw_gyro {
            s += &format!("raw gyro: {} ({})\n", t.what, t.channels.join(", "));
        }
        if let Some((_, changes)) = &self.what_if {
            s += "what-if:\n";
            for c in changes {
                s += &format!("  {c}\n");
            }
        }
        for a in &self.axes {
            s += &axis_summary(a, self.units[0]);
        }
        for n in &self.notes {
            s += &format!("note: {n}\n");
        }
        s
    }
}

/// Power of a dB spectrum between two frequencies, as dB of the band's mean density.
fn band_db(freq: &[f64], v: &[f64], lo: f64, hi: f64) -> Option<f64> {
    let p: Vec<f64> = freq
        .iter()
        .zip(v)
        .filter(|(f, _)| **f >= lo && **f < hi)
        .map(|(_, d)| 10f64.powf(d / 10.0))
        .collect();
    (!p.is_empty()).then(|| 10.0 * (p.iter().sum::<f64>() / p.len() as f64).log10())
}

/// One axis' text block: chain delay, validation, peaks and the PSD per band of every spectrum.
pub fn axis_summary(a: &AxisNoise, unit: &str) -> String {
    let mut s = format!("\n{}:\n", a.axis.name());
    let delays: Vec<String> = a
        .gyro_chain
        .delay_ms_at
        .iter()
        .map(|(f, d)| format!("{d:.2} ms at {f} Hz"))
        .collect();
    s += &format!("  flown gyro chain delay: {}\n", delays.join(", "));
    if let Some(w) = &a.what_if_chain {
        let d: Vec<String> = w
            .delay_ms_at
            .iter()
            .map(|(f, d)| format!("{d:.2} ms at {f} Hz"))
            .collect();
        s += &format!("  what-if gyro chain delay: {}\n", d.join(", "));
    }
    if let Some(v) = &a.validation {
        s += &format!(
            "  flown chain on the raw gyro vs the logged gyro: {:+.2} dB mean, {:.2} dB RMS, {:.2} dB worst over {} bins in {:.0}–{:.0} Hz (both ≥ 10 dB above the floor, {:.1} dB)\n",
            v.mean_db, v.rms_db, v.max_abs_db, v.bins, v.band_hz.0, v.band_hz.1, v.floor_db
        );
    }
    if a.peaks.is_empty() {
        s += "  peaks: none 6 dB above the floor\n";
    }
    for p in &a.peaks {
        s += &format!(
            "  peak {:6.1} Hz {:6.1} dB (+{:.1} dB): {} — {}\n",
            p.freq_hz, p.db, p.prominence_db, p.kind, p.reason
        );
    }
    let bands = [(0.0, 20.0), (20.0, 100.0), (100.0, 250.0), (250.0, f64::INFINITY)];
    s += &format!("  mean PSD per band, dB re 1 ({unit})²/Hz:   0–20 Hz  20–100  100–250  250+\n");
    for (name, v) in &a.spectra {
        let cells: Vec<String> = bands
            .iter()
            .map(|(lo, hi)| band_db(&a.freq_hz, v, *lo, *hi).map_or("     -".into(), |d| format!("{d:8.1}")))
            .collect();
        s += &format!("    {name:<16}{}\n", cells.join(" "));
    }
    s
}
