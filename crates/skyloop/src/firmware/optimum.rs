//! What the tuner asks of a firmware when it turns the optimizer's continuous (Kp, Ki, Kd) into
//! gains the flight controller stores: each firmware's controller with default gains (the
//! optimizer's template), the gain sets in the firmware's resolution near an optimum, the
//! feedforward's paths, bound and resolution, and the notes on units and ranges.

use super::rate_gains::RateGains;
use super::vocab::Axis;
use super::{ardupilot, betaflight, inav, px4, round6, Firmware};
use crate::error::Result;
use skyloop_lti::StateSpace;

/// Largest PX4 rate feedforward the fit may propose, normalized torque per rad/s (a sanity bound:
/// full torque for a 1 rad/s setpoint).
const PX4_FF_MAX: f64 = 1.0;

impl RateGains {
    /// The firmware's controller with its default filters and loop rate, P = I = D = 0 and the
    /// default feedforward (Betaflight F 120, 4.4's default; 0 elsewhere), for a plant in the
    /// firmware's own units (ArduPilot: rad/s); None for [`Firmware::Generic`].
    pub fn template(firmware: Firmware, axis: Axis) -> Option<RateGains> {
        match firmware {
            Firmware::Betaflight => Some(RateGains::Betaflight {
                gains: betaflight::Gains {
                    p: 0,
                    i: 0,
                    d: 0,
                    f: 120,
                },
                axis,
                filters: betaflight::Filters::default(),
            }),
            Firmware::Inav => Some(RateGains::Inav {
                gains: inav::Gains {
                    p: 0,
                    i: 0,
                    d: 0,
                    cd: 0,
                },
                axis,
                filters: inav::Filters::default(),
            }),
            Firmware::Px4 => Some(RateGains::Px4 {
                gains: px4::Gains::default(),
                axis,
                filters: px4::Filters::default(),
            }),
            Firmware::Ardupilot => Some(RateGains::Ardupilot {
                gains: ardupilot::Gains::default(),
                axis,
                filters: ardupilot::Filters::default(),
                plant_unit_rad_s: 1.0,
            }),
            Firmware::Generic => None,
        }
    }

    /// Whether a rounding to the firmware's resolution can move the loop enough to break a goal
    /// the optimum met (Betaflight's whole units), so the tuner re-tunes with tightened bounds.
    pub fn coarse_resolution(&self) -> bool {
        matches!(self, RateGains::Betaflight { .. })
    }

    /// The gain sets in the firmware's resolution near the continuous optimum `th` = (Kp, Ki, Kd)
    /// in the plant's units, feedforward and filters as these: Betaflight the 8 floor/ceil
    /// roundings of (P, I, D) and the floors with I lowered by 1 to 10 units (one unit of I can
    /// move the margins more than a tightened re-tune foresees); INAV its rounding; PX4 and
    /// ArduPilot six significant digits.
    ///
    /// # Errors
    /// A gain beyond the firmware's largest (named).
    pub fn roundings(&self, th: &[f64]) -> Result<Vec<RateGains>> {
        let t = |k: usize| th.get(k).copied().unwrap_or(0.0);
        Ok(match self {
            RateGains::Betaflight { gains, axis, filters } => {
                let yaw = if *axis == Axis::Yaw { filters.yaw_i_factor } else { 1.0 };
                let scales = [
                    betaflight::PTERM_SCALE,
                    betaflight::ITERM_SCALE * yaw,
                    betaflight::DTERM_SCALE,
                ];
                let units: Vec<f64> = (0..3).map(|j| t(j) / scales[j]).collect();
                let make = |u: [f64; 3]| -> Result<RateGains> {
                    Ok(RateGains::Betaflight {
                        gains: betaflight::from_continuous(
                            u[0] * scales[0],
                            u[1] * scales[1],
                            u[2] * scales[2],
                            gains.f,
                            *axis,
                            filters,
                        )?,
                        axis: *axis,
                        filters: filters.clone(),
                    })
                };
                let mut out = Vec::new();
                for mask in 0..8u32 {
                    let pick = |j: usize| {
                        (if mask & (1 << j) == 0 {
                            units[j].floor()
                        } else {
                            units[j].ceil()
                        })
                        .max(0.0)
                    };
                    out.push(make([pick(0), pick(1), pick(2)])?);
                }
                let floors: Vec<f64> = units.iter().map(|u| u.floor().max(0.0)).collect();
                for back in 1..=10u32 {
                    let i = floors[1] - f64::from(back);
                    if i < 0.0 {
                        break;
                    }
                    out.push(make([floors[0], i, floors[2]])?);
                }
                out
            }
            RateGains::Inav { gains, axis, filters } => vec![RateGains::Inav {
                gains: inav::from_continuous(t(0), t(1), t(2), gains.cd, *axis)?,
                axis: *axis,
                filters: filters.clone(),
            }],
            RateGains::Px4 { gains, axis, filters } => vec![RateGains::Px4 {
                gains: px4::Gains {
                    p: round6(t(0) / gains.k),
                    i: round6(t(1) / gains.k),
                    d: round6(t(2) / gains.k),
                    ..*gains
                },
                axis: *axis,
                filters: *filters,
            }],
            RateGains::Ardupilot {
                gains,
                axis,
                filters,
                plant_unit_rad_s: u,
            } => vec![RateGains::Ardupilot {
                gains: ardupilot::Gains {
                    p: round6(t(0) / u),
                    i: round6(t(1) / u),
                    d: round6(t(2) / u),
                    ff: gains.ff,
                },
                axis: *axis,
                filters: *filters,
                plant_unit_rad_s: *u,
            }],
        })
    }

