//! skyloop-robust.
pub mod mu;
pub mod musyn;
pub mod uncertainty;
