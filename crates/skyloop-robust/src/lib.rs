//! skyloop-robust.
pub mod mu;
pub mod uncertainty;
