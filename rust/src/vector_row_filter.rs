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

use crate::column_precision::{ColumnPrecision, INFORMATION_RATIO};
use crate::error::{try_zeros, FieldError, Result};
use crate::field::AxisModel;
use crate::field::AxisModes;
use crate::field::FieldModel;
use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use nalgebra::{Matrix4, Vector4};
use rayon::prelude::*;

/// Highest row multiplicity n_y of the row filters.
pub const MAX_ROW_ORDER: usize = 4;

/// Small row-state matrices (n_y ≤ 4; unused rows and columns are zero).
pub type Small = Matrix4<f64>;

/// The optimal filter for one model, noise variance and row width.
#[derive(Debug, Clone)]
pub struct VectorRowFilter {
    /// The rows' dynamics in their whitened basis (module doc).
    dynamics: RowDynamics,
    /// R_y⁻¹, for the smoothed map of the modes with σ_θ²/v_j ≤ [`INFORMATION_RATIO`].
    column: ColumnPrecision,
    noise_var: f64,
    modes: AxisModes,
    mode_var: Vec<f64>,
}

/// The row-state dynamics of one mode, in units of its variance (SPEC §2.2): in the rows'
/// own basis (`new`), the companion transition of the row axis, the innovation β̃_y² e₀e₀ᵀ,
/// the exact stationary prior R_y[:n,:n] of the first n rows and the identity readout (the
/// quasi-optimal filter's splice check runs there); both row filters run it in the whitened
/// basis (`whitened`).
#[derive(Debug, Clone)]
pub(crate) struct RowDynamics {
    pub(crate) order: usize,
    pub(crate) transition: Small,
    /// Covariance one row's prediction adds.
    pub(crate) innovation: Small,
    pub(crate) prior: Small,
    /// Row i: the observation vector of the image row that state component i holds.
    pub(crate) readout: Small,
    /// The readout's inverse T (v' = T v; the identity in the rows' own basis).
    pub(crate) whitening: Small,
}

/// Per step t (row t+1) and mode j: the gain K (n) and the smoother gain J_t (n×n, linking
/// rows t and t+1); steps past `steps` reuse the last one (the Riccati has converged).
struct Schedule {
    steps: usize,
    gains: Vec<[f64; MAX_ROW_ORDER]>,
    smoothers: Vec<Small>,
}

