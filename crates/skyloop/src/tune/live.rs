//! Re-analysing other gains and filter cutoffs on a log tune's model, fast enough for a slider:
//! the same margins over the uncertainty set, noise gain and predicted step as `tune LOG` reports
//! for the flown and proposed tunes (one [`super::log`] analysis, the 6-DOF flight left out), plus
//! L's frequency response, the disk the Nyquist curve must avoid, and the predicted motor noise
//! against the flown tune's from the log's gyro spectrum.
//!
//! Gains are given with the firmware's own keys, as `tune --json` prints them, optionally with
//! `dterm_hz`, the D-term chain's cutoffs ([`RateGains::with_knobs`] says which).

use super::candidates::Screen;
use super::log::{analyse, noise_of};
use super::noise::GyroNoise;
use crate::error::Result;
use crate::firmware::rate_gains::RateGains;
use serde_json::{json, Value};
use skyloop_lti::freqresp::freqresp_flat;
use skyloop_lti::StateSpace;
use std::f64::consts::PI;

/// What re-analysing gains on a log's model needs: kept by [`super::log::tune_from_log`].
#[derive(Debug, Clone)]
pub struct LiveLoop {
    /// The flown gains with the filters and loop rate they flew with.
    pub flown: RateGains,
    /// The uncertainty set with the loop's sample-and-hold (nominal first).
    pub held: Vec<StateSpace>,
    /// Lowest frequency of the noise-gain peak search, rad/s (3× the ultimate frequency).
    pub wn: f64,
    /// The log's gyro spectrum (None when it could not be measured).
    pub gyro_noise: Option<GyroNoise>,
}

/// Points of the frequency grid of [`LiveLoop::evaluate`].
pub const GRID_POINTS: usize = 240;

impl LiveLoop {
    /// The gain set `v` describes (the firmware's keys, and `dterm_hz`), with every key it leaves
    /// out taken from the flown tune.
    ///
    /// # Errors
    /// A gain that is negative, not a number, or not an integer where the firmware's are; a cutoff
    /// that is not positive; more cutoffs than the chain has stages.
    pub fn gains(&self, v: &Value) -> Result<RateGains> {
        self.flown.with_knobs(v)
    }

    /// The knobs of a gain set as the page shows them: `{gains: {key: value}, dterm: [{kind,
    /// cutoff_hz}]}` (the D-term chain's stages; a notch is listed with its centre and cannot be
    /// moved).
    pub fn knobs(g: &RateGains) -> Value {
        json!({"gains": g.to_json(), "dterm": g.dterm_knobs(), "loop_hz": g.loop_hz()})
    }

    /// One gain set analysed as `tune LOG` analyses the flown and proposed tunes (the `proposed`
    /// object of `tune --json`, without the 6-DOF flight; with `robust` false on the nominal plant
    /// alone, about a seventh of the work, for a slider being dragged: `worst_margins` is then
    /// null, and `noise` carries the band's powers without spectra), plus `loop` (L = P·C_fb on
    /// [`GRID_POINTS`] frequencies from 1 Hz to the loop's Nyquist frequency: `freq_hz`, `mag_db`,
    /// `phase_deg`, `re`, `im`), `disk` (the region of the Nyquist plane the disk margin keeps L
    /// out of: `center_re`, `radius`), `noise` (the predicted motor-command noise against the
    /// flown tune's, or null), `knobs` and `cli`.
    ///
    /// # Errors
    /// Filter settings the controller cannot be built from, or a loop whose margins fail.
    pub fn evaluate(&self, g: &RateGains, robust: bool) -> Result<Value> {
        let c = g.feedback_controller()?;
        let held = if robust { &self.held[..] } else { &self.held[..1] };
        let a = analyse(g.to_json(), &c, &g.reference_path()?, held, self.wn, None)?;
        let mut v = a.to_json();
        if !robust {
            v["worst_margins"] = Value::Null;
        }
        v["robust"] = json!(robust);
        let (n, hi) = (GRID_POINTS, (0.5 * g.loop_hz()).max(10.0));
        let freq_hz: Vec<f64> = (0..n)
            .map(|k| 10f64.powf(hi.log10() * k as f64 / (n - 1) as f64))
            .collect();
        v["loop"] = loop_response(&self.held[0], &c, &freq_hz)?;
        v["disk"] = disk_json(a.margins.disk_alpha);
        v["noise"] = match (&self.gyro_noise, robust) {
            (Some(gn), true) => noise_of(gn, gn, &self.flown, g, &self.held[..1])?.to_json(),
            (Some(gn), false) => self.noise_ratio(gn, g)?,
            (None, _) => Value::Null,
        };
        v["knobs"] = Self::knobs(g);
        v["cli"] = json!(g.cli());
        Ok(v)
    }
}

