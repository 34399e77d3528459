//! Every TOML spec a user writes, each rejecting unknown keys and naming the key in its errors:
//!
//! - [`design`]: the design pipeline (plant, synthesis, boost, reduction, discretization);
//! - [`musyn`]: μ-synthesis by DK-iteration (generalized plant, block structure, options);
//! - [`scenario`]: a nonlinear 6-DOF simulation (vehicle, controller, disturbances, Monte Carlo).
//!   It is defined in `skyloop-sim`, whose Monte Carlo runner consumes it, and re-exported here.

pub mod design;
pub mod musyn;

/// The simulation scenario spec (TOML), defined beside the simulator that runs it.
pub mod scenario {
    pub use skyloop_sim::montecarlo::MonteCarloSpec;
    pub use skyloop_sim::scenario::*;
}
