//! LTI models, transfer-function expressions with delays, interconnection and classical analysis.
//!
//! Continuous time unless `dt > 0`; frequencies are rad/s unless a name says `_hz`.

pub mod error;
pub mod freqresp;
pub mod json;
pub mod margins;
pub mod norms;
pub mod ss;

pub use error::LtiError;
pub use faer::{c64, Mat, MatRef};
pub use ss::StateSpace;
pub mod convert;
pub mod discretize;
pub mod display;
pub mod expr;
pub mod feedthrough;
pub mod gramian;
pub mod interconnect;
pub mod minreal;
pub mod pade;
pub mod poles_zeros;
pub mod poly;
pub mod reduce;
pub mod sos;
pub mod stabsep;
pub mod tf;
pub mod timeresp;
pub mod zpk;
