//! Models named on a command line or in a spec: a path to an LTI JSON file, or a transfer-function
//! expression.

use crate::error::{Error, Result};
use skyloop_lti::StateSpace;
use std::path::Path;

/// Loads MODEL: an LTI JSON file when `arg` names an existing file, else a transfer-function
/// expression such as `"0.0887*exp(-0.032*s)/(0.0256*s+1)"`.
///
/// # Errors
/// An unreadable file, invalid LTI JSON, a `.json` name that does not exist, or an expression that
/// does not parse ([`Error::Lti`] with the column).
///
/// # Examples
/// ```
/// let g = skyloop::model::load_model("1/(s+1)")?;
/// assert_eq!((g.nx(), g.nu(), g.ny()), (1, 1, 1));
/// assert!(skyloop::model::load_model("missing.json").is_err());
/// # Ok::<(), skyloop::Error>(())
/// ```
pub fn load_model(arg: &str) -> Result<StateSpace> {
    let path = Path::new(arg);
    if path.is_file() {
        let text = std::fs::read_to_string(path).map_err(|e| Error::read(path, e))?;
        return skyloop_lti::json::from_json_str(&text).map_err(|e| Error::Input(format!("{arg}: {e}")));
    }
    if arg.ends_with(".json") {
        return Err(Error::Input(format!("no such file: {arg}")));
    }
    skyloop_lti::expr::parse_model(arg)
        .map_err(|e| Error::Input(format!("'{arg}' is not a file; as an expression: {e}")))
}

/// Loads a model named relative to `base` (a spec file's directory) when such a file exists, else
/// as [`load_model`] does.
pub fn load_model_in(base: &Path, name: &str) -> Result<StateSpace> {
    let rel = base.join(name);
    if rel.is_file() {
        load_model(&rel.to_string_lossy())
    } else {
        load_model(name)
    }
}
