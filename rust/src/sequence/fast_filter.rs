//! The fast filter over frames (SPEC §2.5, the row filters' idea carried into time), O(H·W)
//! per frame: the prediction of frame t from the previous estimates by the time axis'
//! recursion, then the smoothed quasi-optimal row filter (SPEC §2.3) of the prediction
//! error u = x_t − x̂_e,t from y = z_t − x̂_e,t = u + θ, with a separable model of u fitted
//! to the steady state (by the caller; frame 0, predicted by zero, uses the field's own
//! spatial model). For n_t ≥ 2 the previous estimate is also corrected by the newest
//! frame, x̂_{t−1|t} = x̂_{t−1} + c·û_t (a fixed-lag-1 smoothing step with a constant gain c
//! fitted with the model of u), and the next prediction uses the corrected pair.

use super::{check_model, check_pixels, check_sizes};
use crate::error::{try_zeros, FieldError, Result};
use crate::field::{AxisRecursion, FieldModel};
use crate::rowfilter::{ModeSet, ScalarRowFilter};

/// The streaming fast filter of a 3-axis model.
#[derive(Debug)]
pub struct FastSequenceFilter {
    /// Row filters of frame 0 (the field's spatial model) and of the later frames (the
    /// model of the steady prediction error).
    first: ScalarRowFilter,
    steady: ScalarRowFilter,
    /// The time axis' stationary-start recursion: position t < n_t predicts from t frames.
    recursion: AxisRecursion<f64>,
    /// The gain c of the previous estimate's correction by the newest û (n_t ≥ 2).
    smoothing: f64,
    noise_var: f64,
    height: usize,
    /// The last n_t estimates, newest first (frame-major); the older ones corrected by the
    /// newer frames.
    history: Vec<f64>,
    frames: u64,
    /// Scratch frames reused by every step (fresh 8 MB buffers per 1024² frame cost page
    /// faults): the residual y and, once a frame has missing pixels, the row filter's
    /// weights.
    residual: Vec<f64>,
    weights: Vec<f64>,
}

impl FastSequenceFilter {
    /// The filter of `model` (axes t, y, x) for height × width frames with noise variance
    /// `noise_var`; `error_model`: the 2-axis model of the steady prediction error;
    /// `smoothing`: the gain c of the previous estimate's correction (unused for n_t = 1).
    pub fn new(
        model: &FieldModel,
        error_model: &FieldModel,
        smoothing: f64,
        noise_var: f64,
        height: usize,
        width: usize,
    ) -> Result<Self> {
        check_model(model)?;
        if !smoothing.is_finite() {
            return Err(FieldError::InvalidParameter(format!(
                "the smoothing gain must be finite, got {smoothing}"
            )));
        }
        if height == 0 || width == 0 {
            return Err(FieldError::Shape("the frames must not be empty".into()));
        }
        let axes = model.axes();
        let spatial = FieldModel::new(
            &[axes[1].rho(), axes[2].rho()],
            &[axes[1].order(), axes[2].order()],
            model.sigma(),
        )?;
        let row_filter =
            |m: &FieldModel| ScalarRowFilter::new(m, noise_var, width, None, ModeSet::Ends);
        let n_t = axes[0].order();
        Ok(Self {
            first: row_filter(&spatial)?,
            steady: row_filter(error_model)?,
            recursion: AxisRecursion::new(&axes[0], 1.0)?,
            smoothing,
            noise_var,
            height,
            history: try_zeros(n_t * height * width, "the previous estimates")?,
            frames: 0,
            residual: try_zeros(height * width, "a frame buffer")?,
            weights: Vec::new(),
        })
    }

    /// H·W.
    pub fn frame_size(&self) -> usize {
        self.history.len() / self.recursion.order()
    }

