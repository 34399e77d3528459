//! A flown or proposed rate-PID gain set in the firmware's own units, with what the tuner needs of
//! it: the continuous (Kp, Ki, Kd) of the loop's feedback path, the neighbouring gain sets a
//! bounded change may reach (in the firmware's own resolution), the reference path, the JSON gains
//! and the lines the pilot pastes. One value per firmware whose gains a log carries.

use super::ardupilot;
use super::betaflight;
use super::inav;
use super::px4;
use super::vocab::Axis;
use crate::error::Result;
use serde_json::{json, Value};
use skyloop_lti::StateSpace;
use skyloop_robust::structured::blocks::Block;

/// A firmware's rate gains for one axis, with the filters and loop rate they fly with.
#[derive(Debug, Clone, PartialEq)]
pub enum RateGains {
    /// Betaflight integer P, I, D, F (D the constant D flown or proposed).
    Betaflight {
        /// The gains.
        gains: betaflight::Gains,
        /// The axis (yaw's I is scaled by the filters' `yaw_i_factor`).
        axis: Axis,
        /// Filters and loop rate.
        filters: betaflight::Filters,
    },
    /// INAV integer mc_p, mc_i, mc_d, mc_cd.
    Inav {
        /// The gains.
        gains: inav::Gains,
        /// The axis.
        axis: Axis,
        /// Filters and loop rate.
        filters: inav::Filters,
    },
    /// PX4 MC_*RATE_{K,P,I,D,FF}.
    Px4 {
        /// The gains.
        gains: px4::Gains,
        /// The axis.
        axis: Axis,
        /// Filters and loop rate.
        filters: px4::Filters,
    },
    /// ArduPilot `ATC_RAT_<AXIS>_{P,I,D,FF}` (per rad/s); the loop uses the gains × the plant's
    /// unit.
    Ardupilot {
        /// The gains, as the parameters hold them.
        gains: ardupilot::Gains,
        /// The axis.
        axis: Axis,
        /// Filters and loop rate.
        filters: ardupilot::Filters,
        /// rad/s per unit of the plant's output: 1 for a plant in rad/s (`--plant`),
        /// [`ardupilot::LOG_RATE_UNIT_RAD_S`] for one identified from a log's deg/s.
        plant_unit_rad_s: f64,
    },
}

impl RateGains {
    /// The firmware these gains are for.
    pub fn firmware(&self) -> super::Firmware {
        match self {
            RateGains::Betaflight { .. } => super::Firmware::Betaflight,
            RateGains::Inav { .. } => super::Firmware::Inav,
            RateGains::Px4 { .. } => super::Firmware::Px4,
            RateGains::Ardupilot { .. } => super::Firmware::Ardupilot,
        }
    }

    /// The feedback path's tunable structure (filters included): C_fb = block.realize(continuous()).
    ///
    /// # Errors
    /// Invalid filter settings.
    pub fn block(&self) -> Result<Block> {
        match self {
            RateGains::Betaflight { filters, .. } => betaflight::block(filters),
            RateGains::Inav { filters, .. } => inav::block(filters),
            RateGains::Px4 { filters, .. } => px4::block(filters),
            RateGains::Ardupilot { filters, .. } => ardupilot::block(filters),
        }
    }

    /// Continuous (Kp, Ki, Kd) in the plant's units.
    pub fn continuous(&self) -> [f64; 3] {
        match self {
            RateGains::Betaflight { gains, axis, filters } => {
                let (p, i, d, _) = betaflight::continuous(gains, *axis, filters);
                [p, i, d]
            }
            RateGains::Inav { gains, .. } => {
                let (p, i, d, _) = inav::continuous(gains);
                [p, i, d]
            }
            RateGains::Px4 { gains, .. } => {
                let (p, i, d) = px4::continuous(gains);
                [p, i, d]
            }
            RateGains::Ardupilot {
                gains,
                plant_unit_rad_s,
                ..
            } => {
                let g = gains.in_plant_units(*plant_unit_rad_s);
                [g.p, g.i, g.d]
            }
        }
    }

    /// The PID loop rate, Hz.
    pub fn loop_hz(&self) -> f64 {
        match self {
            RateGains::Betaflight { filters, .. } => filters.loop_hz,
            RateGains::Inav { filters, .. } => filters.loop_hz,
            RateGains::Px4 { filters, .. } => filters.loop_hz,
            RateGains::Ardupilot { filters, .. } => filters.loop_hz,
        }
    }

    /// C_fb(s) (y → u, plant units).
    ///
    /// # Errors
    /// Invalid filter settings.
    pub fn feedback_controller(&self) -> Result<StateSpace> {
        Ok(self.block()?.realize(&self.continuous())?)
    }

