//! skyloop-plot.