impl LiveLoop {
    /// The predicted motor-command noise power of `g` and of the flown tune in the whole noise
    /// band, as [`noise_of`] computes its `flown` and `proposed` (one screen each, without its
    /// sub-bands, spectra and D-term check): `{flown, proposed, ratio, band_hz, spectra: null}`.
    fn noise_ratio(&self, gn: &GyroNoise, g: &RateGains) -> Result<Value> {
        let (f, w) = gn.band_weights(gn.band_hz);
        let power = |g: &RateGains| -> Result<f64> {
            Ok(Screen::new(&g.block()?, &self.held[..1], 10.0, &f, &w)?.noise(g.continuous()))
        };
        let (flown, proposed) = (power(&self.flown)?, power(g)?);
        Ok(json!({
            "flown": flown,
            "proposed": proposed,
            "ratio": proposed / flown.max(f64::MIN_POSITIVE),
            "band_hz": [gn.band_hz.0, gn.band_hz.1],
            "spectra": Value::Null,
        }))
    }
}

/// L = P·C at `freq_hz` (exact delays): `{freq_hz, mag_db, phase_deg (unwrapped along the grid),
/// re, im}`.
///
/// # Errors
/// A model that is not SISO, or a frequency at a pole.
pub fn loop_response(plant: &StateSpace, c: &StateSpace, freq_hz: &[f64]) -> Result<Value> {
    let w: Vec<f64> = freq_hz.iter().map(|f| 2.0 * PI * f).collect();
    let p = freqresp_flat(plant, &w)?;
    let cc = freqresp_flat(c, &w)?;
    let l: Vec<_> = p.iter().zip(&cc).map(|(a, b)| a * b).collect();
    // The phase unwrapped along the grid, so a Bode plot draws no jumps of 360°.
    let mut phase = Vec::with_capacity(l.len());
    let mut prev = f64::NAN;
    for z in &l {
        let mut ph = z.arg().to_degrees();
        if prev.is_finite() {
            ph -= 360.0 * ((ph - prev) / 360.0).round();
        }
        phase.push(ph);
        prev = ph;
    }
    Ok(json!({
        "freq_hz": freq_hz,
        "mag_db": l.iter().map(|z| 20.0 * z.norm().log10()).collect::<Vec<_>>(),
        "phase_deg": phase,
        "re": l.iter().map(|z| z.re).collect::<Vec<_>>(),
        "im": l.iter().map(|z| z.im).collect::<Vec<_>>(),
    }))
}

/// The disk of the Nyquist plane a loop with (balanced, skew 0) disk margin α keeps out of: the
/// critical points −1/f for every gain–phase factor f in the disk through (1 − α/2)/(1 + α/2) and
/// its reciprocal on the real axis; it meets the real axis at −1/g_min and −1/g_max.
fn disk_json(alpha: f64) -> Value {
    if !(alpha.is_finite() && alpha > 0.0 && alpha < 2.0) {
        return Value::Null;
    }
    let g_min = (1.0 - alpha / 2.0) / (1.0 + alpha / 2.0);
    let (a, b) = (-1.0 / g_min, -g_min);
    json!({"center_re": 0.5 * (a + b), "radius": 0.5 * (b - a), "real_axis": [a, b]})
}
