//! μ-synthesis by DK-iteration. So far: the D-step's rational fit of D-scale data (the K-step
//! needs `hinfsyn`, not yet available).

pub mod dfit;

pub use dfit::{fit_magnitude, DFit};
