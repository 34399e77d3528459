//! The one error type of the application layer: each crate's own error is kept as its variant, so a
//! caller can match on the cause (a Riccati failure, a parse error at a column) rather than on text.

use thiserror::Error;

/// Why a skyloop workflow failed.
#[derive(Debug, Error)]
pub enum Error {
    /// Dense numerics (Schur, Riccati, Lyapunov, ...).
    #[error(transparent)]
    Linalg(#[from] skyloop_linalg::LinalgError),
    /// Models and classical analysis.
    #[error(transparent)]
    Lti(#[from] skyloop_lti::LtiError),
    /// Robust synthesis and analysis (H∞, loop shaping, μ): infeasible γ, unstabilizable modes, ...
    #[error(transparent)]
    Robust(#[from] skyloop_robust::RobustError),
    /// System identification and log reading.
    #[error(transparent)]
    Sysid(#[from] skyloop_sysid::SysidError),
    /// Nonlinear simulation.
    #[error(transparent)]
    Sim(#[from] skyloop_sim::SimError),
    /// Runtime controllers.
    #[error(transparent)]
    Control(#[from] skyloop_control::ControlError),
    /// Plots and reports.
    #[error(transparent)]
    Plot(#[from] skyloop_plot::PlotError),
    /// A spec file (TOML) that does not describe a valid design; the message names the key.
    #[error("{0}")]
    Spec(String),
    /// An input outside what the workflow accepts; the message names the input and the allowed range.
    #[error("{0}")]
    Input(String),
    /// A file that could not be read or written.
    #[error("cannot {action} {path}: {message}")]
    Io {
        /// "read", "write" or "create".
        action: &'static str,
        /// The file or directory.
        path: String,
        /// What the operating system said.
        message: String,
    },
    /// A workflow step that failed for a reason of its own (a reproduction without the expected structure, ...).
    #[error("{0}")]
    Failed(String),
}

impl From<String> for Error {
    fn from(s: String) -> Self {
        Error::Failed(s)
    }
}

impl From<&str> for Error {
    fn from(s: &str) -> Self {
        Error::Failed(s.to_string())
    }
}

impl From<serde_json::Error> for Error {
    fn from(e: serde_json::Error) -> Self {
        Error::Failed(format!("cannot encode JSON: {e}"))
    }
}

impl Error {
    /// A file that could not be read.
    pub fn read(path: &std::path::Path, e: impl std::fmt::Display) -> Self {
        Self::io("read", path, e)
    }

    /// A file that could not be written.
    pub fn write(path: &std::path::Path, e: impl std::fmt::Display) -> Self {
        Self::io("write", path, e)
    }

    /// A directory that could not be created.
    pub fn create(path: &std::path::Path, e: impl std::fmt::Display) -> Self {
        Self::io("create", path, e)
    }

    fn io(action: &'static str, path: &std::path::Path, e: impl std::fmt::Display) -> Self {
        Error::Io {
            action,
            path: path.display().to_string(),
            message: e.to_string(),
        }
    }
}

/// Result alias of the application layer.
pub type Result<T> = std::result::Result<T, Error>;
