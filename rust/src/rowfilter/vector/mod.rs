//! The optimal vector row filter (SPEC §2.1–2.2) with its exact start and an RTS pass over
//! the rows, computed in the eigenbasis of the row correlation.
//!
//! The row state ȳ_k = (x̄_k, …, x̄_{k-n+1}) (n = n_y) has transition A_y ⊗ I, process noise
//! β̃_y² e₁e₁ᵀ ⊗ V_x (V_x = σ² Toeplitz(R_x)) [P 3.32], observation noise σ_θ² I and the exact
//! stationary prior σ² R_y[:n,:n] ⊗ R_x for the first n rows (SPEC §1.3). Every matrix is a
//! Kronecker product with V_x or I, so with V_x = U diag(v) Uᵀ the rotation z̄ → Uᵀz̄ splits
//! the nW-dimensional filter into W independent n-dimensional ones (mode j: prior
//! v_j R_y[:n,:n], process noise β̃_y² v_j e₁e₁ᵀ, observation noise σ_θ²). This is the same
//! filter, exactly, at O(W²) per row (two rotations) instead of O(n³W³).
//!
//! Start: rows 1..n form one static state (x̄_n, …, x̄_1) observed one row at a time — the
//! SPEC's "row 1 by the 1-D model along the row, rows 2..n by the boundary models", written
//! as one Kalman filter — so row t ≤ n gets E[x̄_t | z̄_1..z̄_t].
//!
//! Each mode's Riccati and state run in the whitened basis of the n rows (`RowDynamics::
//! whitened`: v' = L⁻¹ v, R_y[:n,:n] = L Lᵀ, prior I, row t read out through a row of L):
//! in the rows' own basis the prior of n_y = 4 rows has a condition ~3e17 at ρ = 0.999, and
//! the smoother, whose gain needs P_e⁻¹, lay up to 1.19× above the Wiener bound there.

use crate::error::{try_zeros, FieldError, Result};
use crate::field::{AxisModes, FieldModel};
use crate::rowfilter::row_dynamics::{ModeCovariance, RowDynamics};
use crate::rowfilter::{check_images, row_axes, StateMatrix, MAX_ROW_ORDER};
use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use inverse_correlation::InverseCorrelation;
use rayon::prelude::*;

mod inverse_correlation;

pub use inverse_correlation::INFORMATION_RATIO;

/// The optimal filter for one model, noise variance and row width.
#[derive(Debug, Clone)]
pub struct VectorRowFilter {
    /// The rows' dynamics in their whitened basis (module doc).
    dynamics: RowDynamics,
    /// R_y⁻¹, for the smoothed map of the modes with σ_θ²/v_j ≤ [`INFORMATION_RATIO`].
    column: InverseCorrelation,
    noise_var: f64,
    modes: AxisModes,
    mode_var: Vec<f64>,
}

/// Per step t (row t+1) and mode j: the gain K (n) and the smoother gain J_t (n×n, linking
/// rows t and t+1); steps past `steps` reuse the last one (the Riccati has converged).
struct Schedule {
    steps: usize,
    gains: Vec<[f64; MAX_ROW_ORDER]>,
    smoothers: Vec<StateMatrix>,
}

impl VectorRowFilter {
    /// The filter of a 2-axis `model` (axis 0 = rows) for rows of `width` pixels.
    pub fn new(model: &FieldModel, noise_var: f64, width: usize) -> Result<Self> {
        let (y, x) = row_axes(model)?;
        crate::error::check_noise_var(noise_var)?;
        if width == 0 {
            return Err(FieldError::Shape("width must be positive".into()));
        }
        let modes = AxisModes::new(x, width)?;
        let signal = model.sigma() * model.sigma();
        let mode_var = modes.values.iter().map(|l| signal * l).collect();
        let dynamics = RowDynamics::new(y).whitened()?;
        Ok(Self {
            column: InverseCorrelation::new(y, &dynamics.whitening),
            dynamics,
            noise_var,
            modes,
            mode_var,
        })
    }

