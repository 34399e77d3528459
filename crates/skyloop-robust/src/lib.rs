//! skyloop-robust.
