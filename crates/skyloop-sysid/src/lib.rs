//! skyloop-sysid.
