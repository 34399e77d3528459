//! The one error type of skyloop-robust. In the spirit of SLICOT's INFO codes, the failures a
//! synthesis can report by design (no controller at γ, an unstabilizable mode, a rank-deficient
//! D12/D21, a Riccati equation without a stabilizing solution) are named variants carrying the
//! offending quantity, so callers can match on the cause instead of on message text.

use faer::c64;
use skyloop_linalg::LinalgError;
use skyloop_lti::LtiError;
use thiserror::Error;

/// Why a robust-control computation (H∞, loop shaping, μ, DK-iteration, uncertainty) failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RobustError {
    /// No controller achieves the performance level `gamma` (the upper end of the γ range, or the
    /// largest γ the iteration tried); `reason` is the last failed test (Riccati, coupling, closed loop).
    #[error("no controller achieves gamma <= {gamma:.6e}: {reason}")]
    Infeasible {
        /// The γ level that could not be achieved.
        gamma: f64,
        /// What failed at that level.
        reason: String,
    },
    /// A mode with Re λ ≥ 0 that no input reaches (PBH test), so no controller can stabilize it.
    #[error(
        "{system} is not stabilizable: the mode at {:.6}{:+.6}i cannot be moved by its inputs",
        .mode.re,
        .mode.im
    )]
    NotStabilizable {
        /// The pair that fails the test, e.g. "(A, B2)" or "the shaped plant (A, B)".
        system: &'static str,
        /// The uncontrollable eigenvalue of A.
        mode: c64,
    },
    /// A mode with Re λ ≥ 0 that no output sees (PBH test), so no observer can estimate it.
    #[error(
        "{system} is not detectable: the mode at {:.6}{:+.6}i is not seen by its outputs",
        .mode.re,
        .mode.im
    )]
    NotDetectable {
        /// The pair that fails the test, e.g. "(C2, A)" or "the shaped plant (C, A)".
        system: &'static str,
        /// The unobservable eigenvalue of A.
        mode: c64,
    },
    /// D12 without full column rank or D21 without full row rank (a singular H∞ problem).
    #[error(
        "{matrix} is rank deficient (smallest singular value {sigma_min:.3e}): {}",
        rank_hint(.matrix)
    )]
    RankDeficient {
        /// "D12" or "D21".
        matrix: &'static str,
        /// Its smallest singular value.
        sigma_min: f64,
    },
    /// A Riccati equation (CARE/DARE) without a stabilizing solution; `equation` names which one.
    #[error("numerical failure: {equation}: {source}")]
    Riccati {
        /// Which equation failed, e.g. "control Riccati equation of the shaped plant".
        equation: &'static str,
        /// The failure reported by skyloop-linalg.
        source: LinalgError,
    },
    /// Matrix, system or block dimensions that do not fit together.
    #[error("dimension mismatch: {0}")]
    Dimension(String),
    /// An argument outside what the operation accepts (γ range, tolerance, weights, ...).
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// The operation requires a property the model lacks (rational, continuous time, states, ...).
    #[error("{0}")]
    Unsupported(String),
    /// A numerical method failed for a reason without a named variant (no convergence, singular matrix).
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// An error of an LTI operation (interconnection, norm, discretization, ...).
    #[error(transparent)]
    Lti(#[from] LtiError),
}

/// What the user can do about a rank-deficient D12 or D21.
fn rank_hint(matrix: &str) -> &'static str {
    if matrix == "D21" {
        "every measurement needs its own noise input (add a sensor-noise weight)"
    } else {
        "every control must act on a performance output directly (add a control weight)"
    }
}

/// A linalg failure met directly (not through an LTI operation) keeps its cause inside [`LtiError`].
impl From<LinalgError> for RobustError {
    fn from(e: LinalgError) -> Self {
        RobustError::Lti(LtiError::from(e))
    }
}

/// Result alias used across skyloop-robust.
pub type Result<T> = std::result::Result<T, RobustError>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_names_the_quantities() {
        let e = RobustError::Infeasible {
            gamma: 0.5,
            reason: "coupling condition fails".into(),
        };
        assert_eq!(
            e.to_string(),
            "no controller achieves gamma <= 5.000000e-1: coupling condition fails"
        );
        let e = RobustError::NotStabilizable {
            system: "(A, B2)",
            mode: c64::new(2.0, -1.0),
        };
        assert_eq!(
            e.to_string(),
            "(A, B2) is not stabilizable: the mode at 2.000000-1.000000i cannot be moved by its inputs"
        );
        let e = RobustError::NotDetectable {
            system: "(C2, A)",
            mode: c64::new(0.0, 3.0),
        };
        assert!(
            e.to_string().contains("not detectable: the mode at 0.000000+3.000000i"),
            "{e}"
        );
        let e = RobustError::RankDeficient {
            matrix: "D21",
            sigma_min: 1e-12,
        };
        assert!(
            e.to_string()
                .starts_with("D21 is rank deficient (smallest singular value 1.000e-12)"),
            "{e}"
        );
        assert!(e.to_string().contains("sensor-noise"), "{e}");
    }

    #[test]
    fn linalg_causes_survive_through_lti() {
        let e = RobustError::from(LinalgError::NoSolution("care: no stabilizing solution".into()));
        assert!(
            matches!(&e, RobustError::Lti(LtiError::Linalg(LinalgError::NoSolution(_)))),
            "{e:?}"
        );
        assert_eq!(
            e.to_string(),
            "numerical failure: no solution: care: no stabilizing solution"
        );
        // Dimension and argument errors keep their LTI meaning.
        let e = RobustError::from(LinalgError::Dimension("A is 2x3".into()));
        assert!(matches!(e, RobustError::Lti(LtiError::Dimension(_))), "{e:?}");
    }
}
