//! Fixed-structure H∞ tuning (the systune/hinfstruct class): tunable blocks inside fixed ones
//! ([`blocks`]), goals as hard constraints or soft objectives ([`goals`]), minimized by nonsmooth
//! BFGS ([`nonsmooth`]) from a stabilization phase and parallel random restarts ([`systune`] for
//! SISO loops, [`hinfstruct`] for a generalized plant), every result re-verified with the exact
//! plants by skyloop-lti's analysis routines ([`verify`]).
pub mod blocks;
pub mod closed_loop;
pub mod goals;
pub mod hinfstruct;
pub mod nonsmooth;
pub mod systune;
pub mod verify;