    /// Row width W.
    pub fn width(&self) -> usize {
        self.modes.size()
    }

    /// The eigenbasis of the row covariance.
    pub fn modes(&self) -> &AxisModes {
        &self.modes
    }

    /// v_j = σ² λ_j: the variance of every mode.
    pub fn mode_variances(&self) -> &[f64] {
        &self.mode_var
    }

    fn gain(&self, cov: &ModeCovariance, t: usize, ratio: f64) -> [f64; MAX_ROW_ORDER] {
        let h = self.dynamics.observation(t);
        let c = cov.predicted * h;
        let s = h.dot(&c) + ratio;
        std::array::from_fn(|i| c[i] / s)
    }

    /// J_t = P_t F_{t+1}ᵀ P_e,t+1⁻¹ (identity inside the static start).
    fn smoother(
        &self,
        t: usize,
        filtered: &StateMatrix,
        next_predicted: &StateMatrix,
    ) -> StateMatrix {
        if t < self.dynamics.order {
            return StateMatrix::identity();
        }
        let mut padded = *next_predicted;
        for i in self.dynamics.order..MAX_ROW_ORDER {
            padded[(i, i)] = 1.0;
        }
        // Jᵀ = P_e⁻¹ F P. A P_e that rounds to indefinite (in the rows' own basis, n_y = 4 with
        // ρ_y ≥ 0.995, whose prior of 4 rows has a condition ≥ 1e15; rare in the whitened
        // one) gets J = 0: that mode keeps its filtered value, and the error map, made with
        // the same J, says so (an LU solve there gave J from rounding noise).
        let rhs = self.dynamics.transition * filtered;
        match padded.cholesky() {
            Some(ch) => ch.solve(&rhs).transpose(),
            None => StateMatrix::zeros(),
        }
    }

    fn schedule(&self, height: usize) -> Schedule {
        crate::simd::clear_upper_state();
        let w = self.width();
        let ratios: Vec<f64> = self.mode_var.iter().map(|v| self.noise_var / v).collect();
        let mut gains = Vec::new();
        let mut smoothers = Vec::new();
        let mut current: Vec<ModeCovariance> = Vec::new();
        let mut steps = 0;
        let mut settled = false;
        for t in 1..=height {
            let next: Vec<ModeCovariance> = (0..w)
                .map(|j| {
                    let prev = current.get(j).map_or(self.dynamics.prior, |c| c.filtered);
                    self.dynamics.riccati_step(t, &prev, ratios[j])
                })
                .collect();
            if t > 1 {
                smoothers.extend(
                    (0..w).map(|j| self.smoother(t - 1, &current[j].filtered, &next[j].predicted)),
                );
            }
            let new_gains: Vec<_> = (0..w).map(|j| self.gain(&next[j], t, ratios[j])).collect();
            settled = t > self.dynamics.order + 2 && {
                let old = &gains[gains.len() - w..];
                let old_j = &smoothers[smoothers.len() - 2 * w..smoothers.len() - w];
                let new_j = &smoothers[smoothers.len() - w..];
                max_change(old, &new_gains) < 1e-15
                    && old_j
                        .iter()
                        .zip(new_j)
                        .all(|(a, b)| (a - b).amax() < 1e-15 * (1.0 + b.amax()))
            };
            gains.extend(new_gains);
            current = next;
            steps = t;
            if settled {
                break;
            }
        }
        // J_steps: the steady one once settled; otherwise it links the last row to nothing.
        let last: Vec<StateMatrix> = if settled {
            smoothers[smoothers.len() - w..].to_vec()
        } else {
            vec![StateMatrix::identity(); w]
        };
        smoothers.extend(last);
        Schedule {
            steps,
            gains,
            smoothers,
        }
    }

    /// Filters one image (row-major height × width) into `out`; `smooth` adds the RTS pass.
    /// `par`: parallelism of the rotations and of the modes.
    pub fn filter_image(
        &self,
        z: &[f64],
        out: &mut [f64],
        height: usize,
        smooth: bool,
        par: bool,
    ) -> Result<()> {
        check_images(z, out, height * self.width())?;
        if height == 0 {
            return Ok(());
        }
        let schedule = self.schedule(height);
        self.filter_with(&schedule, z, out, height, smooth, par)
    }

