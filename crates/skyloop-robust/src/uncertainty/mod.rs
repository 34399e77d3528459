//! Uncertainty models: block structures of Δ, uncertain parameters and blocks, weights, samples,
//! and uncertain systems as upper LFTs.

pub mod blocks;
pub mod params;
pub mod sample;
pub mod usys;
pub mod weights;

pub use blocks::{BlockKind, BlockStructure};
pub use params::{UComplex, ULtiDyn, UReal};
pub use sample::{sample_delta, sample_ltidyn};
pub use usys::{input_multiplicative, output_multiplicative, UncertainSystem};
pub use weights::{makeweight, makeweight_mag};
pub mod worst;
pub use worst::{realize_perturbation, realize_perturbation_detailed, RealizedPerturbation};