/// Per-mode covariances of one step: prediction P_e, filtered P.
#[derive(Clone, Copy)]
pub(crate) struct ModeCovariance {
    pub(crate) predicted: Small,
    pub(crate) filtered: Small,
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
            column: ColumnPrecision::new(y, &dynamics.whitening),
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
    fn smoother(&self, t: usize, filtered: &Small, next_predicted: &Small) -> Small {
        if t < self.dynamics.order {
            return Small::identity();
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
            None => Small::zeros(),
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
        let last: Vec<Small> = if settled {
            smoothers[smoothers.len() - w..].to_vec()
        } else {
            vec![Small::identity(); w]
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
    /// `column_precision`).
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
        let variance = |t: usize, p: &Small| {
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

impl RowDynamics {
    /// The dynamics of the row axis `y`.
    pub(crate) fn new(y: &AxisModel) -> Self {
        let order = y.order();
        let mut transition = Small::zeros();
        for (i, a) in y.ar_coefficients().iter().enumerate() {
            transition[(0, i)] = *a;
        }
        for i in 1..order {
            transition[(i, i - 1)] = 1.0;
        }
        let mut prior = Small::zeros();
        for i in 0..order {
            for k in 0..order {
                prior[(i, k)] = y.correlation(i.abs_diff(k) as f64);
            }
        }
        let mut innovation = Small::zeros();
        innovation[(0, 0)] = y.beta_tilde_sq();
        Self {
            order,
            transition,
            innovation,
            prior,
            readout: Small::identity(),
            whitening: Small::identity(),
        }
    }

    /// The same dynamics in the whitened basis v' = T v of the rows (T = L⁻¹, R_y[:n,:n] =
    /// L Lᵀ): prior I, transition T S L, innovation β̃² (T e₀)(T e₀)ᵀ, readout L. Every
    /// quantity is O(1) there, so the covariances stay positive semi-definite where the rows'
    /// basis (R_y[:n,:n] of condition ~3e17 for n_y = 4 at ρ = 0.999) rounds them indefinite.
    /// Error: R_y[:n,:n] does not factor in float64 (n_y = 4 at ρ = 0.9999).
    pub(crate) fn whitened(&self) -> Result<Self> {
        let n = self.order;
        let mut prior = self.prior;
        for i in n..MAX_ROW_ORDER {
            prior[(i, i)] = 1.0;
        }
        let lower = prior.cholesky().map(|c| c.l()).ok_or_else(|| {
            FieldError::InvalidParameter("the row correlation is not positive definite".into())
        })?;
        // a triangular solve, not a general 4×4 inverse: R_y[:n,:n] is ill-conditioned
        // (condition ~5e9 for n = 4, ρ = 0.95)
        let whitening = lower
            .solve_lower_triangular(&Small::identity())
            .ok_or_else(|| {
                FieldError::InvalidParameter("the row correlation is singular".into())
            })?;
        let mut identity = Small::zeros();
        identity.view_mut((0, 0), (n, n)).fill_with_identity();
        let t0 = whitening.column(0).into_owned();
        Ok(Self {
            order: n,
            transition: whitening * self.transition * lower,
            innovation: (t0 * t0.transpose()) * self.innovation[(0, 0)],
            prior: identity,
            readout: lower,
            whitening,
        })
    }

    /// h_t: the observation vector of row t (1-based), row `observed(t)` of the readout.
    pub(crate) fn observation(&self, t: usize) -> Vector4<f64> {
        self.readout.row(self.observed(t)).transpose()
    }

    /// Index of the state component that row t (1-based) observes.
    pub(crate) fn observed(&self, t: usize) -> usize {
        self.order.saturating_sub(t)
    }

    /// One Riccati step of mode j in units of its variance v_j (so every mode is O(1)): row t
    /// observes h_t = row `observed(t)` of the readout with noise `ratio` = σ_θ² / v_j.
    pub(crate) fn riccati_step(&self, t: usize, previous: &Small, ratio: f64) -> ModeCovariance {
        if self.order == 1 {
            return self.scalar_riccati_step(t, previous[(0, 0)], ratio);
        }
        self.matrix_riccati_step(t, previous, ratio)
    }

    /// [`Self::riccati_step`] on the 4 × 4 matrices, for any state order.
    fn matrix_riccati_step(&self, t: usize, previous: &Small, ratio: f64) -> ModeCovariance {
        let predicted = if t == 1 {
            self.prior
        } else if t <= self.order {
            *previous
        } else {
            let p = self.transition * previous * self.transition.transpose() + self.innovation;
            (p + p.transpose()) * 0.5
        };
        let h = self.observation(t);
        // P − c cᵀ / s (c = P h) keeps P exactly symmetric; the row-times-column form drifted
        // apart by rounding and made P_e indefinite for ill-conditioned modes (ρ ≥ 0.99).
        let c = predicted * h;
        let filtered = predicted - (c * c.transpose()) / (h.dot(&c) + ratio);
        ModeCovariance {
            predicted,
            filtered,
        }
    }

    /// [`Self::riccati_step`] of a one-row state (n_y = 1) on the (0, 0) entries, the only
    /// non-zero ones (a plan walks thousands of modes per row); the update as p r / (h² p + r),
    /// which keeps its digits where p − (hp)²/(h² p + r) cancels (r ≪ p: σ_θ² ≲ 1e-16 σ_x²).
    fn scalar_riccati_step(&self, t: usize, previous: f64, ratio: f64) -> ModeCovariance {
        let (a, h) = (self.transition[(0, 0)], self.readout[(0, 0)]);
        let p = if t == 1 {
            self.prior[(0, 0)]
        } else {
            a * previous * a + self.innovation[(0, 0)]
        };
        let c = p * h;
        let mut predicted = Small::zeros();
        let mut filtered = Small::zeros();
        predicted[(0, 0)] = p;
        filtered[(0, 0)] = p * ratio / (h * c + ratio);
        ModeCovariance {
            predicted,
            filtered,
        }
    }

    /// (t, P_e,t per mode) of the modal Riccati for the mode variances `var` and noise
    /// variance `noise_var` (SPEC §2.2 [P 3.29, 3.30]), rows t = 1, 2, ….
    pub(crate) fn prediction_errors<'a>(
        &'a self,
        noise_var: f64,
        var: &'a [f64],
    ) -> impl Iterator<Item = (usize, Vec<Small>)> + 'a {
        let ratios: Vec<f64> = var.iter().map(|v| noise_var / v).collect();
        let start = ModeCovariance {
            predicted: self.prior,
            filtered: self.prior,
        };
        let mut current = vec![start; var.len()];
        (1..).map(move |t| {
            for (mode, ratio) in current.iter_mut().zip(&ratios) {
                *mode = self.riccati_step(t, &mode.filtered, *ratio);
            }
            let modal = current.iter().zip(var).map(|(c, v)| c.predicted * *v);
            (t, modal.collect())
        })
    }
}

fn max_change(old: &[[f64; MAX_ROW_ORDER]], new: &[[f64; MAX_ROW_ORDER]]) -> f64 {
    old.iter()
        .zip(new)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0, f64::max)
}

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
pub fn row_axes(model: &FieldModel) -> Result<(&AxisModel, &AxisModel)> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_one_row_riccati_step_is_the_matrix_one_and_keeps_its_digits_at_high_snr() {
        let axis = AxisModel::new(0.95, 1).unwrap();
        for dynamics in [
            RowDynamics::new(&axis),
            RowDynamics::new(&axis).whitened().unwrap(),
        ] {
            let (mut scalar, mut matrix) = (dynamics.prior, dynamics.prior);
            for t in 1..=6 {
                let s = dynamics.riccati_step(t, &scalar, 0.3);
                let m = dynamics.matrix_riccati_step(t, &matrix, 0.3);
                assert!((s.predicted - m.predicted).abs().max() < 1e-15);
                assert!((s.filtered - m.filtered).abs().max() < 1e-15);
                assert_eq!(s.filtered.abs().sum(), s.filtered[(0, 0)].abs());
                (scalar, matrix) = (s.filtered, m.filtered);
            }
            // r ≪ p: the filtered variance is r (1 − r/p + …), where p − p²/(p + r) is 0
            let step = dynamics.riccati_step(3, &scalar, 1e-30);
            let want = 1e-30 / (1.0 + 1e-30 / step.predicted[(0, 0)]);
            assert!((step.filtered[(0, 0)] / want - 1.0).abs() < 1e-14);
        }
    }
}