    /// Filters a stack of `frames` images in parallel (one frame per task).
    pub fn filter_stack(
        &self,
        z: &[f64],
        out: &mut [f64],
        frames: usize,
        height: usize,
        smooth: bool,
    ) -> Result<()> {
        let size = height * self.width();
        check_images(z, out, frames * size)?;
        if size == 0 {
            return Ok(());
        }
        let schedule = self.schedule(height);
        out.par_chunks_mut(size)
            .zip(z.par_chunks(size))
            .try_for_each(|(o, f)| self.filter_with(&schedule, f, o, height, smooth, false))
    }

    fn filter_with(
        &self,
        schedule: &Schedule,
        z: &[f64],
        out: &mut [f64],
        height: usize,
        smooth: bool,
        par: bool,
    ) -> Result<()> {
        let w = self.width();
        let faer_par = if par { Par::rayon(0) } else { Par::Seq };
        // modal[j * height + t] = (Uᵀ z̄_t)_j: each mode's column is contiguous
        let mut modal = try_zeros(height * w, "the modal image")?;
        let image = MatRef::from_row_major_slice(z, height, w);
        matmul(
            MatMut::from_column_major_slice_mut(&mut modal, height, w),
            Accum::Replace,
            image,
            self.modes.vectors.as_ref(),
            1.0,
            faer_par,
        );
        crate::simd::clear_upper_state();
        let run = |(j, column): (usize, &mut [f64])| self.filter_mode(schedule, j, column, smooth);
        if par {
            modal.par_chunks_mut(height).enumerate().for_each(run);
        } else {
            modal.chunks_mut(height).enumerate().for_each(run);
        }
        matmul(
            MatMut::from_row_major_slice_mut(out, height, w),
            Accum::Replace,
            MatRef::from_column_major_slice(&modal, height, w),
            self.modes.vectors.transpose(),
            1.0,
            faer_par,
        );
        Ok(())
    }

    /// Kalman filter (+ RTS) of mode j over the rows; the column is replaced by the estimates.
    fn filter_mode(&self, schedule: &Schedule, j: usize, column: &mut [f64], smooth: bool) {
        crate::simd::clear_upper_state();
        let (n, w, height) = (self.dynamics.order, self.width(), column.len());
        let step = |t: usize| (t.min(schedule.steps) - 1) * w + j;
        let mut filtered = vec![[0.0f64; MAX_ROW_ORDER]; if smooth { height } else { 1 }];
        let mut predicted = vec![[0.0f64; MAX_ROW_ORDER]; if smooth { height } else { 1 }];
        let mut state = [0.0f64; MAX_ROW_ORDER];
        let readout = |t: usize, x: &[f64; MAX_ROW_ORDER]| {
            let h = self.dynamics.observation(t);
            (0..n).map(|i| h[i] * x[i]).sum::<f64>()
        };
        for t in 1..=height {
            let prediction = if t <= n { state } else { self.predict(&state) };
            let innovation = column[t - 1] - readout(t, &prediction);
            let gain = &schedule.gains[step(t)];
            state = std::array::from_fn(|i| prediction[i] + gain[i] * innovation);
            column[t - 1] = readout(t, &state);
            if smooth {
                filtered[t - 1] = state;
                predicted[t - 1] = prediction;
            }
        }
        if smooth {
            let mut smoothed = state;
            for t in (1..height).rev() {
                let jt = &schedule.smoothers[step(t)];
                let diff: [f64; MAX_ROW_ORDER] =
                    std::array::from_fn(|i| smoothed[i] - predicted[t][i]);
                smoothed = std::array::from_fn(|i| {
                    filtered[t - 1][i] + (0..n).map(|k| jt[(i, k)] * diff[k]).sum::<f64>()
                });
                column[t - 1] = readout(t, &smoothed);
            }
        }
    }

