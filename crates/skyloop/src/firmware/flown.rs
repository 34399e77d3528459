//! The flown tune a log states, read through its firmware: the controller the tuner fills in
//! (filters, loop rate, feedforward, the plant's units), the flown gains, and what a report says
//! of them. One dispatcher over the firmwares; each firmware's file reads its own header.

use super::filter_settings::FilterSettings;
use super::rate_gains::RateGains;
use super::vocab::Axis;
use super::{ardupilot, betaflight, inav, px4, Firmware};
use crate::error::{Error, Result};
use crate::firmware::FirmwareTuning;
use skyloop_sysid::logs::Log;

/// The flown tune of one axis as a log states it.
#[derive(Debug, Clone)]
pub struct FlownTune {
    /// The controller with the flown filters, loop rate and plant units, and the flown gains
    /// (P = I = D = 0 and the default feedforward when the log has none).
    pub controller: RateGains,
    /// Whether the log carries the axis's gains (then `controller` holds them).
    pub gains_flown: bool,
    /// Betaflight with d_min active: the header's gains (D at its maximum); `controller` holds
    /// the D the firmware applies away from fast stick moves.
    pub d_max_gains: Option<betaflight::Gains>,
    /// The gyro and D-term lowpass settings `--tune-filters` may change, as the firmware names them.
    pub filter_settings: Option<FilterSettings>,
    /// The firmware's limit on the rate target's acceleration, deg/s², for the 6-DOF check
    /// (ArduPilot's `ATC_ACCEL_*_MAX`); None: Betaflight-style stick moves.
    pub setpoint_accel_deg_s2: Option<f64>,
    /// The filter settings as a report lists them.
    pub lines: Vec<String>,
    /// What the analysis assumes.
    pub notes: Vec<String>,
}

impl FlownTune {
    /// The flown gains, None when the log has none for the axis.
    pub fn gains(&self) -> Option<&RateGains> {
        self.gains_flown.then_some(&self.controller)
    }

    /// The line a proposal adds so the firmware flies its D as analysed, with why: Betaflight
    /// with d_min active would fly d_min instead of the proposed D away from fast moves.
    pub fn constant_d_line(&self) -> Option<(String, &'static str)> {
        let RateGains::Betaflight { axis, .. } = &self.controller else {
            return None;
        };
        self.d_max_gains.map(|_| {
            (
                format!("set d_min_{} = 0", axis.name()),
                "the proposed D is meant constant (d_min would otherwise replace it away from fast moves)",
            )
        })
    }

    /// Betaflight with d_min active: the flown gains with D at its maximum, and that D.
    pub fn at_d_max(&self) -> Option<(RateGains, u32)> {
        let full = self.d_max_gains?;
        match &self.controller {
            RateGains::Betaflight { axis, filters, .. } => Some((
                RateGains::Betaflight {
                    gains: full,
                    axis: *axis,
                    filters: filters.clone(),
                },
                full.d,
            )),
            _ => None,
        }
    }
}

/// Reads the flown tune of `axis` from `log` for `firmware`; None for the generic firmware or a
/// log whose header carries no rate-controller tuning of `firmware`.
///
/// # Errors
/// An ArduPilot log without its rate gains: its plant is identified in deg/s and the gains act on
/// rad/s, so there is nothing to tune around (named, with what to use instead).
pub fn flown_tune(log: &Log, firmware: Firmware, axis: Axis) -> Result<Option<FlownTune>> {
    let header = FirmwareTuning::from_log(log);
    let tune = |controller, gains_flown, lines, notes| FlownTune {
        controller,
        gains_flown,
        d_max_gains: None,
        filter_settings: None,
        setpoint_accel_deg_s2: None,
        lines,
        notes,
    };
    Ok(match (&header, firmware) {
        (Some(FirmwareTuning::Betaflight(b)), Firmware::Betaflight) => {
            let h = betaflight::flown_from_header(b, axis, log);
            let (gains, d_max) = match h.gains {
                Some((g, d_applied)) => (
                    Some(betaflight::Gains { d: d_applied, ..g }),
                    (d_applied != g.d).then_some(g),
                ),
                None => (None, None),
            };
            let controller = RateGains::Betaflight {
                gains: gains.unwrap_or(betaflight::Gains {
                    p: 0,
                    i: 0,
                    d: 0,
                    f: 120,
                }),
                axis,
                filters: h.filters,
            };
            Some(FlownTune {
                d_max_gains: d_max,
                filter_settings: Some(h.filter_settings),
                ..tune(controller, gains.is_some(), h.lines, h.notes)
            })
        }
        (Some(FirmwareTuning::Inav(t)), Firmware::Inav) => {
            let h = inav::flown_from_header(t, axis);
            let controller = RateGains::Inav {
                gains: h.gains.unwrap_or(inav::Gains {
                    p: 0,
                    i: 0,
                    d: 0,
                    cd: 0,
                }),
                axis,
                filters: h.filters,
            };
            Some(FlownTune {
                filter_settings: Some(inav::filter_settings(t, log)),
                ..tune(controller, h.gains.is_some(), h.lines, h.notes)
            })
        }
        (Some(FirmwareTuning::Px4(p)), Firmware::Px4) => {
            let (filters, g, lines) = px4::flown_from_header(p, axis);
            let controller = RateGains::Px4 {
                gains: g.unwrap_or_default(),
                axis,
                filters,
            };
            Some(FlownTune {
                filter_settings: Some(px4::filter_settings(p)),
                ..tune(controller, g.is_some(), lines, Vec::new())
            })
        }
        (Some(FirmwareTuning::ArduPilot(t)), Firmware::Ardupilot) => {
            let (filters, g, lines) = ardupilot::flown_from_header(t, axis);
            let g = g.ok_or_else(|| {
                let n = ardupilot::param_names(axis);
                Error::Input(format!(
                    "{}: the log's parameters lack {}, {} or {}: the flown gains are needed to tune around (the plant is identified in deg/s, the gains act on rad/s); use a log with its PARM messages, or --firmware generic",
                    log.source, n[0], n[1], n[2]
                ))
            })?;
            let accel = ardupilot::setpoint_accel_deg_s2(t, axis);
            let notes = accel
                .map(|a| {
                    format!(
                        "6-DOF check: the rate target's acceleration is limited to {a:.0} deg/s² (ATC_ACCEL_{}_MAX), as the attitude controller shapes it",
                        ["R", "P", "Y"][axis.index()]
                    )
                })
                .into_iter()
                .collect();
            let controller = RateGains::Ardupilot {
                gains: g,
                axis,
                filters,
                plant_unit_rad_s: ardupilot::LOG_RATE_UNIT_RAD_S,
            };
            Some(FlownTune {
                setpoint_accel_deg_s2: accel,
                filter_settings: Some(ardupilot::filter_settings(t, axis)),
                ..tune(controller, true, lines, notes)
            })
        }
        _ => None,
    })
}
