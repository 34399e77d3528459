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
                dist: None,
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

/// Largest random error (relative, 1σ) of a measured plant point the crossover check uses.
pub const CROSSOVER_POINT_ERR_MAX: f64 = 0.5;

/// The flown loop where its margins are decided, measured against predicted: around the flown
/// crossover (half to twice it), the sensitivity S = 1/(1 + L) and T = L/(1 + L) of the flown
/// feedback controller on the plant's *measured* frequency response (the instrument estimate
/// Φ_yr/Φ_ur of the identification, point by point, no parametric model) against the same on the
/// identified model. The controller is the firmware's own arithmetic, known exactly, so a
/// difference is the model's: a predicted |S| peak the measurement does not show means the model
/// is wrong where the margins are decided.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossoverCheck {
    /// The flown crossover the band is centred on, Hz.
    pub crossover_hz: f64,
    /// Frequencies used (the estimate's points in the band with a random error of at most
    /// [`CROSSOVER_POINT_ERR_MAX`]), Hz.
    pub freq_hz: Vec<f64>,
    /// |S| from the measured plant, dB.
    pub measured_s_db: Vec<f64>,
    /// Its random error (1σ), dB.
    pub measured_s_err_db: Vec<f64>,
    /// |S| from the identified model, dB.
    pub predicted_s_db: Vec<f64>,
    /// |T| from the measured plant, dB.
    pub measured_t_db: Vec<f64>,
    /// |T| from the identified model, dB.
    pub predicted_t_db: Vec<f64>,
}

impl CrossoverCheck {
    /// Largest measured |S| (dB, Hz, its 1σ in dB).
    pub fn measured_peak(&self) -> (f64, f64, f64) {
        let k = argmax(&self.measured_s_db);
        (self.measured_s_db[k], self.freq_hz[k], self.measured_s_err_db[k])
    }

    /// Largest predicted |S| over the same points (dB, Hz).
    pub fn predicted_peak(&self) -> (f64, f64) {
        let k = argmax(&self.predicted_s_db);
        (self.predicted_s_db[k], self.freq_hz[k])
    }

    /// The |S| peaks differ by more than [`PEAK_DB_MAX`] and by more than twice the measured
    /// peak's random error.
    pub fn disagrees(&self) -> bool {
        let (m, _, e) = self.measured_peak();
        let (p, _) = self.predicted_peak();
        (m - p).abs() > PEAK_DB_MAX.max(2.0 * e)
    }

    /// `{crossover_hz, band_hz, points, measured_s_peak_db, measured_s_peak_hz,
    /// measured_s_peak_err_db, predicted_s_peak_db, predicted_s_peak_hz, agrees, freq_hz,
    /// measured_s_db, measured_s_err_db, predicted_s_db, measured_t_db, predicted_t_db}`.
    pub fn to_json(&self) -> Value {
        let (m, mf, me) = self.measured_peak();
        let (p, pf) = self.predicted_peak();
        json!({
            "crossover_hz": self.crossover_hz,
            "band_hz": [self.freq_hz.first(), self.freq_hz.last()],
            "points": self.freq_hz.len(),
            "measured_s_peak_db": m,
            "measured_s_peak_hz": mf,
            "measured_s_peak_err_db": me,
            "predicted_s_peak_db": p,
            "predicted_s_peak_hz": pf,
            "agrees": !self.disagrees(),
            "freq_hz": self.freq_hz,
            "measured_s_db": self.measured_s_db,
            "measured_s_err_db": self.measured_s_err_db,
            "predicted_s_db": self.predicted_s_db,
            "measured_t_db": self.measured_t_db,
            "predicted_t_db": self.predicted_t_db,
        })
    }
}

