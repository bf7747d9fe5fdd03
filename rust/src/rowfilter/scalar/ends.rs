//! Where the band of the `Ends` modes comes from: the span W' of the exact ends, doubled
//! until their splice with the Toeplitz interior is invisible on every row of a plan.

use super::settling::{Settling, SETTLE_TOLERANCE};
use super::{variances, ScalarRowFilter};
use crate::error::Result;
use crate::field::AxisModel;
use crate::rowfilter::row_modes::{Fourier, RowModes, SPLICE_TOLERANCE};
use crate::rowfilter::StateMatrix;

/// How far above the estimated rounding floor of the band a splice defect may lie: the
/// exact band sums W' modes against the second quadrature's few hundred, and its scatter was
/// measured at 3–7× the estimate (n_y = 4, ρ = 0.95), with the splice itself converged.
pub(super) const FLOOR_FACTOR: f64 = 8.0;

/// Most rows the splice check walks (the Riccati settles within a few hundred).
pub(super) const MAX_SETTLE_ROWS: usize = 100_000;

impl ScalarRowFilter {
    /// The `Ends` modes for rows of the `x` axis: W' from `RowModes::first_span`, doubled until
    /// the splice holds on every row of the plan (`splice_holds`); the whole row's eigenbasis
    /// when W' would exceed half the row.
    pub(super) fn ends_modes(&self, x: &AxisModel, sigma: f64) -> Result<RowModes> {
        let width = self.width();
        let mut span = RowModes::first_span(x, width);
        while let Some(w_ends) = span {
            let modes = RowModes::ends(x, width, w_ends)?;
            if self.splice_holds(&modes, x, sigma) {
                return Ok(modes);
            }
            span = Some(2 * w_ends).filter(|s| 2 * s <= width);
        }
        RowModes::exact(x, width)
    }

    /// Whether the splice of `modes` is invisible on the rows whose band a plan uses (row 1,
    /// the start's prior, and rows n + 1, …, until the per-mode covariances settle, 10×
    /// tighter than the plan's band: the walk outlasts the plan's): its defect
    /// (`RowModes::splice_defect`) within [`SPLICE_TOLERANCE`] plus [`FLOOR_FACTOR`] times the
    /// rounding floor of the per-mode covariances, estimated by a second quadrature of the
    /// Fourier band (the largest estimate over the rows so far) (n_y = 4 at ρ ≥ 0.9: ~1e-11 and growing with the row, from the Riccati
    /// of a state whose rows correlate to 1 − 1e-9; the exact band has the same floor).
    /// Measured in the state's own basis, not the whitened one: the splice is a property of
    /// the row's modes, and whitening (condition up to ~5e9 for n_y = 4) adds a scatter of
    /// ~1e-8 to either band.
    pub(super) fn splice_holds(&self, modes: &RowModes, x: &AxisModel, sigma: f64) -> bool {
        let (n, m) = (self.dynamics.order, self.ar_order);
        let finer = Fourier::finer(x);
        let (var, finer_var) = (
            variances(modes.values(), sigma),
            variances(finer.values(), sigma),
        );
        let rows = self
            .dynamics
            .prediction_errors(self.noise_var, &var)
            .zip(self.dynamics.prediction_errors(self.noise_var, &finer_var));
        let mut previous: Option<Vec<StateMatrix>> = None;
        let mut settling = Settling::default();
        // the largest floor estimate so far: the rounding accumulates down the rows, and one
        // row's estimate (a difference of two noisy bands) dips at random
        let mut floor = 0.0f64;
        for ((t, modal), (_, finer_modal)) in rows.take(MAX_SETTLE_ROWS) {
            if t > 1 && t <= n {
                continue;
            }
            let Some((defect, row_floor)) = modes.splice_defect(&modal, &finer, &finer_modal, n, m)
            else {
                return true;
            };
            floor = floor.max(row_floor);
            if defect > SPLICE_TOLERANCE + FLOOR_FACTOR * floor {
                return false;
            }
            if let Some(old) = &previous {
                let scale = modal.iter().fold(0.0f64, |s, c| s.max(c.amax()));
                let change = modal
                    .iter()
                    .zip(old)
                    .fold(0.0f64, |s, (a, b)| s.max((a - b).amax()))
                    / scale;
                if settling.settled_after(change, 0.1 * SETTLE_TOLERANCE) {
                    break;
                }
            }
            if t > n {
                previous = Some(modal);
            }
        }
        true
    }
}
