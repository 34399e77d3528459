//! skyloop-robust.
pub mod error;
pub mod hinfsyn;
mod matrix_ops;
pub mod mixsyn;
pub mod mu;
pub mod musyn;
pub mod ncfsyn;
pub mod structured;
pub mod uncertainty;

pub use error::{Result, RobustError};
