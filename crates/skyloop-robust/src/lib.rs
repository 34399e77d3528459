//! skyloop-robust.
pub mod hinfsyn;
mod linutil;
pub mod mixsyn;
pub mod mu;
pub mod musyn;
pub mod ncfsyn;
pub mod uncertainty;