    /// C_r(s) (setpoint → u).
    ///
    /// # Errors
    /// A loop rate that is not positive.
    pub fn reference_path(&self) -> Result<StateSpace> {
        match self {
            RateGains::Betaflight { gains, axis, filters } => betaflight::reference_path(gains, *axis, filters),
            RateGains::Inav { gains, filters, .. } => inav::reference_path(gains, filters),
            RateGains::Px4 { gains, .. } => px4::reference_path(gains),
            RateGains::Ardupilot {
                gains,
                filters,
                plant_unit_rad_s,
                ..
            } => ardupilot::reference_path(&gains.in_plant_units(*plant_unit_rad_s), filters),
        }
    }

    /// The gains as JSON with the firmware's keys.
    pub fn to_json(&self) -> Value {
        match self {
            RateGains::Betaflight { gains, .. } => json!(gains),
            RateGains::Inav { gains, .. } => json!(gains),
            RateGains::Px4 { gains, axis, .. } => {
                let n = px4::param_names(*axis);
                let mut m = serde_json::Map::new();
                for (k, v) in n.iter().zip([gains.k, gains.p, gains.i, gains.d, gains.ff]) {
                    m.insert(k.clone(), json!(v));
                }
                Value::Object(m)
            }
            RateGains::Ardupilot { gains, axis, .. } => {
                let n = ardupilot::param_names(*axis);
                let mut m = serde_json::Map::new();
                for (k, v) in n.iter().zip([gains.p, gains.i, gains.d, gains.ff]) {
                    m.insert(k.clone(), json!(v));
                }
                Value::Object(m)
            }
        }
    }

    /// The pilot's lines that load these gains.
    pub fn cli(&self) -> Vec<String> {
        match self {
            RateGains::Betaflight { gains, axis, .. } => betaflight::cli_lines(gains, *axis),
            RateGains::Inav { gains, axis, .. } => inav::cli_lines(gains, *axis),
            RateGains::Px4 { gains, axis, .. } => px4::cli_lines(gains, *axis),
            RateGains::Ardupilot { gains, axis, .. } => ardupilot::cli_lines(gains, *axis),
        }
    }

    /// The gains as (name, value) rows for a pilot's table: P, I, D, F (FF).
    pub fn rows(&self) -> Vec<(&'static str, f64)> {
        match self {
            RateGains::Betaflight { gains: g, .. } => vec![
                ("P", f64::from(g.p)),
                ("I", f64::from(g.i)),
                ("D", f64::from(g.d)),
                ("F", f64::from(g.f)),
            ],
            RateGains::Inav { gains: g, .. } => vec![
                ("P", f64::from(g.p)),
                ("I", f64::from(g.i)),
                ("D", f64::from(g.d)),
                ("CD", f64::from(g.cd)),
            ],
            RateGains::Px4 { gains: g, .. } => {
                vec![("K", g.k), ("P", g.p), ("I", g.i), ("D", g.d), ("FF", g.ff)]
            }
            RateGains::Ardupilot { gains: g, .. } => vec![("P", g.p), ("I", g.i), ("D", g.d), ("FF", g.ff)],
        }
    }

