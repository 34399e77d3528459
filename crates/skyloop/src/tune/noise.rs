//! The noise the controller sees, measured from the log: the logged gyro's power spectral density
//! over the airborne segments (Betaflight `gyroADC`, after the gyro filters; PX4
//! `vehicle_angular_velocity`), and the motor-command noise a candidate's C_fb makes of it,
//! ∫|C_fb(j2πf)|²·S_gyro(f) df over the band above the loop's (from twice the flown crossover to
//! the log's Nyquist frequency; the continuous C_fb with the firmware's filter chain). The
//! prediction is checked on the flown tune against the logged D term (`axisD`), whose spectrum the
//! same gyro spectrum through the D path predicts.
//!
//! Why measured and not a multiple of the ultimate gain: a flown tune that breaks "10·Ku above
//! 3·f_u" seven times and flies smoothly (PID-Analyzer's smooth-tune log) shows that a fixed
//! multiple says nothing of a craft's own noise; its gyro spectrum does.

use crate::error::{Error, Result};
use serde_json::{json, Value};
use skyloop_sysid::logs::Log;
use skyloop_sysid::spectral::psd::{psd, Psd};
use std::ops::Range;

/// The gyro spectrum of a flight and the band the noise is predicted in.
#[derive(Debug, Clone)]
pub struct GyroNoise {
    /// The gyro channel's PSD, (gyro unit)²/Hz.
    pub gyro: Psd,
    /// The noise band, Hz.
    pub band_hz: (f64, f64),
    /// The D term's measured PSD (None when the log has no D channel for the axis).
    pub dterm: Option<Psd>,
}

/// Segment length of the spectra, s (about 2 Hz resolution).
const SEGMENT_S: f64 = 0.5;

/// The PSDs of `gyro` (and `dterm`, when given) over the sample ranges `ranges` of the log's
/// uniform grid at its own rate, with the noise band from `2·crossover_hz` to Nyquist.
///
/// # Errors
/// Channels the log does not hold, or segments too short for one spectrum segment.
pub fn measure(
    log: &Log,
    gyro: &str,
    dterm: Option<&str>,
    spans_s: &[(f64, f64)],
    crossover_hz: f64,
) -> Result<GyroNoise> {
    let one = |name: &str| -> Result<Psd> {
        let d = log.uniform(&[name], None, None, None).map_err(Error::from)?;
        let ranges: Vec<Range<usize>> = spans_s
            .iter()
            .map(|&(a, b)| {
                let lo = ((a - d.t0_s) / d.dt_s).ceil().max(0.0) as usize;
                let hi = (((b - d.t0_s) / d.dt_s).floor().max(0.0) as usize + 1).min(d.len());
                lo..hi.max(lo)
            })
            .collect();
        let x = &d.columns[0];
        let recs: Vec<&[f64]> = ranges.iter().map(|r| &x[r.clone()]).collect();
        let nfft = ((SEGMENT_S / d.dt_s).round() as usize)
            .next_power_of_two()
            .clamp(64, 1 << 14);
        Ok(psd(&recs, d.dt_s, nfft)?)
    };
    let g = one(gyro)?;
    let nyq = g.freq_hz.last().copied().unwrap_or(0.0);
    let lo = (2.0 * crossover_hz).max(10.0).min(0.5 * nyq);
    Ok(GyroNoise {
        band_hz: (lo, nyq),
        dterm: dterm.and_then(|d| one(d).ok()),
        gyro: g,
    })
}

impl GyroNoise {
    /// The PSD points in the band (Hz) and their weights S_gyro(f)·Δf.
    pub fn weights(&self) -> (Vec<f64>, Vec<f64>) {
        self.band_weights(self.band_hz)
    }

    /// As [`weights`](Self::weights) over `band` Hz.
    pub fn band_weights(&self, band: (f64, f64)) -> (Vec<f64>, Vec<f64>) {
        let f = &self.gyro.freq_hz;
        let df = if f.len() > 1 { f[1] - f[0] } else { 1.0 };
        f.iter()
            .zip(&self.gyro.density)
            .filter(|(f, _)| **f >= band.0 && **f <= band.1)
            .map(|(&f, &s)| (f, s * df))
            .unzip()
    }

