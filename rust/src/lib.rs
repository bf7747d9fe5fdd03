//! kalmanfield: Markov (autoregressive) random fields and Kalman recursions for image
//! sequences. Plain-Rust numerics; the optional `python` feature adds the `_core` bindings.
//!
//! Formulas are those of the method pages of the documentation (`docs/methods/`), cited per
//! item as "SPEC §x.y". One folder per domain, each a layer that uses only the layers below
//! it (checked by `.ci/check_layers.py`): `simd` < `linalg` < `field`, `identification` <
//! `rowfilter` < `denoising` < `tracking` < the `python` bindings. The crate's API is the
//! domains' re-exports.

pub mod denoising;
mod error;
pub mod field;
pub mod filterbank;
pub mod identification;
pub mod kalman;
pub mod linalg;
pub mod rowfilter;
mod simd;
pub mod tracking;
pub mod trajectory;

#[cfg(feature = "python")]
mod python;

pub use error::{FieldError, Result};
