//! LTI JSON, the interchange format with Python and MATLAB (row-major matrices, delays optional).

use crate::error::{LtiError, Result};
use crate::ss::{mat_to_rows, StateSpace};
use serde::{Deserialize, Serialize};

/// The on-disk form of a state-space model: `{"a":[[..]],"b":..,"c":..,"d":..,"dt":0.0,"input_delay":[..],"output_delay":[..]}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LtiJson {
    /// State matrix rows (`[]` for a static gain).
    pub a: Vec<Vec<f64>>,
    /// Input matrix rows (`[]` for a static gain).
    pub b: Vec<Vec<f64>>,
    /// Output matrix rows (`[]` for a static gain).
    pub c: Vec<Vec<f64>>,
    /// Feedthrough rows.
    pub d: Vec<Vec<f64>>,
    /// Sample period in seconds; 0 for continuous time.
    #[serde(default)]
    pub dt: f64,
    /// Input delays in seconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub input_delay: Option<Vec<f64>>,
    /// Output delays in seconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output_delay: Option<Vec<f64>>,
}

impl LtiJson {
    /// Converts to a validated state-space model.
    pub fn to_ss(&self) -> Result<StateSpace> {
        let sys = StateSpace::from_rows(&self.a, &self.b, &self.c, &self.d, self.dt)?;
        let (nu, ny) = (sys.nu(), sys.ny());
        sys.with_delays(
            self.input_delay.clone().unwrap_or_else(|| vec![0.0; nu]),
            self.output_delay.clone().unwrap_or_else(|| vec![0.0; ny]),
        )
    }

    /// The JSON form of a model (delays written only when present).
    pub fn from_ss(sys: &StateSpace) -> Self {
        LtiJson {
            a: mat_to_rows(&sys.a),
            b: mat_to_rows(&sys.b),
            c: mat_to_rows(&sys.c),
            d: mat_to_rows(&sys.d),
            dt: sys.dt,
            input_delay: sys
                .input_delay
                .iter()
                .any(|&t| t > 0.0)
                .then(|| sys.input_delay.clone()),
            output_delay: sys
                .output_delay
                .iter()
                .any(|&t| t > 0.0)
                .then(|| sys.output_delay.clone()),
        }
    }
}

/// Largest text file (LTI JSON, a TOML spec, a CSV of inputs) read, bytes: a 2000-state model is
/// about 100 MB of JSON.
pub const MAX_TEXT_BYTES: u64 = 256 << 20;

/// The text of a file a user names: a regular file of at most [`MAX_TEXT_BYTES`]. A device or a
/// pipe (`/dev/urandom`, a FIFO) would be read forever: it is refused by name, as is a larger file.
///
/// # Errors
/// The message (without the path) of a file that is not regular, too large, unreadable or not
/// UTF-8.
pub fn read_text_file(path: &std::path::Path) -> std::result::Result<String, String> {
    use std::io::Read;
    let meta = std::fs::metadata(path).map_err(|e| format!("cannot read the file: {e}"))?;
    require_regular_file(&meta)?;
    let mut text = String::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_TEXT_BYTES + 1).read_to_string(&mut text))
        .map_err(|e| format!("cannot read the file: {e}"))?;
    if text.len() as u64 > MAX_TEXT_BYTES {
        return Err(format!(
            "larger than {} MB, the most a text file may hold here",
            MAX_TEXT_BYTES >> 20
        ));
    }
    Ok(text)
}

/// Refuses what is not a regular file: a device or a pipe (`/dev/zero`, `/dev/urandom`, a FIFO)
/// may never end, and a directory holds no text. One rule for every file a user names (text
/// files here, flight logs in skyloop-sysid).
///
/// # Errors
/// The message (without the path) when `meta` is not a regular file's.
pub fn require_regular_file(meta: &std::fs::Metadata) -> std::result::Result<(), String> {
    if meta.is_file() {
        Ok(())
    } else {
        Err("not a regular file (a device, a pipe or a directory is not read)".into())
    }
}

/// Parses LTI JSON text into a validated model; errors name the bad field.
pub fn from_json_str(text: &str) -> Result<StateSpace> {
    let j: LtiJson = serde_json::from_str(text).map_err(|e| LtiError::InvalidArgument(format!("LTI JSON: {e}")))?;
    j.to_ss()
}

/// Serializes a model as LTI JSON text.
pub fn to_json_string(sys: &StateSpace) -> String {
    serde_json::to_string(&LtiJson::from_ss(sys)).expect("LTI JSON of finite numbers always serializes")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_delays() {
        let t = r#"{"a":[[-1.0]],"b":[[1.0]],"c":[[2.0]],"d":[[0.0]],"dt":0.0,"input_delay":[0.03]}"#;
        let s = from_json_str(t).unwrap();
        assert_eq!(s.input_delay, vec![0.03]);
        assert_eq!(from_json_str(&to_json_string(&s)).unwrap(), s);
    }

    #[test]
    fn wrong_shapes_are_errors() {
        let t = r#"{"a":[[-1.0, 0.0]],"b":[[1.0]],"c":[[2.0]],"d":[[0.0]]}"#;
        assert!(from_json_str(t).is_err());
        assert!(from_json_str("{").is_err());
    }
}
