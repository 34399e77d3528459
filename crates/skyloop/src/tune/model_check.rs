//! The flown tune's closed loop, measured against predicted: the setpoint → gyro frequency response
//! estimated from the log (Welch, over the airborne segments, where its coherence is at least 0.5)
//! against the identified model's P·C_r/(1 + P·C_fb) with the flown gains. Its peak is the loop's
//! resonance: a model that rates a flown tune near-unstable predicts a peak the flight did not show.

use crate::error::{Error, Result};
use crate::identify::Identification;
use serde_json::{json, Value};
use skyloop_lti::freqresp::FreqEvaluator;
use skyloop_lti::{c64, StateSpace};
use skyloop_sysid::logs::Log;
use skyloop_sysid::spectral::{estimate_records, IoData, Method, Options};
use std::f64::consts::PI;

/// Least squared coherence of a measured point the check uses.
pub const COHERENCE_MIN: f64 = 0.5;
/// Largest difference of the closed-loop peaks (dB) that passes without a warning.
pub const PEAK_DB_MAX: f64 = 3.0;

/// The measured and predicted closed loop setpoint → gyro of the flown tune.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedLoopCheck {
    /// Frequencies of the coherent band, Hz.
    pub freq_hz: Vec<f64>,
    /// Measured |T|, dB.
    pub measured_db: Vec<f64>,
    /// Predicted |T|, dB.
    pub predicted_db: Vec<f64>,
    /// Measured peak (dB, Hz).
    pub measured_peak: (f64, f64),
    /// Predicted peak over the same band (dB, Hz).
    pub predicted_peak: (f64, f64),
    /// RMS of the difference, dB.
    pub rms_db: f64,
}

impl ClosedLoopCheck {
    /// `{band_hz, measured_peak_db, measured_peak_hz, predicted_peak_db, predicted_peak_hz, rms_db, freq_hz, measured_db, predicted_db}`.
    pub fn to_json(&self) -> Value {
        json!({
            "band_hz": [self.freq_hz.first(), self.freq_hz.last()],
            "measured_peak_db": self.measured_peak.0,
            "measured_peak_hz": self.measured_peak.1,
            "predicted_peak_db": self.predicted_peak.0,
            "predicted_peak_hz": self.predicted_peak.1,
            "rms_db": self.rms_db,
            "freq_hz": self.freq_hz,
            "measured_db": self.measured_db,
            "predicted_db": self.predicted_db,
        })
    }

    /// The peaks differ by more than [`PEAK_DB_MAX`].
    pub fn disagrees(&self) -> bool {
        (self.measured_peak.0 - self.predicted_peak.0).abs() > PEAK_DB_MAX
    }
}

/// The check of the flown tune (`c_fb`, `c_r`) on the nominal plant `plant` (hold included).
///
/// # Errors
/// No setpoint channel, too little data, or no coherent band of at least three points.
pub fn closed_loop_check(
    log: &Log,
    id: &Identification,
    plant: &StateSpace,
    c_fb: &StateSpace,
    c_r: &StateSpace,
) -> Result<ClosedLoopCheck> {
    let r = id
        .instrument
        .as_deref()
        .ok_or_else(|| Error::Input("no setpoint channel for the closed-loop check".into()))?;
    let data = log.uniform(&[r, id.output.as_str()], None, None, None)?;
    let recs: Vec<IoData> = id
        .segments
        .iter()
        .filter_map(|s| {
            let r = data.range_of(s);
            (r.len() > 64).then(|| IoData {
                u: &data.columns[0][r.clone()],
                y: &data.columns[1][r],
                r: None,
                dt_s: data.dt_s,
            })
        })
        .collect();
    let opts = Options {
        method: Method::Welch,
        nfft: Some(
            ((0.5 / data.dt_s).round() as usize)
                .next_power_of_two()
                .clamp(64, 1 << 14),
        ),
        ..Options::default()
    };
    let frf = estimate_records(&recs, &opts)?;
    // The widest run of coherent points from 1 Hz up.
    let ok: Vec<bool> = frf
        .freq_hz
        .iter()
        .zip(&frf.coherence)
        .map(|(f, c)| *f >= 1.0 && *c >= COHERENCE_MIN)
        .collect();
    let run = skyloop_sysid::logs::segments_where(&ok, 3)
        .into_iter()
        .max_by_key(|r| r.len())
        .ok_or_else(|| Error::Failed("the setpoint → gyro response is coherent at fewer than 3 points".into()))?;
    let evs = [
        FreqEvaluator::new(plant)?,
        FreqEvaluator::new(c_fb)?,
        FreqEvaluator::new(c_r)?,
    ];
    let mut out = ClosedLoopCheck {
        freq_hz: Vec::new(),
        measured_db: Vec::new(),
        predicted_db: Vec::new(),
        measured_peak: (f64::NEG_INFINITY, 0.0),
        predicted_peak: (f64::NEG_INFINITY, 0.0),
        rms_db: 0.0,
    };
    for k in run {
        let f = frf.freq_hz[k];
        let s = c64::new(0.0, 2.0 * PI * f);
        let v: Vec<c64> = evs
            .iter()
            .map(|e| e.eval(s).map(|m| m[(0, 0)]))
            .collect::<std::result::Result<_, _>>()?;
        let t = v[0] * v[2] / (c64::new(1.0, 0.0) + v[0] * v[1]);
        let (m, p) = (20.0 * frf.response[k].norm().log10(), 20.0 * t.norm().log10());
        if m > out.measured_peak.0 {
            out.measured_peak = (m, f);
        }
        if p > out.predicted_peak.0 {
            out.predicted_peak = (p, f);
        }
        out.freq_hz.push(f);
        out.measured_db.push(m);
        out.predicted_db.push(p);
    }
    let n = out.freq_hz.len() as f64;
    out.rms_db = (out
        .measured_db
        .iter()
        .zip(&out.predicted_db)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    Ok(out)
}
