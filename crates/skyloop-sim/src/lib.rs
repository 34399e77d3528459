//! skyloop-sim.
pub mod cascade;
pub mod delayed_loop;
pub mod disturbance;
pub mod error;
pub mod geometry;
pub mod linear_models;
pub mod linearize;
pub mod lti_loop;
pub mod montecarlo;
pub mod presets;
pub mod rigid;
pub mod runtime_controller;
pub mod scenario;
pub mod sensors;
pub mod sim;
pub mod vehicle;

pub use error::{Result, SimError};
pub use linearize::{linearize, Linearization};
pub use scenario::Scenario;
pub use sim::{simulate, simulate_with_progress, Metrics, Sample, Simulation};
pub use vehicle::{Vehicle, VehicleSpec};
