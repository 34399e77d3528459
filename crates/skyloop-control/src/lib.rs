//! Runtime controllers for flight computers: no allocation, no std.
#![cfg_attr(not(feature = "std"), no_std)]
