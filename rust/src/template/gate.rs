//! The validation gate of the non-linear link: the positions admitted around the predicted
//! one, and the search window that holds them.

use super::frame::Window;
use crate::kalman::{Gaussian, LinearGaussian};

/// The ellipse of positions p (template top-left) with νᵀ S⁻¹ ν ≤ gate², ν = p − ẑ, ẑ the
/// predicted top-left and S = H P⁻ Hᵀ + R the predicted measurement's covariance.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Gate {
    centre: [f64; 2],
    /// S (2 × 2, row-major).
    s: [f64; 4],
    gate: f64,
}

impl Gate {
    /// The gate of the prediction `predicted` under `model`.
    pub(crate) fn new(model: &LinearGaussian, predicted: &Gaussian, gate: f64) -> Self {
        let centre = &model.h * &predicted.mean;
        let s = &model.h * &predicted.cov * model.h.transpose() + &model.r;
        Self {
            centre: [centre[0], centre[1]],
            s: [s[(0, 0)], s[(0, 1)], s[(1, 0)], s[(1, 1)]],
            gate,
        }
    }

    /// Whether the pixel cell [x ± ½] × [y ± ½] of an integer position reaches into the
    /// ellipse: ν shrunk by ½ per axis towards 0 (the cell's nearest point to ẑ; exact for the
    /// diagonal S of the per-axis models), then νᵀ S⁻¹ ν ≤ gate². Every position admits when
    /// S is not positive definite or not finite (nothing to gate with).
    pub(crate) fn admits(&self, x: f64, y: f64) -> bool {
        let shrink = |d: f64| d.signum() * (d.abs() - 0.5).max(0.0);
        let (u, v) = (shrink(x - self.centre[0]), shrink(y - self.centre[1]));
        let [a, b, c, d] = self.s;
        let det = a * d - b * c;
        if !(det > 0.0 && a > 0.0 && det.is_finite()) {
            return true;
        }
        // νᵀ S⁻¹ ν with S⁻¹ = [[d, −b], [−c, a]] / det
        let q = (d * u * u - (b + c) * u * v + a * v * v) / det;
        q.is_nan() || q <= self.gate * self.gate
    }

    /// The frame region searched: the positions within ± gate·√S of ẑ per axis, widened to
    /// whole pixels plus one position on each side (so that the peak of an edge position can
    /// be refined), plus the template's extent; cut to the frame. None when nothing of it is
    /// in the frame.
    pub(crate) fn window(
        &self,
        (h, w): (usize, usize),
        (height, width): (usize, usize),
    ) -> Option<Window> {
        let [x, y] = self.centre;
        let half_x = self.gate * self.s[0].sqrt();
        let half_y = self.gate * self.s[3].sqrt();
        let (x0, x1) = ((x - half_x).floor() - 1.0, (x + half_x).ceil() + 1.0);
        let (y0, y1) = ((y - half_y).floor() - 1.0, (y + half_y).ceil() + 1.0);
        if !(x0.is_finite() && x1.is_finite() && y0.is_finite() && y1.is_finite()) {
            return Some(Window::full(height, width));
        }
        Window::clipped(x0, y0, x1 + w as f64, y1 + h as f64, height, width)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gate(centre: [f64; 2], s: [f64; 4]) -> Gate {
        Gate {
            centre,
            s,
            gate: 3.0,
        }
    }

    #[test]
    fn the_cell_nearest_point_decides() {
        // S = diag(4, 1): the ellipse reaches ±6 along x, ±3 along y
        let g = gate([10.0, 20.0], [4.0, 0.0, 0.0, 1.0]);
        assert!(g.admits(16.0, 20.0) && g.admits(16.5, 20.0) && !g.admits(16.6, 20.0));
        assert!(g.admits(10.0, 23.5) && !g.admits(10.0, 23.6) && g.admits(3.5, 20.0));
        // (u, v) = (4, 2): 16/4 + 4/1 = 8 ≤ 9; (5, 2): 25/4 + 4 > 9
        assert!(g.admits(14.5, 22.5) && !g.admits(15.5, 22.5));
        assert!(g.admits(10.3, 19.6));
    }

    #[test]
    fn a_correlated_covariance_tilts_the_ellipse() {
        // S = [[2, 1.5], [1.5, 2]]: det 1.75; ν = (2, 2): (2·4 − 3·4 + 2·4)/1.75 = 2.29 ≤ 9;
        // ν = (3, −3): (18 + 27 + 18)/1.75 = 36 > 9 (both after the ½ shrink)
        let g = gate([0.0, 0.0], [2.0, 1.5, 1.5, 2.0]);
        assert!(g.admits(2.5, 2.5));
        assert!(!g.admits(3.5, -3.5));
    }

    #[test]
    fn a_degenerate_covariance_admits_everything() {
        assert!(gate([0.0, 0.0], [f64::INFINITY, 0.0, 0.0, 1.0]).admits(1e9, 0.0));
        assert!(gate([0.0, 0.0], [0.0, 0.0, 0.0, 0.0]).admits(5.0, 5.0));
    }
}
