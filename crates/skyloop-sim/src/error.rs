//! Errors of simulation setup and linearization.

/// What went wrong building or running a simulation.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A scenario or parameter value is invalid (message names it).
    #[error("invalid parameter: {0}")]
    Param(String),
    /// The scenario file is not valid TOML or has unknown fields.
    #[error("scenario: {0}")]
    Scenario(String),
    /// A controller could not be built.
    #[error("controller: {0}")]
    Control(String),
    /// An LTI operation failed.
    #[error(transparent)]
    Lti(#[from] skyloop_lti::LtiError),
}

impl From<skyloop_control::ControlError> for SimError {
    fn from(e: skyloop_control::ControlError) -> Self {
        SimError::Control(e.to_string())
    }
}

/// Result of a simulation operation.
pub type Result<T> = std::result::Result<T, SimError>;

/// Fails with a message naming `what` unless `v` is finite and `v >= lo`.
pub(crate) fn check_min(v: f64, lo: f64, what: &str) -> Result<()> {
    if v.is_finite() && v >= lo {
        Ok(())
    } else {
        Err(SimError::Param(format!("{what} = {v} (must be finite and >= {lo})")))
    }
}

/// Fails with a message naming `what` unless `lo <= v <= hi`.
pub(crate) fn check_range(v: f64, lo: f64, hi: f64, what: &str) -> Result<()> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(SimError::Param(format!("{what} = {v} (must be in {lo}..={hi})")))
    }
}

/// Fails with a message naming `what` unless `v` is finite and `v > 0`.
pub(crate) fn check_pos(v: f64, what: &str) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(SimError::Param(format!("{what} = {v} (must be finite and > 0)")))
    }
}