    /// Every gain set whose P, I and D each lie within ±`span` (e.g. 0.4) of these, at most
    /// `levels` values per gain in the firmware's resolution (Betaflight, INAV: whole units; PX4,
    /// ArduPilot: six significant digits); the feedforward and PX4's K are kept. A gain at 0 stays 0.
    pub fn neighbours(&self, span: f64, levels: usize) -> Vec<RateGains> {
        let steps = |x: f64, integer: bool| -> Vec<f64> {
            if x <= 0.0 {
                return vec![0.0];
            }
            let (mut lo, mut hi) = (x * (1.0 - span), x * (1.0 + span));
            if integer {
                // Whole units inside the bound (never beyond ±span).
                (lo, hi) = ((lo - 1e-9).ceil(), (hi + 1e-9).floor());
            }
            let n = levels.max(2);
            let mut v: Vec<f64> = (0..n)
                .map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64)
                .map(|y| if integer { y.round() } else { super::round6(y) })
                .filter(|y| *y >= 0.0 && *y >= x * (1.0 - span) * (1.0 - 1e-9) && *y <= x * (1.0 + span) * (1.0 + 1e-9))
                .collect();
            v.push(x);
            v.sort_by(f64::total_cmp);
            v.dedup();
            v
        };
        // Every (P, I, D) of the three gains' steps, none above the firmware's largest gain.
        let grid = |pid: [f64; 3], integer: bool, max: f64, make: &dyn Fn(f64, f64, f64) -> RateGains| {
            let mut out = Vec::new();
            for p in steps(pid[0], integer) {
                for i in steps(pid[1], integer) {
                    for d in steps(pid[2], integer) {
                        if p.max(i).max(d) <= max {
                            out.push(make(p, i, d));
                        }
                    }
                }
            }
            out
        };
        match self {
            RateGains::Betaflight { gains, axis, filters } => grid(
                [gains.p, gains.i, gains.d].map(f64::from),
                true,
                f64::from(betaflight::PID_GAIN_MAX),
                &|p, i, d| RateGains::Betaflight {
                    gains: betaflight::Gains {
                        p: p as u32,
                        i: i as u32,
                        d: d as u32,
                        f: gains.f,
                    },
                    axis: *axis,
                    filters: filters.clone(),
                },
            ),
            RateGains::Inav { gains, axis, filters } => grid(
                [gains.p, gains.i, gains.d].map(f64::from),
                true,
                f64::from(inav::GAIN_MAX),
                &|p, i, d| RateGains::Inav {
                    gains: inav::Gains {
                        p: p as u32,
                        i: i as u32,
                        d: d as u32,
                        cd: gains.cd,
                    },
                    axis: *axis,
                    filters: filters.clone(),
                },
            ),
            RateGains::Px4 { gains, axis, filters } => {
                grid([gains.p, gains.i, gains.d], false, f64::INFINITY, &|p, i, d| {
                    RateGains::Px4 {
                        gains: px4::Gains { p, i, d, ..*gains },
                        axis: *axis,
                        filters: *filters,
                    }
                })
            }
            RateGains::Ardupilot {
                gains,
                axis,
                filters,
                plant_unit_rad_s,
            } => grid([gains.p, gains.i, gains.d], false, f64::INFINITY, &|p, i, d| {
                RateGains::Ardupilot {
                    gains: ardupilot::Gains { p, i, d, ..*gains },
                    axis: *axis,
                    filters: *filters,
                    plant_unit_rad_s: *plant_unit_rad_s,
                }
            }),
        }
    }

    /// The same gains with every D-term lowpass cutoff scaled by `k` (whole Hz, as
    /// [`super::Lowpass::scaled`]; notches kept); None when the D term has no lowpass to scale.
    pub fn with_dterm_scale(&self, k: f64) -> Option<RateGains> {
        let scaled = |hz: f64| super::scaled_cutoff_hz(hz, k);
        let mut out = self.clone();
        match &mut out {
            RateGains::Betaflight { filters, .. } => filters.dterm = super::scale_lowpasses(&filters.dterm, k),
            RateGains::Inav { filters, .. } => filters.dterm = super::scale_lowpasses(&filters.dterm, k),
            RateGains::Px4 { filters, .. } if filters.dgyro_cutoff_hz > 0.0 => {
                filters.dgyro_cutoff_hz = scaled(filters.dgyro_cutoff_hz);
            }
            RateGains::Ardupilot { filters, .. } if filters.fltd_hz > 0.0 => filters.fltd_hz = scaled(filters.fltd_hz),
            RateGains::Px4 { .. } | RateGains::Ardupilot { .. } => return None,
        }
        self.lowest_dterm_cutoff_hz()?;
        Some(out)
    }

    /// The D-term filter stages in the controller, in order: Betaflight's and INAV's chain,
    /// PX4's `IMU_DGYRO_CUTOFF` biquad, ArduPilot's `FLTD` first-order lowpass (empty when off).
    pub fn dterm_lowpasses(&self) -> Vec<super::Lowpass> {
        match self {
            RateGains::Betaflight { filters, .. } => filters.dterm.clone(),
            RateGains::Inav { filters, .. } => filters.dterm.clone(),
            RateGains::Px4 { filters, .. } => (filters.dgyro_cutoff_hz > 0.0)
                .then_some(super::Lowpass::Biquad(filters.dgyro_cutoff_hz))
                .into_iter()
                .collect(),
            RateGains::Ardupilot { filters, .. } => (filters.fltd_hz > 0.0)
                .then_some(super::Lowpass::Pt1(filters.fltd_hz))
                .into_iter()
                .collect(),
        }
    }

    /// The lowest D-term lowpass cutoff, Hz (None without one).
    pub fn lowest_dterm_cutoff_hz(&self) -> Option<f64> {
        super::lowest_cutoff_hz(&self.dterm_lowpasses())
    }

    /// The relative change of each of P, I, D from `flown`, e.g. [+0.2, 0, −0.1].
    pub fn change_from(&self, flown: &RateGains) -> Vec<(&'static str, f64)> {
        self.rows()
            .into_iter()
            .zip(flown.rows())
            .map(|((n, a), (_, b))| (n, if b != 0.0 { a / b - 1.0 } else { 0.0 }))
            .collect()
    }
}
