//! How a firmware stores a gain: integers in its own units, or floats printed to six significant
//! digits, and the text of an optional header number.

use crate::error::{Error, Result};

/// The integer a firmware stores for continuous gain `k`, `scaled` being k in the firmware's units
/// (rounded here), checked against 0..=`max`; `label` names the parameter in the error
/// ("Betaflight p_roll", "INAV mc_p_roll").
///
/// # Errors
/// A rounded value outside 0..=`max` (negative, too large or NaN).
pub(crate) fn integer_gain(label: &str, k: f64, scaled: f64, max: u32) -> Result<u32> {
    let v = scaled.round();
    if !(v >= 0.0 && v <= max as f64) {
        return Err(Error::Input(format!(
            "{label} = {v} is outside 0..={max} (continuous gain {k:.6e}); the plant's units may not be PID sum per deg/s"
        )));
    }
    Ok(v as u32)
}

/// Six significant digits: PX4 and ArduPilot store floats, and D ~ 0.003 at four decimals would
/// move by 3 %.
pub(crate) fn round6(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let e = 10f64.powi(5 - x.abs().log10().floor() as i32);
    (x * e).round() / e
}

/// An optional header number as text ("-" when the log has none).
pub(crate) fn opt(x: Option<f64>) -> String {
    x.map_or("-".to_string(), |v| format!("{v}"))
}