    /// The same spectra with the gyro's passed through `ratio` (S_gyro·|ratio(j2πf)|²: the gyro a
    /// controller sees behind another gyro lowpass); the logged D term is kept as flown.
    ///
    /// # Errors
    /// A ratio that cannot be evaluated on the spectrum's grid.
    pub fn through(&self, ratio: &skyloop_lti::StateSpace) -> Result<GyroNoise> {
        let ev = skyloop_lti::freqresp::FreqEvaluator::new(ratio)?;
        let mut out = self.clone();
        for (s, f) in out.gyro.density.iter_mut().zip(&self.gyro.freq_hz) {
            let h = ev.eval(skyloop_lti::c64::new(0.0, 2.0 * std::f64::consts::PI * f))?[(0, 0)];
            *s *= h.norm_sqr();
        }
        Ok(out)
    }

    /// Three bands of equal width in octaves across the noise band, Hz.
    pub fn sub_bands(&self) -> Vec<(f64, f64)> {
        let (lo, hi) = self.band_hz;
        let r = (hi / lo).powf(1.0 / 3.0);
        (0..3).map(|k| (lo * r.powi(k), lo * r.powi(k + 1))).collect()
    }
}

/// The noise comparison of a proposal with the flown tune.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseReport {
    /// Predicted motor-command noise power of the flown tune, (PID-output unit)².
    pub flown: f64,
    /// The same of the proposal.
    pub proposed: f64,
    /// The noise band, Hz.
    pub band_hz: (f64, f64),
    /// Per sub-band: (band Hz, flown power, proposed power).
    pub bands: Vec<((f64, f64), f64, f64)>,
    /// Logged D-term power over predicted, flown tune, noise band (1: the prediction holds).
    pub dterm_check: Option<f64>,
    /// Spectra for the report, from 1 Hz to Nyquist: frequency (Hz), the gyro PSD, and the
    /// predicted PID-output PSD of the flown and the proposed tune (units²/Hz), and the logged
    /// D term's PSD where logged.
    pub spectra: Spectra,
    /// The tune's noise budget, the largest proposed/flown power it accepts (`--noise-budget`);
    /// None where no budget applies (a live re-analysis).
    pub budget: Option<f64>,
}

/// The noise spectra a report draws (see [`NoiseReport::spectra`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Spectra {
    /// Frequencies, Hz.
    pub freq_hz: Vec<f64>,
    /// Gyro PSD, (gyro unit)²/Hz.
    pub gyro: Vec<f64>,
    /// The gyro PSD behind the proposal's gyro lowpass (empty when the proposal keeps the flown one).
    pub gyro_proposed: Vec<f64>,
    /// Predicted PID-output PSD of the flown tune.
    pub flown: Vec<f64>,
    /// Predicted PID-output PSD of the proposal.
    pub proposed: Vec<f64>,
    /// The logged D term's PSD (empty when not logged).
    pub dterm: Vec<f64>,
}

impl NoiseReport {
    /// Proposed over flown noise power.
    pub fn ratio(&self) -> f64 {
        self.proposed / self.flown.max(f64::MIN_POSITIVE)
    }

    /// `{flown, proposed, ratio, band_hz, unit, bands: [{band_hz, flown, proposed, ratio}], dterm_check,
    /// budget, spectra: {freq_hz, gyro_psd, gyro_proposed_psd, flown_output_psd,
    /// proposed_output_psd, dterm_psd}}`.
    pub fn to_json(&self) -> Value {
        json!({
            "flown": self.flown,
            "proposed": self.proposed,
            "ratio": self.ratio(),
            "band_hz": [self.band_hz.0, self.band_hz.1],
            "unit": "power of the PID output in the noise band (PID-output unit squared); ratio = proposed/flown",
            "bands": self.bands.iter().map(|(b, f, p)| json!({
                "band_hz": [b.0, b.1], "flown": f, "proposed": p,
                "ratio": p / f.max(f64::MIN_POSITIVE),
            })).collect::<Vec<_>>(),
            "dterm_check": self.dterm_check,
            "budget": self.budget,
            "spectra": {
                "freq_hz": self.spectra.freq_hz,
                "gyro_psd": self.spectra.gyro,
                "gyro_proposed_psd": self.spectra.gyro_proposed,
                "flown_output_psd": self.spectra.flown,
                "proposed_output_psd": self.spectra.proposed,
                "dterm_psd": self.spectra.dterm,
            },
        })
    }
}
