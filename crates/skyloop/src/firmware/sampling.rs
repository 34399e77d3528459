//! The loop's sample and hold as a delay, and the discrete controller the firmware runs.

use crate::error::{Error, Result};
use skyloop_lti::discretize::{c2d, Method};
use skyloop_lti::StateSpace;

/// The loop rate's sample and hold as a delay: half a period (the zero-order hold's average lag).
///
/// # Errors
/// A loop rate that is not a finite positive number.
pub fn hold_delay_s(loop_hz: f64) -> Result<f64> {
    if !(loop_hz.is_finite() && loop_hz > 0.0) {
        return Err(Error::Input(format!(
            "the loop rate must be a positive number of Hz, got {loop_hz}"
        )));
    }
    Ok(0.5 / loop_hz)
}

/// C_fb at the loop rate (Tustin), the discrete form the firmware runs to first order.
///
/// # Errors
/// As [`hold_delay_s`], or a discretization failure.
pub fn discrete(c_fb: &StateSpace, loop_hz: f64) -> Result<StateSpace> {
    hold_delay_s(loop_hz)?;
    Ok(c2d(c_fb, 1.0 / loop_hz, Method::Tustin { prewarp_rad_s: None })?)
}
