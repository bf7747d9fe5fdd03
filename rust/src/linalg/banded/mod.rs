//! Symmetric banded matrices and their factors: the O(size · bandwidth) solves of the
//! quasi-optimal row filter's row systems (SPEC §2.3 generalised), the band of their
//! inverses (the error maps) and the LDLᵀ factors of their per-pixel-weighted variants.
//!
//! Layers, lowest first: `band` (storage), `substitution` (the window substitutions),
//! `lane_steps` and `partitioned` (LANES parts of a long order at once), `steady_band` and
//! `steady_blocks` (a periodic interior's shared coefficients, or blocks for the wide
//! bands), `band_inverse`, then `cholesky` (the factor, which plans its solves) and
//! `band_ldl`.

mod band;
mod band_inverse;
mod band_ldl;
mod cholesky;
mod lane_steps;
mod partitioned;
mod steady_band;
mod steady_blocks;
mod substitution;

pub use band::SymmetricBand;
pub(crate) use band_ldl::{BandLdlBatch, LANES as LDL_LANES};
pub use cholesky::BandCholesky;
