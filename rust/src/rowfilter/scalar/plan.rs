//! The plan of a filter for a height: per row, the model precision Λ_t fitted to the
//! optimal filter's prediction error and the factor of the row's system A_t, refitted row by
//! row until the band of P_e settles.

use super::settling::{band_change, drift_scale, Settling, SETTLE_TOLERANCE};
use super::ScalarRowFilter;
use crate::error::{FieldError, Result};
use crate::linalg::{BandCholesky, SymmetricBand};
use crate::rowfilter::StateMatrix;
use faer::Mat;
use std::sync::Arc;

/// A band of blocks, lag by lag: `lags[d]` holds the n × n blocks Cov(v_ℓ, v_{ℓ+d}) of
/// ℓ = 0..W − d, row-major, one after the other (entry (ℓ, a, b) at ℓ n² + a n + b).
pub(super) type Lags = Vec<Vec<f64>>;

/// The band blocks of `ScalarRowFilter::band` (lag d: row ℓ, column a n + b) as [`Lags`].
pub(super) fn lags_of(blocks: &[Mat<f64>], n: usize) -> Lags {
    blocks
        .iter()
        .map(|lag| {
            let mut flat = Vec::with_capacity(lag.nrows() * n * n);
            for ell in 0..lag.nrows() {
                flat.extend((0..n * n).map(|ab| lag[(ell, ab)]));
            }
            flat
        })
        .collect()
}

/// The most row models (Λ_t and its factor) a plan fits after the start rows; the last one
/// then serves the rows below (slowly settling Riccatis, ρ ≥ 0.99, drift by more than the
/// tolerance for hundreds of rows). Very wide rows get fewer (`ScalarRowFilter::max_models`).
pub(super) const MAX_ROW_MODELS: usize = 64;

/// The memory the row models of a plan may take before very wide rows get fewer of them
/// (at least [`MIN_ROW_MODELS`]): 64 models of (4,4) fit up to W ≈ 5200.
pub(super) const ROW_MODELS_BYTES: usize = 1 << 30;

/// The fewest row models a plan may fit whatever the width (the grid needs ≤ 55).
pub(super) const MIN_ROW_MODELS: usize = 16;

/// Per row: the model precision Λ_t and the factor of A_t (indices into the stores).
#[derive(Debug)]
pub(super) struct Plan {
    pub(super) rows: usize,
    pub(super) settled: bool,
    pub(super) precisions: Vec<SymmetricBand>,
    pub(super) factors: Vec<BandCholesky>,
    pub(super) row_precision: Vec<usize>,
    pub(super) row_factor: Vec<usize>,
    /// The band of the one-row prediction's Q (`innovation_blocks`), for the weighted rows.
    pub(super) innovation: Lags,
}

impl Plan {
    pub(super) fn precision(&self, t: usize) -> &SymmetricBand {
        &self.precisions[self.row_precision[t.min(self.rows) - 1]]
    }

    pub(super) fn factor(&self, t: usize) -> &BandCholesky {
        &self.factors[self.row_factor[t.min(self.rows) - 1]]
    }
}

impl ScalarRowFilter {
    /// `start_systems` for the stationary prior (the band of row 1's prediction error). At
    /// σ_θ² ≲ 1e-16 σ_x² with n_y ≥ 3 the start rows' systems, Λ + Σ h hᵀ/σ_θ² with h dense
    /// rows of L, lose the Schur complements of their σ_θ⁻² terms in float64 and do not
    /// factor: refused here, with the way out (`sigma`: σ_x, for the message).
    pub(super) fn stationary_start(
        &self,
        sigma: f64,
    ) -> Result<(SymmetricBand, Vec<BandCholesky>)> {
        let modal = self
            .whitened
            .prediction_errors(self.noise_var, &self.mode_var)
            .next()
            .map(|(_, modal)| modal)
            .unwrap_or_default();
        self.start_systems(&self.band(&modal)).map_err(|e| {
            FieldError::InvalidParameter(format!(
                "ScalarRowFilter with n_y = {} at noise_var/σ² = {:.2e}: the start rows' \
                 systems do not factor in float64 ({e}); noise_var is too small for this \
                 filter (VectorRowFilter handles it)",
                self.dynamics.order,
                self.noise_var / (sigma * sigma)
            ))
        })
    }

