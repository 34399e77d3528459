//! skyloop-linalg.
