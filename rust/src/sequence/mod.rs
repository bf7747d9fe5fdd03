//! Filtering frame sequences in space and time (SPEC §2.5): the exact Kalman filter over
//! frames split per spatial eigenmode (`modal_filter`, with fixed-lag smoothing), and the
//! fast O(H·W)-per-frame filter that carries the row filter into time (`fast_filter`).

mod fast_filter;
mod modal_filter;
mod mode_basis;
mod mode_kalman;

pub use fast_filter::FastSequenceFilter;
pub use modal_filter::ModalSequenceFilter;

use crate::error::{FieldError, Result};
use crate::field::FieldModel;

/// Largest temporal multiplicity n_t and largest lag: the per-mode state holds
/// max(n_t, lag + 1) frames.
pub const MAX_STATE_FRAMES: usize = 64;

/// The (t, y, x) axes of a 3-axis model.
pub(crate) fn check_model(model: &FieldModel) -> Result<()> {
    if model.ndim() != 3 {
        return Err(FieldError::InvalidParameter(format!(
            "a sequence filter needs a 3-axis model (t, y, x), got {} axes",
            model.ndim()
        )));
    }
    Ok(())
}

/// A step's frame (see [`check_sizes`], [`check_pixels`]) and output of H·W values; the
/// count of missing pixels.
pub(crate) fn check_step(frame: &[f64], out: &[f64], size: usize) -> Result<usize> {
    check_sizes(frame, out, size)?;
    let (mut missing, mut infinite) = (0, false);
    for v in frame {
        missing += usize::from(v.is_nan());
        infinite |= v.is_infinite();
    }
    check_pixels(infinite)?;
    Ok(missing)
}

/// A step's frame and output both of H·W values.
pub(crate) fn check_sizes(frame: &[f64], out: &[f64], size: usize) -> Result<()> {
    for (what, len) in [("frame", frame.len()), ("output", out.len())] {
        if len != size {
            return Err(FieldError::Shape(format!(
                "the {what} holds {len} values, expected {size}"
            )));
        }
    }
    Ok(())
}

/// The error for a frame with infinite pixels (every pixel must be finite or NaN, a missing
/// pixel).
pub(crate) fn check_pixels(infinite: bool) -> Result<()> {
    if infinite {
        return Err(FieldError::NonFinite(
            "the frame holds infinite pixels (NaN marks a missing pixel; ±inf is refused)".into(),
        ));
    }
    Ok(())
}
