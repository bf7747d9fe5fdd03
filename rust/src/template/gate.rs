//! The search window of a predicted position (the gate of the non-linear link).

use super::frame::Window;
use crate::kalman::{Gaussian, LinearGaussian};

/// The frame region searched around the predicted top-left (x̂, ŷ): the positions within
/// ± gate·√S of the prediction (S = H P⁻ Hᵀ + R, the predicted measurement's covariance),
/// widened to whole pixels plus one position on each side (so that the peak of an edge
/// position can be refined), plus the template's extent; cut to the frame. None when nothing
/// of it is in the frame.
pub(crate) fn search_window(
    model: &LinearGaussian,
    predicted: &Gaussian,
    gate: f64,
    (h, w): (usize, usize),
    (height, width): (usize, usize),
) -> Option<Window> {
    let centre = &model.h * &predicted.mean;
    let s = &model.h * &predicted.cov * model.h.transpose() + &model.r;
    let (x, y) = (centre[0], centre[1]);
    let half_x = gate * s[(0, 0)].sqrt();
    let half_y = gate * s[(1, 1)].sqrt();
    let (x0, x1) = ((x - half_x).floor() - 1.0, (x + half_x).ceil() + 1.0);
    let (y0, y1) = ((y - half_y).floor() - 1.0, (y + half_y).ceil() + 1.0);
    if !(x0.is_finite() && x1.is_finite() && y0.is_finite() && y1.is_finite()) {
        return Some(Window::full(height, width));
    }
    Window::clipped(x0, y0, x1 + w as f64, y1 + h as f64, height, width)
}