    /// The feedforward's two paths in the plant's units: the reference path with the feedforward
    /// at zero, and the feedforward's own path per unit of gain (C_r = first + gain·second).
    ///
    /// # Errors
    /// Filter settings the paths cannot be built from.
    pub fn feedforward_paths(&self) -> Result<(StateSpace, StateSpace)> {
        Ok(match self {
            RateGains::Betaflight { gains, axis, filters } => (
                betaflight::reference_path(&betaflight::Gains { f: 0, ..*gains }, *axis, filters)?,
                betaflight::feedforward_unit(filters.loop_hz)?,
            ),
            RateGains::Inav { gains, filters, .. } => (
                inav::reference_path(&inav::Gains { cd: 0, ..*gains }, filters)?,
                inav::feedforward_unit(filters)?,
            ),
            RateGains::Px4 { gains, .. } => (
                px4::reference_path(&px4::Gains { ff: 0.0, ..*gains })?,
                super::static_gain(1.0)?,
            ),
            RateGains::Ardupilot {
                gains,
                filters,
                plant_unit_rad_s: u,
                ..
            } => (
                ardupilot::reference_path(&ardupilot::Gains { ff: 0.0, ..*gains }.in_plant_units(*u), filters)?,
                ardupilot::feedforward_unit(filters)?,
            ),
        })
    }

    /// The largest feedforward gain a fit may propose, plant units (the firmware's largest
    /// stored value; PX4: full torque for 1 rad/s).
    pub fn feedforward_max(&self) -> f64 {
        match self {
            RateGains::Betaflight { .. } => f64::from(betaflight::F_GAIN_MAX) * betaflight::FTERM_SCALE / 100.0,
            RateGains::Inav { .. } => f64::from(inav::GAIN_MAX) / inav::CD_MULTIPLIER,
            RateGains::Px4 { .. } => PX4_FF_MAX,
            RateGains::Ardupilot { plant_unit_rad_s, .. } => ardupilot::GAIN_RANGES[3].1 * plant_unit_rad_s,
        }
    }

    /// These gains with the feedforward `gain` (plant units, as [`Self::feedforward_paths`]
    /// count it), in the firmware's resolution and range.
    pub fn with_feedforward(&self, gain: f64) -> RateGains {
        let mut g = self.clone();
        match &mut g {
            RateGains::Betaflight { gains, .. } => {
                let unit = betaflight::FTERM_SCALE / 100.0;
                gains.f = (gain / unit).round().clamp(0.0, f64::from(betaflight::F_GAIN_MAX)) as u32;
            }
            RateGains::Inav { gains, .. } => {
                gains.cd = (gain * inav::CD_MULTIPLIER)
                    .round()
                    .clamp(0.0, f64::from(inav::GAIN_MAX)) as u32;
            }
            RateGains::Px4 { gains, .. } => gains.ff = round6(gain),
            RateGains::Ardupilot {
                gains,
                plant_unit_rad_s,
                ..
            } => gains.ff = round6(gain / *plant_unit_rad_s),
        }
        g
    }

    /// The feedforward as the pilot names it, with its value: `f_roll = 120`, `mc_cd_roll = 40`,
    /// `FF = 0.05`.
    pub fn feedforward_label(&self) -> String {
        match self {
            RateGains::Betaflight { gains, axis, .. } => format!("f_{} = {}", axis.name(), gains.f),
            RateGains::Inav { gains, axis, .. } => format!("mc_cd_{} = {}", axis.name(), gains.cd),
            RateGains::Px4 { gains, .. } => format!("FF = {}", gains.ff),
            RateGains::Ardupilot { gains, .. } => format!("FF = {}", gains.ff),
        }
    }

