//! What to fly so an axis can be identified: the stick sequence any firmware accepts, and the
//! firmware's own excitation mode where it has one, with the settings to give it.
//!
//! The estimator uses the setpoint as its instrument (it is not driven by the loop's noise), so
//! every advice here puts power into the setpoint (stick moves, Betaflight's CHIRP mode, which adds
//! the sweep to the setpoint) or into a signal the firmware logs beside it (ArduPilot's SystemID
//! rate axes, PX4's autotune).

use super::{Axis, Firmware};

/// The stick sequence that identifies `axis` on any firmware: sharp, short, both directions, in the
/// linear range (no flips, throttle off idle and off full), about 2–5 reversals a second, which
/// puts setpoint power from about 1 Hz to the stick's own bandwidth.
pub fn stick_sequence(axis: Axis) -> String {
    let stick = match axis {
        Axis::Roll => "roll (aileron)",
        Axis::Pitch => "pitch (elevator)",
        Axis::Yaw => "yaw (rudder)",
    };
    format!(
        "in acro (rate) mode at hover throttle, 10–20 s of sharp {stick} stick snaps: half to full deflection and back to centre, \
         2–5 a second, both directions, no flips or rolls, throttle kept off idle and off full"
    )
}

/// The firmware's own excitation mode for `axis`, with its settings (None: the firmware has none
/// skyloop knows of, INAV and generic).
pub fn excitation_mode(firmware: Firmware, axis: Axis) -> Option<String> {
    let i = match axis {
        Axis::Roll => 0,
        Axis::Pitch => 1,
        Axis::Yaw => 2,
    };
    match firmware {
        // Betaflight 2025.12 `pid.c`: CHIRP mode adds a sine sweep to the setpoint of one axis per
        // activation (roll, then pitch, then yaw), defaults 0.2–600 Hz over 20 s; the amplitude is
        // in deg/s (`chirp_amplitude_<axis>`, 230 roll/pitch, 180 yaw by default).
        Firmware::Betaflight => Some(format!(
            "Betaflight 2025.12 or later (built with CHIRP): assign the CHIRP mode to a switch; each activation sweeps one axis (roll, then pitch, then yaw: flip it {n} time{s} to reach {a}); \
             `set chirp_amplitude_{a} = {amp}`, `set chirp_frequency_start_deci_hz = 10`, `set chirp_frequency_end_deci_hz = 1000`, `set chirp_time_seconds = 20`; hover, switch it on for the 20 s",
            n = i + 1,
            s = if i == 0 { "" } else { "s" },
            a = axis.name(),
            amp = if axis == Axis::Yaw { 100 } else { 150 },
        )),
        // ArduCopter SystemID mode (flight mode 25): SID_AXIS 7/8/9 inject into the rate
        // controller's target of roll/pitch/yaw, the magnitude in deg/s.
        Firmware::Ardupilot => Some(format!(
            "ArduCopter's SystemID flight mode (mode 25): `SID_AXIS = {}` (rate {}), `SID_MAGNITUDE = {}`, `SID_F_START_HZ = 0.5`, `SID_F_STOP_HZ = 40`, `SID_T_REC = 30`, `SID_T_FADE_IN = 5`, `SID_T_FADE_OUT = 2`; enter it from a stable hover in AltHold or Loiter",
            7 + i,
            axis.name(),
            if axis == Axis::Yaw { 10 } else { 15 },
        )),
        // PX4 `mc_autotune_attitude_control`: injects its own excitation on each axis in turn and
        // logs it beside the setpoint; MC_AT_APPLY = 0 keeps the flown gains.
        Firmware::Px4 => Some(
            "PX4's multicopter autotune as an identification flight: `param set MC_AT_EN 1`, `param set MC_AT_APPLY 0` (keep your gains), start it from QGroundControl's Autotune button in a hover (Position or Altitude mode), with high-rate logging (`SDLOG_PROFILE` with its high-rate bit)"
                .to_string(),
        ),
        Firmware::Inav | Firmware::Generic => None,
    }
}

/// The whole advice for an axis the log could not identify: the firmware's excitation mode where it
/// has one, otherwise (and always as the alternative) the stick sequence.
///
/// ```
/// use skyloop::firmware::{excitation::what_to_fly, Axis};
/// use skyloop::tune::Firmware;
/// let s = what_to_fly(Firmware::Betaflight, Axis::Yaw);
/// assert!(s.contains("chirp_amplitude_yaw") && s.contains("yaw (rudder) stick snaps"));
/// ```
pub fn what_to_fly(firmware: Firmware, axis: Axis) -> String {
    let sticks = stick_sequence(axis);
    match excitation_mode(firmware, axis) {
        Some(mode) => format!("fly {sticks}; or use {mode}"),
        None => format!("fly {sticks}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_firmware_and_axis_gets_advice_naming_the_axis() {
        for fw in [
            Firmware::Betaflight,
            Firmware::Inav,
            Firmware::Px4,
            Firmware::Ardupilot,
            Firmware::Generic,
        ] {
            for axis in Axis::ALL {
                let s = what_to_fly(fw, axis);
                assert!(s.contains(axis.name()), "{fw:?} {axis:?}: {s}");
            }
        }
        assert!(what_to_fly(Firmware::Ardupilot, Axis::Pitch).contains("SID_AXIS = 8"));
        assert!(what_to_fly(Firmware::Betaflight, Axis::Pitch).contains("2 times to reach pitch"));
        assert!(excitation_mode(Firmware::Inav, Axis::Roll).is_none());
    }
}