fn argmax(v: &[f64]) -> usize {
    (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap_or(0)
}

/// The check of the flown feedback controller `c_fb` around `crossover_hz` on the identification's
/// estimate `frf` (plant input → output, setpoint as instrument): `plant` is the identified model (what the identification's estimate measured: no hold), `held` the same with the
/// loop's sample and hold, which multiplies the measured plant too.
///
/// # Errors
/// Fewer than three measured points in the band with a random error of at most
/// [`CROSSOVER_POINT_ERR_MAX`] (the flight does not measure the loop there), or a model that cannot
/// be evaluated.
pub fn crossover_check(
    frf: &skyloop_sysid::spectral::Frf,
    plant: &StateSpace,
    held: &StateSpace,
    c_fb: &StateSpace,
    crossover_hz: f64,
) -> Result<CrossoverCheck> {
    let err = frf.rel_std();
    let (lo, hi) = (0.5 * crossover_hz, 2.0 * crossover_hz);
    let evs = [
        FreqEvaluator::new(plant)?,
        FreqEvaluator::new(held)?,
        FreqEvaluator::new(c_fb)?,
    ];
    let mut out = CrossoverCheck {
        crossover_hz,
        freq_hz: Vec::new(),
        measured_s_db: Vec::new(),
        measured_s_err_db: Vec::new(),
        predicted_s_db: Vec::new(),
        measured_t_db: Vec::new(),
        predicted_t_db: Vec::new(),
    };
    let one = c64::new(1.0, 0.0);
    let db = |x: f64| 20.0 * x.log10();
    for (k, &f) in frf.freq_hz.iter().enumerate() {
        if f < lo || f > hi || !(err[k] <= CROSSOVER_POINT_ERR_MAX) {
            continue;
        }
        let s = c64::new(0.0, 2.0 * PI * f);
        let v: Vec<c64> = evs
            .iter()
            .map(|e| e.eval(s).map(|m| m[(0, 0)]))
            .collect::<std::result::Result<_, _>>()?;
        // The hold the model adds, applied to the measured plant as well.
        let hold = v[1] / v[0];
        let l_meas = frf.response[k] * hold * v[2];
        let l_pred = v[1] * v[2];
        let (s_meas, s_pred) = (one / (one + l_meas), one / (one + l_pred));
        out.freq_hz.push(f);
        out.measured_s_db.push(db(s_meas.norm()));
        out.measured_s_err_db.push(db(1.0 + (l_meas * s_meas).norm() * err[k]));
        out.predicted_s_db.push(db(s_pred.norm()));
        out.measured_t_db.push(db((l_meas * s_meas).norm()));
        out.predicted_t_db.push(db((l_pred * s_pred).norm()));
    }
    if out.freq_hz.len() < 3 {
        return Err(Error::Failed(format!(
            "the flight measures the plant at {} point(s) between {lo:.1} and {hi:.1} Hz (half to twice the flown crossover) with a random error of at most {:.0} %: too few to check the loop there",
            out.freq_hz.len(),
            100.0 * CROSSOVER_POINT_ERR_MAX
        )));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use skyloop_lti::expr::parse_model;
    use skyloop_sysid::spectral::Frf;

    /// An estimate of `truth` at 2–100 Hz, exact, with the error bars of 200 averages at γ² 0.5.
    fn frf_of(truth: &StateSpace) -> Frf {
        let freq_hz: Vec<f64> = (0..120).map(|k| 2.0 * 10f64.powf(1.7 * f64::from(k) / 119.0)).collect();
        let ev = FreqEvaluator::new(truth).unwrap();
        let response = freq_hz
            .iter()
            .map(|f| ev.eval(c64::new(0.0, 2.0 * PI * f)).unwrap()[(0, 0)])
            .collect();
        let n = freq_hz.len();
        Frf {
            freq_hz,
            response,
            coherence: vec![0.5; n],
            dof: vec![200.0; n],
            bandwidth_hz: vec![0.0; n],
        }
    }

    #[test]
    fn a_model_missing_the_dynamics_at_crossover_disagrees_and_the_right_one_agrees() {
        let model = parse_model("126*exp(-0.0034*s)/(s*(0.0088*s+1))").unwrap();
        // The flown PID (C_fb of a Betaflight-like roll axis, in the model's units).
        let c = parse_model("1.1 + 18/s + 0.015*s/(0.0016*s+1)").unwrap();
        let xo = 30.0;
        let same = crossover_check(&frf_of(&model), &model, &model, &c, xo).unwrap();
        assert!(!same.disagrees(), "{:?}", same.to_json());
        assert!(same
            .measured_s_db
            .iter()
            .zip(&same.predicted_s_db)
            .all(|(a, b)| (a - b).abs() < 1e-9));
        // The craft has a second lag at 40 Hz the model lacks: |S| near crossover is far higher.
        let truth = parse_model("126*exp(-0.0034*s)/(s*(0.0088*s+1)*(0.004*s+1))").unwrap();
        let off = crossover_check(&frf_of(&truth), &model, &model, &c, xo).unwrap();
        let (m, _, _) = off.measured_peak();
        let (p, _) = off.predicted_peak();
        assert!(off.disagrees(), "measured {m} vs predicted {p}");
        assert!(m > p + PEAK_DB_MAX, "measured {m} vs predicted {p}");
        // Too few usable points: an error naming the band, not a verdict.
        let mut poor = frf_of(&truth);
        poor.coherence.iter_mut().for_each(|g| *g = 0.001);
        let e = crossover_check(&poor, &model, &model, &c, xo).unwrap_err().to_string();
        assert!(e.contains("between 15.0 and 60.0 Hz"), "{e}");
    }
}