    /// Frames seen so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Takes the next frame `z` (NaN = missing pixel: weight 0 in the row filter) and
    /// writes the estimate of it into `out`.
    pub fn step(&mut self, z: &[f64], out: &mut [f64]) -> Result<()> {
        let size = self.frame_size();
        check_sizes(z, out, size)?;
        let seen = (self.frames as usize).min(self.recursion.order());
        let (coefficients, _) = self.recursion.at(seen);
        let history = &self.history;
        // y = z − x̂_e (0 at a missing pixel), x̂_e never stored, and the pixels checked, in
        // one pass over the frame: the step is bound by memory traffic (method page)
        let (mut missing, mut infinite) = (0, false);
        let mut residual = |r: &mut f64, v: f64, p: f64| {
            missing += usize::from(v.is_nan());
            infinite |= v.is_infinite();
            *r = if v.is_nan() { 0.0 } else { v - p };
        };
        match coefficients {
            [] => {
                for (r, &v) in self.residual.iter_mut().zip(z) {
                    residual(r, v, 0.0);
                }
            }
            &[a] => {
                for ((r, &v), &h) in self.residual.iter_mut().zip(z).zip(history) {
                    residual(r, v, a * h);
                }
            }
            _ => {
                for (i, (r, &v)) in self.residual.iter_mut().zip(z).enumerate() {
                    residual(r, v, predicted(coefficients, history, size, i));
                }
            }
        }
        check_pixels(infinite)?;
        if missing > 0 {
            let observed = 1.0 / self.noise_var;
            self.weights.resize(size, 0.0);
            for (w, v) in self.weights.iter_mut().zip(z) {
                *w = if v.is_nan() { 0.0 } else { observed };
            }
        }
        let weights = (missing > 0).then_some(self.weights.as_slice());
        let filter = if self.frames == 0 {
            &self.first
        } else {
            &self.steady
        };
        filter.filter_image(&self.residual, weights, out, self.height, true)?;
        // x̂ = x̂_e + û, and the history shifted by one frame with x̂ as the newest (for
        // n_t ≥ 2 the previous estimate corrected first: x̂_{t−1|t} = x̂_{t−1} + c·û)
        let history = &mut self.history;
        match coefficients {
            &[a] if history.len() == size => {
                for (o, h) in out.iter_mut().zip(history.iter_mut()) {
                    *o += a * *h;
                    *h = *o;
                }
            }
            _ => {
                let c = if self.frames == 0 {
                    0.0
                } else {
                    self.smoothing
                };
                for (i, o) in out.iter_mut().enumerate() {
                    let u = *o;
                    *o += predicted(coefficients, history, size, i);
                    history[i] += c * u;
                }
                let kept = history.len() - size;
                history.copy_within(0..kept, size);
                history[..size].copy_from_slice(out);
            }
        }
        self.frames += 1;
        Ok(())
    }

    /// The steady row filter's own per-pixel error variance map (row-major H × W): the
    /// error the filter assumes, with the fitted model of the prediction error.
    pub fn error_variance(&self) -> Result<Vec<f64>> {
        self.steady.error_variance(self.height, None)
    }

    /// The state to save: (frames seen, the last n_t estimates).
    pub fn state(&self) -> (u64, &[f64]) {
        (self.frames, &self.history)
    }

    /// Restores a state saved by [`Self::state`] of a filter built with the same arguments.
    pub fn set_state(&mut self, frames: u64, history: &[f64]) -> Result<()> {
        if history.len() != self.history.len() {
            return Err(FieldError::Shape(
                "the saved state does not fit this filter (other frame shape or order)".into(),
            ));
        }
        if history.iter().any(|v| !v.is_finite()) {
            return Err(FieldError::NonFinite(
                "the saved state holds NaN or infinite values".into(),
            ));
        }
        self.history.copy_from_slice(history);
        self.frames = frames;
        Ok(())
    }
}

/// The prediction x̂_e of pixel `i`: Σ_k a_k x̂_{t−1−k}(i) over the frames of `history`
/// (newest first, `size` pixels each).
#[inline(always)]
fn predicted(coefficients: &[f64], history: &[f64], size: usize, i: usize) -> f64 {
    coefficients
        .iter()
        .enumerate()
        .map(|(k, a)| a * history[k * size + i])
        .sum()
}
