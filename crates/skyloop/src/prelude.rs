//! The headline API in one import: `use skyloop::prelude::*;`.
//!
//! Models and analysis come from `skyloop-lti`, synthesis and μ from `skyloop-robust`,
//! identification from `skyloop-sysid`, simulation from `skyloop-sim`; the workflows (design
//! pipeline, identification of a log, reproductions) from this crate.

pub use crate::error::{Error, Result};

// Models: state space, expressions with exact delays, interconnection.
pub use skyloop_lti::expr::{parse as parse_expr, parse_model};
pub use skyloop_lti::interconnect::{feedback, lft_lower, lft_upper, parallel, series};
pub use skyloop_lti::{c64, LtiError, Mat, StateSpace};

// Classical analysis: frequency response, margins, norms, poles, time responses.
pub use skyloop_lti::discretize::{c2d, d2c, Method as C2dMethod};
pub use skyloop_lti::freqresp::{bode, evalfr, freqresp, logspace};
pub use skyloop_lti::margins::{allmargin, delay_margin, diskmargin, margin, AllMargins, DiskMargin, Margins};
pub use skyloop_lti::norms::{h2_norm, hinf_norm};
pub use skyloop_lti::poles_zeros::{dcgain, poles, zeros};
pub use skyloop_lti::reduce::{balred, hsvd, Method as ReduceMethod};
pub use skyloop_lti::timeresp::{impulse, lsim, step};

// Synthesis, uncertainty and μ.
pub use skyloop_robust::hinfsyn::{hinfsyn, hinfsyn_with, HinfOptions, HinfSolution};
pub use skyloop_robust::mixsyn::{augw, mixsyn};
pub use skyloop_robust::mu::{mu, mu_frequency, robust_performance, robust_stability, MuBounds, MuOptions, MuSweep};
pub use skyloop_robust::musyn::{musyn, MusynOptions, MusynSolution};
pub use skyloop_robust::ncfsyn::{ncfmargin, ncfsyn, NcfOptions};
pub use skyloop_robust::uncertainty::{
    input_multiplicative, makeweight, output_multiplicative, BlockKind, BlockStructure, UComplex, ULtiDyn, UReal,
    UncertainSystem,
};

// Identification.
pub use skyloop_sysid::fit::{fit_expr, fit_tf, FitOptions, FitResult};
pub use skyloop_sysid::logs::Log;
pub use skyloop_sysid::spectral::{estimate, Frf, IoData, Method as FrfMethod, Options as FrfOptions};

// Simulation and Monte Carlo.
pub use skyloop_sim::montecarlo::run as monte_carlo;
pub use skyloop_sim::{simulate, Metrics, Scenario};

// Workflows.
pub use crate::design::{design, DesignResult};
pub use crate::identify::{identify, Identification, IdentifyRequest};
pub use crate::papers::{reproduce, Claim, Reproduction};
pub use crate::spec::design::DesignSpec;
