//! Why a controller could not be built.

/// A controller configuration that cannot run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControlError {
    /// A dimension exceeds the compile-time capacity (`what`, requested, capacity).
    TooLarge(&'static str, usize, usize),
    /// A coefficient is NaN or infinite (`what`).
    NonFinite(&'static str),
    /// Lower output limit above the upper one, or a negative integrator limit / time constant.
    InvalidLimits,
    /// Hanus conditioning needs an invertible feedthrough D.
    SingularFeedthrough,
    /// A value outside its allowed range (`what` names the value and the range).
    OutOfRange(&'static str),
}

impl core::fmt::Display for ControlError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ControlError::TooLarge(what, n, cap) => write!(f, "{what} = {n} exceeds the capacity {cap}"),
            ControlError::NonFinite(what) => write!(f, "{what} is not finite"),
            ControlError::InvalidLimits => write!(f, "invalid limits (min > max or negative limit/time constant)"),
            ControlError::OutOfRange(what) => write!(f, "out of range: {what}"),
            ControlError::SingularFeedthrough => {
                write!(f, "anti-windup conditioning needs a nonzero feedthrough D")
            }
        }
    }
}

impl core::error::Error for ControlError {}

/// Result of building a controller.
pub type Result<T> = core::result::Result<T, ControlError>;
