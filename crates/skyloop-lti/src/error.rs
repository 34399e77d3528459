//! The one error type of skyloop-lti: every failure names what went wrong.

use thiserror::Error;

/// Why an LTI operation failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LtiError {
    /// Matrix or signal dimensions that do not fit together.
    #[error("dimension mismatch: {0}")]
    Dimension(String),
    /// An argument outside what the operation accepts (negative sample time, unknown method, ...).
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// A transfer-function expression that does not parse; `column` counts from 1.
    #[error("parse error at column {column}: {message}")]
    Parse {
        /// 1-based column of the offending character.
        column: usize,
        /// What was found and what was expected.
        message: String,
    },
    /// The operation requires a property the model lacks (stability, properness, ...).
    #[error("{0}")]
    Unsupported(String),
    /// A numerical method failed (no convergence, singular matrix, no stabilizing solution).
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// A file could not be read or written.
    #[error("{0}")]
    Io(String),
    /// A dense matrix computation of skyloop-linalg failed (no convergence, singular matrix, no
    /// stabilizing solution); the linalg cause is kept so callers can match on it.
    #[error("numerical failure: {0}")]
    Linalg(#[source] skyloop_linalg::LinalgError),
}

/// Dimension and argument errors keep their LTI meaning; every other linalg failure becomes
/// [`LtiError::Linalg`] with the linalg error intact.
impl From<skyloop_linalg::LinalgError> for LtiError {
    fn from(e: skyloop_linalg::LinalgError) -> Self {
        match e {
            skyloop_linalg::LinalgError::Dimension(m) => LtiError::Dimension(m),
            skyloop_linalg::LinalgError::InvalidArgument(m) => LtiError::InvalidArgument(m),
            other => LtiError::Linalg(other),
        }
    }
}

/// Result alias used across skyloop-lti.
pub type Result<T> = std::result::Result<T, LtiError>;
