//! kalmanfield: Markov (autoregressive) random fields and Kalman recursions for image
//! sequences. Plain-Rust numerics; the optional `python` feature adds the `_core` bindings.
//!
//! Formulas are those of `SPEC.md` (cited per item as "SPEC §x.y").

pub mod adaptive_denoise;
pub mod anisotropy;
pub mod axis_lines;
pub mod axis_model;
pub mod axis_modes;
mod band_inverse;
pub mod band_ldl;
pub mod banded;
pub mod branching;
pub mod cascade;
pub mod chi_squared;
mod column_precision;
pub mod difference_gram;
pub mod error;
pub mod field_model;
mod four_lanes;
pub mod kalman;
pub mod lag_products;
pub mod local_moments;
pub mod noise;
pub mod noise_level;
pub mod product_field;
mod row_columns;
pub mod row_modes;
pub mod scalar_row_filter;
pub mod scratch;
pub mod segment;
pub mod stationary_start;
pub mod steady_band;
mod steady_blocks;
pub mod template;
pub mod vector_row_filter;
pub mod vector_state;
pub mod whitening;
pub mod wiener_bound;

#[cfg(feature = "python")]
mod python;

pub use error::{FieldError, Result};
pub use field_model::FieldModel;
pub use noise::Noise;