    /// What to say of a feedforward kept at the template's default (not flown): Betaflight's
    /// is 4.4's default, which the pilot should replace by their own.
    pub fn default_feedforward_note(&self) -> &'static str {
        match self {
            RateGains::Betaflight { .. } => "; Betaflight 4.4's default, keep yours",
            _ => "",
        }
    }

    /// The notes a tune states about these gains: the plant's units the gains assume, the
    /// structure, and gains outside the documented ranges.
    pub fn tuning_notes(&self) -> Vec<String> {
        match self {
            RateGains::Betaflight { .. } => vec!["plant units: input Betaflight's PID sum, output gyro deg/s".into()],
            RateGains::Inav { .. } => vec!["plant units: input INAV's PID sum, output gyro deg/s".into()],
            RateGains::Px4 { gains, .. } => vec![
                format!("MC_*RATE_K = {} (parallel form)", gains.k),
                "plant units: input normalized torque, output rad/s".into(),
            ],
            RateGains::Ardupilot {
                gains,
                axis,
                plant_unit_rad_s,
                ..
            } => {
                let mut n = ardupilot::range_notes(gains, *axis);
                n.push(if *plant_unit_rad_s == 1.0 {
                    "plant units: input the mixer's normalized command, output rad/s; IMAX and SMAX not modelled".into()
                } else {
                    "plant units: input RATE.ROut (the mixer's normalized command), output RATE.R deg/s; the gains act on rad/s; IMAX and SMAX not modelled".into()
                });
                n
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use Axis;

    /// Every firmware's template rounds an optimum to gains whose continuous form is the optimum
    /// within the firmware's resolution, and a feedforward set in plant units reads back.
    #[test]
    fn roundings_and_feedforward_round_trip() {
        let th = [0.2, 0.9, 0.004];
        for fw in [Firmware::Betaflight, Firmware::Inav, Firmware::Px4, Firmware::Ardupilot] {
            let t = RateGains::template(fw, Axis::Roll).unwrap();
            // Betaflight's and INAV's gains are whole units (Betaflight's I: 0.24 per unit, a
            // quarter of 0.9): within one unit; PX4's and ArduPilot's within 5 %.
            let tol = |k: usize| match fw {
                Firmware::Betaflight => [
                    betaflight::PTERM_SCALE,
                    betaflight::ITERM_SCALE,
                    betaflight::DTERM_SCALE,
                ][k],
                Firmware::Inav => 1.0 / [inav::P_MULTIPLIER, inav::I_MULTIPLIER, inav::D_MULTIPLIER][k],
                _ => 0.05 * th[k],
            };
            let r = t.roundings(&th).unwrap();
            assert!(!r.is_empty());
            for g in &r[..r.len().min(8)] {
                let c = g.continuous();
                for k in 0..3 {
                    assert!(
                        (c[k] - th[k]).abs() <= tol(k) * (1.0 + 1e-9),
                        "{fw:?} {k}: {} vs {}",
                        c[k],
                        th[k]
                    );
                }
            }
            let ff = 0.5 * t.feedforward_max();
            let g = t.with_feedforward(ff);
            let (c0, cf) = g.feedforward_paths().unwrap();
            let w = skyloop_lti::c64::new(0.0, 3.0);
            let cr = skyloop_lti::freqresp::evalfr(&g.reference_path().unwrap(), w).unwrap()[(0, 0)];
            let sum = skyloop_lti::freqresp::evalfr(&c0, w).unwrap()[(0, 0)]
                + ff * skyloop_lti::freqresp::evalfr(&cf, w).unwrap()[(0, 0)];
            // Integer firmwares round the gain to a unit: Betaflight's F to 1/1000 of its range,
            // INAV's mc_cd to 1/255 (half a unit off at most: 0.4 % of this gain).
            assert!((cr - sum).norm() < 5e-3 * sum.norm(), "{fw:?}: {cr} vs {sum}");
        }
        assert!(RateGains::template(Firmware::Generic, Axis::Roll).is_none());
    }

    /// ArduPilot's gains act on rad/s: on a plant in deg/s the same parameters give a loop gain
    /// π/180 as large, and an optimum in deg/s units maps back to the parameters.
    #[test]
    fn ardupilot_plant_units() {
        let Some(RateGains::Ardupilot {
            gains, axis, filters, ..
        }) = RateGains::template(Firmware::Ardupilot, Axis::Pitch)
        else {
            panic!("template")
        };
        let deg = RateGains::Ardupilot {
            gains: ardupilot::Gains { p: 0.135, ..gains },
            axis,
            filters,
            plant_unit_rad_s: ardupilot::LOG_RATE_UNIT_RAD_S,
        };
        assert!((deg.continuous()[0] - 0.135 * std::f64::consts::PI / 180.0).abs() < 1e-15);
        let back = deg.roundings(&deg.continuous()).unwrap();
        assert!(
            back[0].cli()[0] == "param set ATC_RAT_PIT_P 0.135",
            "{:?}",
            back[0].cli()
        );
    }
}
