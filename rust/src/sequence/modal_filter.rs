//! The exact Kalman filter over frames (SPEC §2.5): in the eigenbasis of the frame
//! covariance every spatial mode is an independent AR(n_t) sequence in time observed in
//! white noise, so the filter over frames is H·W scalar-observation filters, each started
//! exactly from the stationary covariance. A state of lag + 1 frames per mode makes it the
//! fixed-lag smoother.

use super::mode_basis::ModeBasis;
use super::mode_kalman::TemporalDynamics;
use super::{check_model, check_step, MAX_STATE_FRAMES};
use crate::error::{try_zeros, FieldError, Result};
use crate::field::FieldModel;
use rayon::prelude::*;

/// The streaming exact filter (lag 0) or fixed-lag smoother (lag > 0) of a 3-axis model.
#[derive(Debug, Clone)]
pub struct ModalSequenceFilter {
    basis: ModeBasis,
    dynamics: TemporalDynamics,
    noise_var: f64,
    lag: usize,
    /// Per mode, d state values (x_t, …, x_{t−d+1}) and their d × d covariance.
    means: Vec<f64>,
    covs: Vec<f64>,
    frames: u64,
}

impl ModalSequenceFilter {
    /// The filter of `model` (axes t, y, x) for height × width frames observed with white
    /// noise of variance `noise_var`; `lag` > 0 smooths each frame with the `lag` newer ones.
    pub fn new(
        model: &FieldModel,
        noise_var: f64,
        height: usize,
        width: usize,
        lag: usize,
    ) -> Result<Self> {
        check_model(model)?;
        crate::error::check_noise_var(noise_var)?;
        if height == 0 || width == 0 {
            return Err(FieldError::Shape("the frames must not be empty".into()));
        }
        let time = &model.axes()[0];
        let dim = time.order().max(lag + 1);
        if dim > MAX_STATE_FRAMES {
            return Err(FieldError::InvalidParameter(format!(
                "the state of max(n_t, lag + 1) = {dim} frames per mode exceeds \
                 {MAX_STATE_FRAMES} (lower lag)"
            )));
        }
        let size = height
            .checked_mul(width)
            .and_then(|s| s.checked_mul(dim * dim))
            .ok_or_else(|| FieldError::OutOfMemory("the frame is too large".into()))?;
        let means = try_zeros(height * width * dim, "the modes' states")?;
        let covs = try_zeros(size, "the modes' covariances")?;
        Ok(Self {
            basis: ModeBasis::new(model, height, width)?,
            dynamics: TemporalDynamics::new(time, dim),
            noise_var,
            lag,
            means,
            covs,
            frames: 0,
        })
    }

    /// H·W.
    pub fn frame_size(&self) -> usize {
        self.basis.height * self.basis.width
    }

    /// Frames seen so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Takes the next frame `z` (NaN = missing pixel) and writes into `out` the estimate of
    /// frame t − lag; false (out untouched) while fewer than lag + 1 frames were seen.
    ///
    /// Missing pixels break the modes' independence. A frame with every pixel missing is a
    /// prediction step (exact). In a partly missing frame each missing pixel is replaced by
    /// its predicted value before the update: the innovation there is zero, so the
    /// estimate is the prediction corrected by the observed pixels' innovations, and the
    /// covariances go on as if the pixel had been observed (its error is understated).
    pub fn step(&mut self, z: &[f64], out: &mut [f64]) -> Result<bool> {
        let size = self.frame_size();
        let missing = check_step(z, out, size)?;
        let mut work = try_zeros(size, "a frame buffer")?;
        let mut modes = try_zeros(size, "a frame buffer")?;
        self.predict();
        if missing < size {
            if missing == 0 {
                self.basis.to_modes(z, &mut modes, &mut work);
            } else {
                let mut filled = self.element_frame(0)?;
                for (f, &v) in filled.iter_mut().zip(z) {
                    if !v.is_nan() {
                        *f = v;
                    }
                }
                self.basis.to_modes(&filled, &mut modes, &mut work);
            }
            self.update(&modes);
        }
        self.frames += 1;
        if self.frames <= self.lag as u64 {
            return Ok(false);
        }
        self.write_element(self.lag, out, &mut work);
        Ok(true)
    }

    /// The estimates of the frames not yet output (the last min(lag, frames) ones, oldest
    /// first, each from every frame seen), row-major frames × H × W.
    pub fn pending(&self) -> Result<Vec<f64>> {
        let count = (self.lag as u64).min(self.frames) as usize;
        let size = self.frame_size();
        let mut out = try_zeros(count * size, "the pending frames")?;
        let mut work = try_zeros(size, "a frame buffer")?;
        for (k, frame) in out.chunks_exact_mut(size).enumerate() {
            self.write_element(count - 1 - k, frame, &mut work);
        }
        Ok(out)
    }

