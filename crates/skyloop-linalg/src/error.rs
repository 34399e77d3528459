//! The one error type of skyloop-linalg: every failure names what went wrong.

use thiserror::Error;

/// Why a dense matrix computation failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LinalgError {
    /// Matrix dimensions that do not fit together (non-square A, mismatched B, ...).
    #[error("dimension mismatch: {0}")]
    Dimension(String),
    /// An input holding NaN or infinite entries, or otherwise outside what the method accepts.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// An iterative method (QR sweeps, Newton, doubling) did not converge.
    #[error("no convergence: {0}")]
    NoConvergence(String),
    /// A matrix that must be inverted is singular to working precision.
    #[error("singular matrix: {0}")]
    Singular(String),
    /// A matrix equation has no unique or no stabilizing solution (eigenvalues on the axis/circle,
    /// common eigenvalues in a Sylvester equation, unstable A in a Lyapunov equation that needs a stable one).
    #[error("no solution: {0}")]
    NoSolution(String),
}

/// Result alias used across skyloop-linalg.
pub type Result<T> = std::result::Result<T, LinalgError>;
