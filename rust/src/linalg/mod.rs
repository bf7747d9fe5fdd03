//! Linear algebra the numpy/faer/nalgebra stack does not provide fast enough for the row
//! filters: banded SPD systems.

mod banded;

pub(crate) use banded::LDL_LANES;
pub use banded::{BandCholesky, BandLdlBatch, SymmetricBand};
