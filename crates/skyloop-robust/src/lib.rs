//! skyloop-robust.
pub mod hinfsyn;
mod linutil;
pub mod mixsyn;
pub mod mu;
pub mod ncfsyn;
pub mod musyn;
pub mod uncertainty;
