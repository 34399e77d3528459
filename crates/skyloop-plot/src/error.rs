//! Why a plot could not be written.

use thiserror::Error;

/// Why a plot could not be drawn or saved.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PlotError {
    /// The output path does not end in `.svg` or `.png`.
    #[error("unsupported plot format for '{0}': use a .svg or .png file name")]
    Format(String),
    /// The data cannot be drawn (no finite points, mismatched lengths, ...).
    #[error("cannot plot: {0}")]
    Data(String),
    /// The drawing backend failed (file not writable, font missing, ...).
    #[error("cannot draw '{path}': {message}")]
    Draw {
        /// The output file.
        path: String,
        /// What the backend reported.
        message: String,
    },
}

/// Result alias used across skyloop-plot.
pub type Result<T> = std::result::Result<T, PlotError>;
