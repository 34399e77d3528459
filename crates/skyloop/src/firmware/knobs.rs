//! A gain set moved by a pilot's knobs: the firmware's gain keys as `tune --json` prints them
//! (`p`, `i`, `d`, `f` for Betaflight; `p`, `i`, `d`, `cd` for INAV; `MC_ROLLRATE_K` ..
//! `MC_ROLLRATE_FF` for PX4; `ATC_RAT_RLL_P` .. `ATC_RAT_RLL_FF` for ArduPilot), and `dterm_hz`:
//! the cutoffs of the D-term filter chain, in the chain's order (Betaflight and INAV: one per
//! lowpass stage, a notch stage keeps its own; PX4: `IMU_DGYRO_CUTOFF`; ArduPilot:
//! `ATC_RAT_<AXIS>_FLTD`).

use super::rate_gains::RateGains;
use super::{ardupilot, betaflight, inav, px4, Lowpass};
use crate::error::{Error, Result};
use serde_json::{json, Value};

impl RateGains {
    /// The gain set the knobs `v` describe (the firmware's keys, and `dterm_hz`), with every key
    /// `v` leaves out taken from these gains.
    ///
    /// # Errors
    /// A gain that is negative, not a number, or not an integer where the firmware's are; a
    /// cutoff that is not positive; more cutoffs than the chain has stages.
    pub fn with_knobs(&self, v: &Value) -> Result<RateGains> {
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
        Ok(match self {
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
            RateGains::Ardupilot {
                gains,
                axis,
                filters,
                plant_unit_rad_s,
            } => {
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
                    plant_unit_rad_s: *plant_unit_rad_s,
                }
            }
        })
    }

    /// The D-term chain's stages as the page shows them: `[{kind, cutoff_hz, movable}]` (a notch
    /// is listed with its centre and cannot be moved; a filter that is off is not listed).
    pub fn dterm_knobs(&self) -> Vec<Value> {
        let stages = |d: &[Lowpass]| -> Vec<Value> { d.iter().map(stage_json).collect() };
        match self {
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
        }
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