    #[inline(always)]
    fn predict(&self, state: &[f64; MAX_ROW_ORDER]) -> [f64; MAX_ROW_ORDER] {
        let (n, s) = (self.dynamics.order, &self.dynamics.transition);
        std::array::from_fn(|i| (0..n).map(|k| s[(i, k)] * state[k]).sum())
    }

    /// Per-pixel error variance (row-major height × width) of the filter (`smooth` = false) or
    /// of the RTS smoother: diag of U P Uᵀ for the observed component of every row (the
    /// smoother's modes with σ_θ²/v_j ≤ [`INFORMATION_RATIO`] in information form, see
    /// `inverse_correlation`).
    pub fn error_variance(&self, height: usize, smooth: bool, out: &mut [f64]) -> Result<()> {
        let w = self.width();
        if out.len() != height * w {
            return Err(FieldError::Shape(format!(
                "the output must hold {height}×{w} values, got {}",
                out.len()
            )));
        }
        if height == 0 {
            return Ok(());
        }
        // modal[j * height + t]: error variance of row t in mode j
        let mut modal = try_zeros(height * w, "the modal error variances")?;
        modal
            .par_chunks_mut(height)
            .enumerate()
            .for_each(|(j, column)| {
                self.mode_error_variances(j, smooth, column);
            });
        matmul(
            MatMut::from_row_major_slice_mut(out, height, w),
            Accum::Replace,
            MatRef::from_column_major_slice(&modal, height, w),
            self.modes.squared_vectors().transpose(),
            1.0,
            Par::rayon(0),
        );
        Ok(())
    }

    fn mode_error_variances(&self, j: usize, smooth: bool, column: &mut [f64]) {
        let ratio = self.noise_var / self.mode_var[j];
        if smooth
            && ratio <= INFORMATION_RATIO
            && self.column.smoothed_variances(ratio, column).is_ok()
        {
            column.iter_mut().for_each(|v| *v *= self.mode_var[j]);
            return;
        }
        let height = column.len();
        // h_tᵀ P h_t: the variance of the row that row t's readout reads
        let variance = |t: usize, p: &StateMatrix| {
            let h = self.dynamics.observation(t);
            h.dot(&(p * h))
        };
        // the smoother reads every step back; the causal map needs the last one only
        let mut history: Vec<ModeCovariance> = Vec::with_capacity(if smooth { height } else { 1 });
        let mut prev = self.dynamics.prior;
        for t in 1..=height {
            let step = self.dynamics.riccati_step(t, &prev, ratio);
            // h_tᵀ P⁺ h_t = q r / (q + r), q = h_tᵀ P h_t: the same value as read off P⁺, but
            // without its cancellation q − q²/(q + r) at r ≪ q (σ_θ² ≲ 1e-16 σ_x², where
            // the map read off P⁺ was wrong by orders of magnitude)
            let q = variance(t, &step.predicted);
            column[t - 1] = q * ratio / (q + ratio);
            if !smooth && t > self.dynamics.order && step.filtered == prev {
                // a fixed point of the (t-independent) step after the start: every later row
                // is the same, bit for bit (a map of 10⁸ rows took minutes)
                let converged = column[t - 1];
                column[t..].fill(converged);
                break;
            }
            prev = step.filtered;
            if smooth {
                history.push(step);
            }
        }
        if smooth {
            let mut smoothed = history[height - 1].filtered;
            for t in (1..height).rev() {
                let jt = self.smoother(t, &history[t - 1].filtered, &history[t].predicted);
                smoothed = history[t - 1].filtered
                    + jt * (smoothed - history[t].predicted) * jt.transpose();
                column[t - 1] = variance(t, &smoothed);
            }
        }
        column.iter_mut().for_each(|v| *v *= self.mode_var[j]);
    }
}

fn max_change(old: &[[f64; MAX_ROW_ORDER]], new: &[[f64; MAX_ROW_ORDER]]) -> f64 {
    old.iter()
        .zip(new)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0, f64::max)
}
