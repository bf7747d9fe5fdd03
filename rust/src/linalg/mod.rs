//! Linear algebra the numpy/faer/nalgebra stack does not provide fast enough for the row
//! filters: banded SPD systems.

mod banded;

pub use banded::{BandCholesky, SymmetricBand};
pub(crate) use banded::{BandLdlBatch, LDL_LANES};
