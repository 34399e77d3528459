//! Dense numerics on faer: balancing, real Schur form and reordering, Sylvester, Lyapunov
//! (also in Cholesky-factor form), CARE and DARE, eigenvalues of Hamiltonian matrices, matrix
//! exponential, eigenvalues of real matrix pencils (QZ), bounded Levenberg–Marquardt, the top
//! eigenpairs of small Hermitian matrices, and
//! scalar root finding and maximization.
//!
//! Ported from the published algorithms (LAPACK dgebal/dlahqr/dlaqr0–5/dtrexc/dlaexc/dlasy2/dtrsyl,
//! Hammarling, Laub's ordered-Schur Riccati method, Van Loan's square-reduced method); no Fortran.

pub mod error;

pub use error::{LinalgError, Result};
pub use faer::{c64, Mat, MatRef};
pub mod balance;
mod dense;
pub use dense::{fro_norm, product_using_triangles};
pub mod expm;
pub mod hamiltonian;
pub mod hermitian;
pub mod lm;
pub mod logm;
pub mod lyapunov;
mod multishift;
pub mod qz;
pub mod riccati;
pub mod scalar_search;
pub mod schur;
pub mod sylvester;
