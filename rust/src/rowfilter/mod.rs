//! The row filters of SPEC §2: the optimal vector filter (`vector`), the quasi-optimal
//! scalar one (`scalar`), the row dynamics and mode sets they share, and the Wiener bound
//! that no row filter beats.
//!
//! This file holds the items both filters use: the row-state matrices, the limits on the
//! row multiplicity and on the pixels, and the checks of a model and of images.

use crate::error::{FieldError, Result};
use crate::field::{AxisModel, FieldModel};
use nalgebra::Matrix4;

mod row_dynamics;
mod row_modes;
mod scalar;
mod vector;
mod wiener_bound;

pub use row_modes::ModeSet;
pub use scalar::{default_ar_order, model_ar_order, RowModels, ScalarRowFilter, MAX_AR_ORDER};
pub use vector::{VectorRowFilter, INFORMATION_RATIO};
pub use wiener_bound::{wiener_bound, wiener_error_map};

/// Highest row multiplicity n_y of the row filters.
pub const MAX_ROW_ORDER: usize = 4;

/// A matrix of the row state (n_y × n_y, n_y ≤ 4, held in 4 × 4: unused rows and columns
/// are zero): transitions, covariances, gains.
pub(crate) type StateMatrix = Matrix4<f64>;

/// Input and output hold `expected` values and every pixel is in range, [`pixel_in_range`]
/// (the row filters need every observation).
pub(crate) fn check_images(z: &[f64], out: &[f64], expected: usize) -> Result<()> {
    check_sizes(z, out, expected)?;
    if !all_in_range(z) {
        return Err(out_of_range_pixels());
    }
    Ok(())
}

/// The largest |pixel| the row filters take, 2¹⁰⁰⁰ ≈ 1.07e301: their sums of a few gains
/// times pixels stay inside float64 (pixels near 1.8e308 turned the estimates to inf/NaN).
pub const MAX_PIXEL: f64 = 1.0715086071862673e301;

/// |v| ≤ [`MAX_PIXEL`]: false for NaN and ±inf too, at the cost of `is_finite`.
#[inline(always)]
pub(crate) fn pixel_in_range(v: f64) -> bool {
    v.abs() <= MAX_PIXEL
}

/// The error for a NaN, infinite or out-of-range pixel.
pub(crate) fn out_of_range_pixels() -> FieldError {
    FieldError::NonFinite(
        "the images hold NaN, infinite or out-of-range pixels (the row filters need every \
         pixel, with |z − mean| ≤ 2^1000 ≈ 1e301)"
            .into(),
    )
}

/// Input and output hold `expected` values.
pub(crate) fn check_sizes(z: &[f64], out: &[f64], expected: usize) -> Result<()> {
    if z.len() != expected || out.len() != expected {
        return Err(FieldError::Shape(format!(
            "the images hold {} values, expected {expected}",
            z.len()
        )));
    }
    Ok(())
}

/// Whether every value is in range, [`pixel_in_range`] (a branch-free fold per block: vectorised).
pub(crate) fn all_in_range(values: &[f64]) -> bool {
    values
        .chunks(4096)
        .all(|block| block.iter().fold(true, |ok, v| ok & pixel_in_range(*v)))
}

/// The (row, column) axes of a 2-axis model with n_y ≤ 4.
pub(crate) fn row_axes(model: &FieldModel) -> Result<(&AxisModel, &AxisModel)> {
    if model.ndim() != 2 {
        return Err(FieldError::InvalidParameter(format!(
            "row filters need a 2-axis model (rows, columns), got {} axes",
            model.ndim()
        )));
    }
    let axes = model.axes();
    if axes[0].order() > MAX_ROW_ORDER {
        return Err(FieldError::InvalidParameter(format!(
            "row filters support a row multiplicity up to {MAX_ROW_ORDER}, got {}",
            axes[0].order()
        )));
    }
    Ok((&axes[0], &axes[1]))
}
