//! Runtime controllers for flight computers: no allocation, no std (`core` and `libm` only), so the
//! same code builds for microcontrollers, WebAssembly and the host.
#![no_std]

pub mod error;
pub mod filter;
pub mod pid;
pub mod real;
pub mod sos;
pub mod ss;
pub mod ssi;

pub use error::{ControlError, Result};
pub use filter::{Filter, FilterKind};
pub use pid::{AntiWindup, Pid, PidGains};
pub use real::Real;
pub use sos::{Biquad, SosController};
pub use ss::SsController;
pub use ssi::{SsiPi, SsiPiGains};
