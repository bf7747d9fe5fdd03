//! kalmanfield: Markov (autoregressive) random fields and Kalman recursions for image
//! sequences. Plain-Rust numerics; the optional `python` feature adds the `_core` bindings.
//!
//! Formulas are those of `SPEC.md` (cited per item as "SPEC §x.y").

pub mod denoising;
mod error;
pub mod field;
pub mod identification;
pub mod linalg;
pub mod rowfilter;
mod simd;
pub mod tracking;

#[cfg(feature = "python")]
mod python;

pub use error::{FieldError, Result};
