//! kalmanfield: Markov (autoregressive) random fields and Kalman recursions for image
//! sequences. Plain-Rust numerics; the optional `python` feature adds the `_core` bindings.
//!
//! Formulas are those of `SPEC.md` (cited per item as "SPEC §x.y").

pub mod adaptive_denoise;
pub mod branching;
mod column_precision;
pub mod error;
pub mod field;
pub mod identification;
pub mod linalg;
pub mod local_moments;
pub mod noise_level;
mod row_columns;
pub mod row_modes;
pub mod scalar_row_filter;
pub mod scratch;
pub mod segment;
mod simd;
pub mod vector_row_filter;
pub mod wiener_bound;

#[cfg(feature = "python")]
mod python;

pub use error::{FieldError, Result};
