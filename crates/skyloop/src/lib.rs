//! # skyloop: robust flight-control design, from a flight log to gains the firmware loads
//!
//! This crate is where a user starts. It re-exports the numerical crates ([`lti`], [`robust`],
//! [`sysid`], [`sim`], [`control`], [`plot`], [`linalg`]), gathers their headline functions in
//! [`prelude`], and holds the workflows built on them: the design pipeline ([`design`]), the TOML
//! specs ([`spec`]), identification from a log ([`identify`]), code export ([`export`]) and the
//! paper reproductions ([`papers`]).
//!
//! ## A tour
//!
//! A model is a transfer-function expression (delays exact) or a state-space model:
//!
//! ```
//! use skyloop::prelude::*;
//!
//! // The bicopter paper's roll-rate plant, eq. (8): a first-order servo with a 32 ms delay, the
//! // non-minimum-phase roll dynamics and the gyro filter.
//! let p = parse_model(
//!     "0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2-s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5)",
//! )?;
//! assert_eq!(p.nx(), 4);
//! assert!((p.input_delay[0] - 0.032).abs() < 1e-15);
//! # Ok::<(), skyloop::Error>(())
//! ```
//!
//! Classical analysis is exact with the delay: here the paper's controller of eq. (12) closes the
//! loop L = P·C with a 65.8° phase margin at 1.47 Hz and a 7.25 dB gain margin.
//!
//! ```
//! use skyloop::prelude::*;
//!
//! let p = parse_model(
//!     "0.0887*exp(-0.032*s)/(0.0256*s+1) * (42^2-s^2)/s * 2.221e5/(s^2+666.4*s+2.221e5)",
//! )?;
//! let c = parse_model(
//!     "24.02*(s+54.01)*(s+0.2474)*(s^2+139.3*s+2.624e4) / (s*(s^2+24.14*s+8544)*(s^2+232.4*s+7.041e4))",
//! )?;
//! let m = margin(&series(&c, &p)?)?;
//! assert!((m.pm_deg - 65.8).abs() < 0.2);
//! assert!((m.pm_w_rad_s / (2.0 * std::f64::consts::PI) - 1.47).abs() < 0.01);
//! assert!((m.gm_db - 7.25).abs() < 0.05);
//! assert!(m.stable);
//! # Ok::<(), skyloop::Error>(())
//! ```
//!
//! Synthesis: Glover–McFarlane loop shaping ([`prelude::ncfsyn`]), H∞ ([`prelude::hinfsyn`]),
//! mixed sensitivity ([`prelude::mixsyn`]), μ bounds ([`prelude::mu`]) and DK-iteration
//! ([`prelude::musyn`]). The whole design of a spec file, with γ and margins after every step, is
//! one call to [`design::design`]; each paper is one call to [`papers::reproduce`]:
//!
//! ```no_run
//! let r = skyloop::papers::reproduce("bicopter", std::path::Path::new("out"), false)?;
//! for line in r.lines() {
//!     println!("{line}");
//! }
//! println!("{} of {} claims reproduced", r.reproduced_count(), r.claims.len());
//! # Ok::<(), skyloop::Error>(())
//! ```
//!
//! ## Where things are
//!
//! | you want | look in |
//! |---|---|
//! | models, expressions, margins, norms, c2d, reduction | [`lti`], re-exported in [`prelude`] |
//! | ncfsyn, hinfsyn, mixsyn, μ, musyn, uncertainty | [`robust`] |
//! | FRF estimates, fits, flight logs | [`sysid`], and the workflow [`identify`] |
//! | 6-DOF simulation, Monte Carlo | [`sim`] |
//! | the design pipeline of a TOML spec, its report | [`design`], [`spec`] |
//! | a C header for a discrete controller | [`export`] |
//! | the bicopter, SSI-PI and ducted-fan reproductions | [`papers`] |
//!
//! Conventions: continuous time unless `dt > 0`; rad/s inside, and every field a user reads names
//! its unit (`_hz`, `_deg`, `_db`); a controller C closes the loop as u = C·(r − y), so L = P·C;
//! `hinfsyn` follows MATLAB's LFT convention u = K·y with the last outputs and inputs of P as y and u.

pub mod compare;
pub mod design;
pub mod error;
pub mod export;
pub mod figures;
pub mod firmware;
pub mod flightlog;
pub mod identify;
pub mod json_out;
pub mod loops;
pub mod model;
pub mod noise;
pub mod papers;
pub mod prelude;
pub mod response;
pub mod simulation;
pub mod spec;
pub mod synthesis;
pub mod timeverbs;
pub mod tune;

pub use error::{Error, Result};

pub use skyloop_control as control;
pub use skyloop_linalg as linalg;
pub use skyloop_lti as lti;
pub use skyloop_plot as plot;
pub use skyloop_robust as robust;
pub use skyloop_sim as sim;
pub use skyloop_sysid as sysid;
