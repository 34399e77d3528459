//! skyloop-sim.