    fn predict(&mut self) {
        let d = self.dynamics.dim;
        let first = self.frames == 0;
        let dynamics = &self.dynamics;
        self.means
            .par_chunks_mut(d)
            .zip(self.covs.par_chunks_mut(d * d))
            .zip(self.basis.variances.par_iter())
            .for_each_init(
                || vec![0.0; d * d],
                |work, ((mean, cov), &lambda)| {
                    if first {
                        dynamics.prior(lambda, mean, cov);
                    } else {
                        dynamics.predict(lambda, mean, cov, work);
                    }
                },
            );
    }

    fn update(&mut self, modes: &[f64]) {
        let d = self.dynamics.dim;
        let (dynamics, noise_var) = (&self.dynamics, self.noise_var);
        self.means
            .par_chunks_mut(d)
            .zip(self.covs.par_chunks_mut(d * d))
            .zip(modes.par_iter())
            .for_each(|((mean, cov), &z)| dynamics.update(z, noise_var, mean, cov));
    }

    /// The frame of state element `element` (frame t − element) in pixels.
    fn element_frame(&self, element: usize) -> Result<Vec<f64>> {
        let size = self.frame_size();
        let mut out = try_zeros(size, "a frame buffer")?;
        let mut work = try_zeros(size, "a frame buffer")?;
        self.write_element(element, &mut out, &mut work);
        Ok(out)
    }

    fn write_element(&self, element: usize, out: &mut [f64], work: &mut [f64]) {
        let d = self.dynamics.dim;
        let coefficients: Vec<f64> = self.means.chunks_exact(d).map(|m| m[element]).collect();
        self.basis.to_pixels(&coefficients, out, work);
    }

    /// The per-pixel error variance (row-major H × W) of the steady state: of the filtered
    /// frame (lag 0) or of the frame smoothed with `lag` newer ones.
    pub fn error_variance(&self) -> Vec<f64> {
        let (dynamics, noise_var, lag) = (&self.dynamics, self.noise_var, self.lag);
        let per_mode: Vec<f64> = self
            .basis
            .variances
            .par_iter()
            .map(|&lambda| dynamics.steady_variance(lambda, noise_var, lag))
            .collect();
        let mut out = vec![0.0; per_mode.len()];
        self.basis.pixel_variances(&per_mode, &mut out);
        out
    }

    /// The state to save: (frames seen, means, covariances).
    pub fn state(&self) -> (u64, &[f64], &[f64]) {
        (self.frames, &self.means, &self.covs)
    }

    /// Restores a state saved by [`Self::state`] of a filter built with the same arguments.
    pub fn set_state(&mut self, frames: u64, means: &[f64], covs: &[f64]) -> Result<()> {
        if means.len() != self.means.len() || covs.len() != self.covs.len() {
            return Err(FieldError::Shape(
                "the saved state does not fit this filter (other frame shape, order or lag)".into(),
            ));
        }
        if means.iter().chain(covs).any(|v| !v.is_finite()) {
            return Err(FieldError::NonFinite(
                "the saved state holds NaN or infinite values".into(),
            ));
        }
        self.means.copy_from_slice(means);
        self.covs.copy_from_slice(covs);
        self.frames = frames;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_in_time_is_the_per_frame_wiener_estimate() {
        // ρ_t → 0: each frame alone; the mean error is the per-frame Wiener bound
        let model = FieldModel::new(&[1e-9, 0.8, 0.6], &[1, 1, 2], 1.0).unwrap();
        let filter = ModalSequenceFilter::new(&model, 0.5, 4, 6, 0).unwrap();
        let map = filter.error_variance();
        let mean = map.iter().sum::<f64>() / 24.0;
        let planar = FieldModel::new(&[0.8, 0.6], &[1, 2], 1.0).unwrap();
        let bound = crate::rowfilter::wiener_bound(&planar, 0.5, 4, 6).unwrap();
        assert!((mean - bound).abs() < 1e-9, "{mean} vs {bound}");
    }

    #[test]
    fn streams_lagged_frames_and_refuses_bad_frames() {
        let model = FieldModel::new(&[0.9, 0.8, 0.6], &[2, 1, 1], 1.0).unwrap();
        let mut filter = ModalSequenceFilter::new(&model, 0.5, 3, 4, 2).unwrap();
        let mut out = vec![0.0; 12];
        let frame: Vec<f64> = (0..12).map(|k| k as f64 / 6.0 - 1.0).collect();
        assert!(!filter.step(&frame, &mut out).unwrap());
        assert!(!filter.step(&frame, &mut out).unwrap());
        assert_eq!(filter.pending().unwrap().len(), 24);
        assert!(filter.step(&frame, &mut out).unwrap());
        assert!(filter.step(&frame[..11], &mut out).is_err());
        let mut bad = frame.clone();
        bad[3] = f64::INFINITY;
        assert!(filter.step(&bad, &mut out).is_err());
        assert_eq!(filter.frames(), 3);
        assert!(ModalSequenceFilter::new(&model, 0.0, 3, 4, 0).is_err());
        let planar = FieldModel::new(&[0.8, 0.6], &[1, 1], 1.0).unwrap();
        assert!(ModalSequenceFilter::new(&planar, 1.0, 3, 4, 0).is_err());
    }
}
