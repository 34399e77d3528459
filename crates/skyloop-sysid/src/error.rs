//! The one error type of skyloop-sysid: every failure names what went wrong.

use thiserror::Error;

/// Why an identification step failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SysidError {
    /// An argument outside what the operation accepts (negative rate, empty range, unknown name, ...).
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// A log file that cannot be read: unknown format, truncated or corrupt; the text says where.
    #[error("{0}")]
    Log(String),
    /// A requested column/field is not in the log; lists what is available nearby.
    #[error("no field '{name}' in {source_name}{hint}")]
    MissingField {
        /// The name that was asked for.
        name: String,
        /// The file (or log session) searched.
        source_name: String,
        /// Suggestions such as ", similar: gyroADC\[0\], gyroADC\[1\]" (may be empty).
        hint: String,
    },
    /// Too little data for the requested estimate.
    #[error("not enough data: {0}")]
    NotEnoughData(String),
    /// A numerical method failed (singular normal equations, no convergence, non-finite values).
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// A file could not be read or written.
    #[error("{0}")]
    Io(String),
}

/// Result with [`SysidError`].
pub type Result<T> = std::result::Result<T, SysidError>;

pub(crate) fn invalid(msg: impl Into<String>) -> SysidError {
    SysidError::InvalidArgument(msg.into())
}

impl From<skyloop_linalg::LinalgError> for SysidError {
    fn from(e: skyloop_linalg::LinalgError) -> SysidError {
        use skyloop_linalg::LinalgError as L;
        match e {
            L::InvalidArgument(m) => SysidError::InvalidArgument(m),
            L::Dimension(m) => SysidError::NotEnoughData(m),
            other => SysidError::Numerical(other.to_string()),
        }
    }
}