    pub(super) fn plan(&self, height: usize) -> Result<Arc<Plan>> {
        let mut cached = self.plan.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(plan) = cached.as_ref() {
            if plan.settled || plan.rows >= height {
                return Ok(plan.clone());
            }
        }
        let plan = Arc::new(self.build_plan(height)?);
        *cached = Some(plan.clone());
        Ok(plan)
    }

    /// Band blocks C_d[ℓ] of Σ_j u_j u_jᵀ ⊗ M_j, d = 0..=m (see `RowModes::band`).
    pub(super) fn band(&self, modal: &[StateMatrix]) -> Vec<Mat<f64>> {
        self.modes.band(modal, self.dynamics.order, self.ar_order)
    }

    /// The band blocks (as `band`) of Q = σ² R_x ⊗ (I − S Sᵀ), the covariance the prediction
    /// of one row adds in the whitened basis (stationary state covariance σ² R_x ⊗ I).
    pub(super) fn innovation_blocks(&self) -> Vec<Mat<f64>> {
        let n = self.dynamics.order;
        let mut unit = StateMatrix::zeros();
        unit.view_mut((0, 0), (n, n)).fill_with_identity();
        let added = unit - self.whitened.transition * self.whitened.transition.transpose();
        let modal: Vec<StateMatrix> = self.mode_var.iter().map(|v| added * *v).collect();
        self.band(&modal)
    }

    /// [`MAX_ROW_MODELS`], or fewer for rows so wide that their models would take more than
    /// [`ROW_MODELS_BYTES`] (each ~5 W n_y (b + 1) doubles: Λ, the factor and its
    /// substitution tables), but at least [`MIN_ROW_MODELS`].
    pub(super) fn max_models(&self) -> usize {
        let doubles = 5 * self.width() * self.dynamics.order * (self.bandwidth() + 1);
        (ROW_MODELS_BYTES / (8 * doubles)).clamp(MIN_ROW_MODELS, MAX_ROW_MODELS)
    }

    pub(super) fn build_plan(&self, height: usize) -> Result<Plan> {
        let n = self.dynamics.order;
        // the band of Q: the scale of the bands' drift and the weighted rows' prediction
        let innovation = self.innovation_blocks();
        let mut plan = Plan {
            rows: 0,
            settled: false,
            precisions: Vec::new(),
            factors: Vec::new(),
            row_precision: Vec::new(),
            row_factor: Vec::new(),
            innovation: lags_of(&innovation, n),
        };
        // the band the current model was fitted to, the previous row's, and its change
        let mut fitted: Option<Vec<Mat<f64>>> = None;
        let mut previous_band: Option<Vec<Mat<f64>>> = None;
        let mut settling = Settling::default();
        for (t, modal) in self
            .whitened
            .prediction_errors(self.noise_var, &self.mode_var)
            .take(height)
        {
            if t <= n {
                if t == 1 {
                    let (prior, factors) = match &self.start {
                        Some(start) => start.clone(),
                        None => self.start_systems(&self.band(&modal))?,
                    };
                    plan.precisions.push(prior);
                    plan.factors = factors;
                }
                plan.row_precision.push(0);
                plan.row_factor.push(t - 1);
            } else {
                let band = self.band(&modal);
                let scale = drift_scale(&band, &innovation);
                let drifted = fitted
                    .as_ref()
                    .is_none_or(|old| band_change(&band, old) > SETTLE_TOLERANCE * scale);
                if drifted {
                    match self.row_system(&band) {
                        Ok((precision, factor)) => {
                            plan.factors.push(factor);
                            plan.precisions.push(precision);
                            fitted = Some(band.clone());
                            // (precisions[0] is the start's prior)
                            plan.settled |= plan.precisions.len() > self.max_models();
                        }
                        // a later row's fit beyond float64 (n_y = 4 near ρ = 1): the model
                        // stays the last sound one
                        Err(_) if fitted.is_some() => plan.settled = true,
                        Err(e) => return Err(e),
                    }
                }
                if let Some(old) = &previous_band {
                    let change = band_change(&band, old) / scale;
                    plan.settled |= settling.settled_after(change, SETTLE_TOLERANCE);
                }
                previous_band = Some(band);
                plan.row_precision.push(plan.precisions.len() - 1);
                plan.row_factor.push(plan.factors.len() - 1);
            }
            plan.rows = t;
            if plan.settled {
                break;
            }
        }
        Ok(plan)
    }
}
