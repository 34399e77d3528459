//! Re-analysing other gains and filter cutoffs on a log tune's model, fast enough for a slider:
//! the same margins over the uncertainty set, noise gain and predicted step as `tune LOG` reports
//! for the flown and proposed tunes (one [`super::log`] analysis, the 6-DOF flight left out), plus
//! L's frequency response, the disk the Nyquist curve must avoid, and the predicted motor noise
//! against the flown tune's from the log's gyro spectrum.
//!
//! Gains are given with the firmware's own keys, as `tune --json` prints them (`p`, `i`, `d`, `f`
//! for Betaflight; `p`, `i`, `d`, `cd` for INAV; `MC_ROLLRATE_K` .. `MC_ROLLRATE_FF` for PX4),
//! optionally with `dterm_hz`: the cutoffs of the D-term filter chain, in the chain's order
//! (Betaflight and INAV: one per lowpass stage, a notch stage keeps its own; PX4: one value,
//! `IMU_DGYRO_CUTOFF`; ArduPilot: one value, `ATC_RAT_<AXIS>_FLTD`, with `ATC_RAT_RLL_P` ..
//! `ATC_RAT_RLL_FF` as its gain keys).

use super::candidates::Screen;
use super::log::{analyse, noise_of};
use super::noise::GyroNoise;
use crate::error::{Error, Result};
use crate::firmware::ardupilot;
use crate::firmware::betaflight;
use crate::firmware::inav;
use crate::firmware::px4;
use crate::firmware::rate_gains::RateGains;
use crate::firmware::Lowpass;
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
        let int = |k: &str, flown: u32| -> Result<u32> {
            match v.get(k) {
                None | Some(Value::Null) => Ok(flown),
                Some(x) => x
                    .as_f64()
                    .filter(|f| *f >= 0.0 && f.fract() == 0.0 && *f <= f64::from(u32::MAX))
                    .map(|f| f as u32)
                    .ok_or_else(|| Error::Input(format!("gain {k} must be a non-negative integer, got {x}"))),
            }
        };
        let real = |k: &str, flown: f64| -> Result<f64> {
            match v.get(k) {
                None | Some(Value::Null) => Ok(flown),
                Some(x) => x
                    .as_f64()
                    .filter(|f| f.is_finite() && *f >= 0.0)
                    .ok_or_else(|| Error::Input(format!("gain {k} must be a non-negative number, got {x}"))),
            }
        };
        let cutoffs = cutoffs_of(v)?;
        Ok(match &self.flown {
            RateGains::Betaflight { gains, axis, filters } => RateGains::Betaflight {
                gains: betaflight::Gains {
                    p: int("p", gains.p)?,
                    i: int("i", gains.i)?,
                    d: int("d", gains.d)?,
                    f: int("f", gains.f)?,
                },
                axis: *axis,
                filters: betaflight::Filters {
                    dterm: with_cutoffs(&filters.dterm, &cutoffs)?,
                    ..filters.clone()
                },
            },
            RateGains::Inav { gains, axis, filters } => RateGains::Inav {
                gains: inav::Gains {
                    p: int("p", gains.p)?,
                    i: int("i", gains.i)?,
                    d: int("d", gains.d)?,
                    cd: int("cd", gains.cd)?,
                },
                axis: *axis,
                filters: inav::Filters {
                    dterm: with_cutoffs(&filters.dterm, &cutoffs)?,
                    ..filters.clone()
                },
            },
            RateGains::Px4 { gains, axis, filters } => {
                let n = px4::param_names(*axis);
                if cutoffs.len() > 1 {
                    return Err(Error::Input(
                        "dterm_hz: PX4 has one D-term cutoff (IMU_DGYRO_CUTOFF)".into(),
                    ));
                }
                RateGains::Px4 {
                    gains: px4::Gains {
                        k: real(&n[0], gains.k)?,
                        p: real(&n[1], gains.p)?,
                        i: real(&n[2], gains.i)?,
                        d: real(&n[3], gains.d)?,
                        ff: real(&n[4], gains.ff)?,
                    },
                    axis: *axis,
                    filters: px4::Filters {
                        dgyro_cutoff_hz: cutoffs.first().copied().unwrap_or(filters.dgyro_cutoff_hz),
                        ..*filters
                    },
                }
            }
            RateGains::Ardupilot { gains, axis, filters } => {
                let n = ardupilot::param_names(*axis);
                if cutoffs.len() > 1 {
                    return Err(Error::Input(format!(
                        "dterm_hz: ArduPilot has one D-term cutoff ({})",
                        n[0].replace("_P", "_FLTD")
                    )));
                }
                RateGains::Ardupilot {
                    gains: ardupilot::Gains {
                        p: real(&n[0], gains.p)?,
                        i: real(&n[1], gains.i)?,
                        d: real(&n[2], gains.d)?,
                        ff: real(&n[3], gains.ff)?,
                    },
                    axis: *axis,
                    filters: ardupilot::Filters {
                        fltd_hz: cutoffs.first().copied().unwrap_or(filters.fltd_hz),
                        ..*filters
                    },
                }
            }
        })
    }

    /// The knobs of a gain set as the page shows them: `{gains: {key: value}, dterm: [{kind,
    /// cutoff_hz}]}` (the D-term chain's stages; a notch is listed with its centre and cannot be
    /// moved).
    pub fn knobs(g: &RateGains) -> Value {
        let stages = |d: &[Lowpass]| -> Vec<Value> { d.iter().map(stage_json).collect() };
        let dterm = match g {
            RateGains::Betaflight { filters, .. } => stages(&filters.dterm),
            RateGains::Inav { filters, .. } => stages(&filters.dterm),
            RateGains::Px4 { filters, .. } => {
                vec![json!({"kind": "biquad", "cutoff_hz": filters.dgyro_cutoff_hz, "movable": true})]
            }
            // FLTD at 0 is off: no cutoff to move.
            RateGains::Ardupilot { filters, .. } if filters.fltd_hz > 0.0 => {
                vec![json!({"kind": "pt1", "cutoff_hz": filters.fltd_hz, "movable": true})]
            }
            RateGains::Ardupilot { .. } => Vec::new(),
        };
        json!({"gains": g.to_json(), "dterm": dterm, "loop_hz": g.loop_hz()})
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
            (Some(gn), true) => noise_of(gn, &self.flown, g, &self.held[..1])?.to_json(),
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

/// `dterm_hz` of a knob object (empty when absent).
fn cutoffs_of(v: &Value) -> Result<Vec<f64>> {
    match v.get("dterm_hz") {
        None | Some(Value::Null) => Ok(Vec::new()),
        Some(Value::Array(a)) => a
            .iter()
            .map(|x| {
                x.as_f64()
                    .filter(|f| f.is_finite() && *f > 0.0)
                    .ok_or_else(|| Error::Input(format!("dterm_hz: a cutoff must be a positive number of Hz, got {x}")))
            })
            .collect(),
        Some(x) => Err(Error::Input(format!(
            "dterm_hz must be a list of cutoffs in Hz, got {x}"
        ))),
    }
}

/// The chain with its lowpass stages moved to `cutoffs` (in order; a notch keeps its own).
fn with_cutoffs(chain: &[Lowpass], cutoffs: &[f64]) -> Result<Vec<Lowpass>> {
    if cutoffs.len() > chain.len() {
        return Err(Error::Input(format!(
            "dterm_hz: {} cutoffs for a D-term chain of {} stages",
            cutoffs.len(),
            chain.len()
        )));
    }
    Ok(chain
        .iter()
        .enumerate()
        .map(|(k, l)| cutoffs.get(k).map_or(*l, |&f| l.with_cutoff(f)))
        .collect())
}

fn stage_json(l: &Lowpass) -> Value {
    let (kind, hz, movable) = match *l {
        Lowpass::Pt1(f) => ("pt1", f, true),
        Lowpass::Pt2(f) => ("pt2", f, true),
        Lowpass::Pt3(f) => ("pt3", f, true),
        Lowpass::Biquad(f) => ("biquad", f, true),
        Lowpass::Notch(f0, _) => ("notch", f0, false),
    };
    json!({"kind": kind, "cutoff_hz": hz, "movable": movable})
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
