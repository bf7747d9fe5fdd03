//! The separable multiple-root autoregressive field (SPEC §1): the axis models, the
//! eigenbasis of an axis' correlation, the exactly stationary start, the generators
//! (cascade, product field) with their driving white noise ξ, and the anisotropy
//! coefficient.

mod anisotropy;
mod axis_lines;
mod axis_model;
mod axis_modes;
mod cascade;
mod driving_noise;
mod field_model;
mod product_field;
mod real;
mod stationary_start;

pub use anisotropy::anisotropy;
pub(crate) use axis_lines::{AxisLines, LaneBlock};
pub use axis_model::{correlation_table, AxisModel, MAX_ORDER};
pub use axis_modes::AxisModes;
pub use cascade::{sample_into, stream_frame_into};
pub use driving_noise::DrivingNoise;
pub use field_model::{FieldModel, MAX_SIGMA, MIN_SIGMA};
pub use product_field::product_field_into;
pub use real::Real;
pub use stationary_start::{AxisRecursion, MAX_ROUNDING_GAIN, MAX_START_SENSITIVITY};
