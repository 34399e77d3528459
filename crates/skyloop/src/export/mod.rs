//! What leaves skyloop for the flight controller: C code for a discrete controller.

pub mod c_header;
