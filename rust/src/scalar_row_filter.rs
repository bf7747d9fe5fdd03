//! The quasi-optimal row filter (SPEC §2.3 generalised): O(width) work per row.
//!
//! SPEC §2.3 replaces the optimal update (a Wiener estimate of the prediction error from the
//! innovation) by a Kalman filter + smoother along the row with an AR model of the
//! prediction error fitted to the optimal P_e. Generalised here so that it stays within ~2 %
//! of the optimal filter for every multiplicity:
//! (a) the modelled vector at column ℓ is the prediction error of *all* n_y rows of the state
//!     (whitened by T = chol(R_y[:n,:n])⁻¹), so older rows are corrected too;
//! (b) it follows a block AR(m) along the row, m = max(n_x, 2) by default, fitted to the band of
//!     P_e ([P 3.11, 3.12, 3.34–3.36]: Γ_ℓ = C_{ℓ,past} C_{past,past}⁻¹, D_ℓ = C_ℓℓ − Γ_ℓ C_{past,ℓ});
//! (c) its precision Λ = Lᵀ D⁻¹ L is banded (half-bandwidth b = n(m+1) − 1), so the filter +
//!     smoother along the row is one banded SPD solve with A = Λ + HᵀH/σ_θ² (Cholesky
//!     precomputed): ŷ_k = ŷ_e + A⁻¹ (y ⊗ e₀)/σ_θ².
//! The model is refitted row by row to the optimal filter's P_e,k (modal Riccati of
//! `vector_row_filter`) until its band changes by < 1e-3, then frozen. In the interior of a
//! row the columns' fits differ by rounding only; there Λ takes the middle column's term
//! (exactly periodic, see `precision`). The start (rows 1..n) is the information form with
//! the exact stationary prior. The RTS pass over the rows uses P_k ≈ A_k⁻¹,
//! P_e,k+1⁻¹ ≈ Λ_{k+1}; the product by Λ_{k+1} comes from what the passes already solved
//! (`smooth_row`), so the pass costs one solve per row.
//! The band of P_e comes from the modes of `row_modes`: the exact eigenbasis of the row, the
//! Fourier modes of the infinite row (no O(W³) step), or both spliced (exact ends of a
//! W'-point row, Fourier interior; W' chosen here by `ends_modes`).
//! Per-pixel noise variances (and missing pixels, weight 0) enter A_k: the weighted variant
//! refactors A_k = Λ_k + Σ_ℓ h hᵀ/σ²_θ,kℓ row by row, and from the first row whose weights
//! depart from the nominal ones Λ_k is refitted to the filter's own prediction covariance
//! (`propagated_models`; `RowModels::Nominal` keeps the plan's).

use crate::error::{try_zeros, FieldError, Result};
use crate::field::AxisModel;
use crate::field::FieldModel;
use crate::linalg::{BandCholesky, BandLdlBatch, SymmetricBand, LDL_LANES as LANES};
use crate::row_columns::{self as columns, for_order, Nominal, PerPixel, RtsRow};
use crate::row_modes::{Fourier, ModeSet, RowModes, SPLICE_TOLERANCE};
use crate::simd::{self, Arith, Kernel};
use crate::vector_row_filter::{
    all_in_range, check_sizes, out_of_range_pixels, pixel_in_range, RowDynamics, Small,
};
use faer::Mat;
use nalgebra::DMatrix;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::{Arc, Mutex};

mod propagated_models;

use propagated_models::Propagation;

/// One run of the filter: the plan, the image (row-major height × W), its per-pixel
/// 1/σ_θ² (None: nominal) and whether the RTS pass follows.
#[derive(Clone, Copy)]
struct Job<'a> {
    plan: &'a Plan,
    z: &'a [f64],
    weights: Option<&'a [f64]>,
    height: usize,
    smooth: bool,
}

/// The passes of one run into `out`, a [`Kernel`] of `simd::dispatch` (the per-column
/// loops run four columns per instruction where AVX2 runs).
struct Passes<'a> {
    filter: &'a ScalarRowFilter,
    job: Job<'a>,
    out: &'a mut [f64],
}

impl Kernel for Passes<'_> {
    type Output = Result<()>;
    #[inline(always)]
    fn run<A: Arith>(self) -> Result<()> {
        self.filter.passes(self.job, self.out)
    }
}

/// Drift of the band from the one the row model was fitted to (relative to `drift_scale`)
/// beyond which the model is refitted, and the tolerance within which the band must have
/// settled (`settled`) for the model to be frozen.
const SETTLE_TOLERANCE: f64 = 1e-3;
/// The most the ratio of successive changes may rise from one row to the next for their
/// geometric tail to be trusted (`settled`).
const RATIO_RISE: f64 = 0.05;
/// Largest order m of the block AR model along the row.
pub const MAX_AR_ORDER: usize = 8;
/// The drift scale (`drift_scale`) is at least this fraction of the band's largest entry, so
/// the band's rounding stays far below the refit tolerance.
const DRIFT_FLOOR: f64 = 1e-9;
/// The most row models (Λ_t and its factor) a plan fits after the start rows; the last one
/// then serves the rows below (slowly settling Riccatis, ρ ≥ 0.99, drift by more than the
/// tolerance for hundreds of rows). Very wide rows get fewer (`ScalarRowFilter::max_models`).
const MAX_ROW_MODELS: usize = 64;
/// The memory the row models of a plan may take before very wide rows get fewer of them
/// (at least [`MIN_ROW_MODELS`]): 64 models of (4,4) fit up to W ≈ 5200.
const ROW_MODELS_BYTES: usize = 1 << 30;
/// The fewest row models a plan may fit whatever the width (the grid needs ≤ 55).
const MIN_ROW_MODELS: usize = 16;
/// How far above the estimated rounding floor of the band a splice defect may lie: the
/// exact band sums W' modes against the second quadrature's few hundred, and its scatter was
/// measured at 3–7× the estimate (n_y = 4, ρ = 0.95), with the splice itself converged.
const FLOOR_FACTOR: f64 = 8.0;
/// Most rows the splice check walks (the Riccati settles within a few hundred).
const MAX_SETTLE_ROWS: usize = 100_000;
/// Largest entry difference, relative to the largest entry, within which a column's term of
/// Λ is replaced by the middle column's (see `ScalarRowFilter::precision`): above the
/// rounding scatter of the interior columns' fits (~1e-10 for n_y = 3; ~5e-8 for n_y = 4 at
/// ρ = 0.9, ~6e-6 at ρ = 0.95), below the edge effects that matter.
const INTERIOR_TOLERANCE: f64 = 1e-5;
/// Jitters ε (relative to the largest variance of a column's joint covariance with its
/// past), smallest first, of the square-root fit that replaces a row model whose systems
/// cannot be factored in float64 (`ScalarRowFilter::sound_systems`): near ρ = 1 the
/// innovation variance D of an AR(n_x) fit along the row falls to the rounding of the band
/// (~6e-15 of the variance for n_x = 3 at ρ = 0.999), and D⁻¹ is then rounding noise.
const JITTERS: [f64; 8] = [0.0, 1e-15, 1e-14, 1e-13, 1e-12, 1e-11, 1e-10, 1e-9];

/// Where the row models Λ_t of an image with per-pixel weights (missing pixels, noise maps)
/// come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowModels {
    /// Refitted row by row to the prediction covariance the weighted systems imply
    /// (`propagated_models`): near the exact posterior whatever the weights.
    Propagated,
    /// The plan's models, fitted for every pixel observed at the nominal σ_θ² (O(W) less
    /// work per row; unfit below missing or much noisier pixels at high SNR).
    Nominal,
    /// Propagated from the first predicted row on, for every image, the nominal ones too:
    /// each Λ_t fitted to the covariance the filter itself implies, so every RTS step pairs
    /// consistent models. It removes the loss of the plan's models near a unit root at high
    /// SNR ((3,3), ρ_y = 0.9997, σ_θ²/σ_x² = 0.01, 32²: +1.1 % causal, +5.4 % smoothed; (2,2)
    /// at ρ = 0.99979, 21 × 4: +19 %, +95 %), at the propagated rows' cost on every image.
    Implied,
}

impl RowModels {
    /// Whether the weighted rows' models are propagated (not the plan's).
    fn propagates(self) -> bool {
        self != RowModels::Nominal
    }
}

/// The quasi-optimal filter for one model, noise variance, width and AR order m.
#[derive(Debug)]
pub struct ScalarRowFilter {
    dynamics: RowDynamics,
    modes: RowModes,
    mode_var: Vec<f64>,
    ar_order: usize,
    noise_var: f64,
    /// The rows' dynamics in the whitened basis (`RowDynamics::whitened`): its transition
    /// T S L is the prediction's, its readout L (`lower`) reads the image rows out of the
    /// state.
    whitened: RowDynamics,
    row_models: RowModels,
    /// The start's prior Λ and the factors of the start rows' systems (`start_systems`):
    /// the same for every height, made by `new` so that a noise variance too small for them
    /// is refused there (None only inside `new`, before the row's modes are chosen).
    start: Option<(SymmetricBand, Vec<BandCholesky>)>,
    plan: Mutex<Option<Arc<Plan>>>,
}

/// Per row: the model precision Λ_t and the factor of A_t (indices into the stores).
#[derive(Debug)]
struct Plan {
    rows: usize,
    settled: bool,
    precisions: Vec<SymmetricBand>,
    factors: Vec<BandCholesky>,
    row_precision: Vec<usize>,
    row_factor: Vec<usize>,
    /// The band of the one-row prediction's Q (`innovation_blocks`), for the weighted rows.
    innovation: propagated_models::Lags,
}

impl Plan {
    fn precision(&self, t: usize) -> &SymmetricBand {
        &self.precisions[self.row_precision[t.min(self.rows) - 1]]
    }

    fn factor(&self, t: usize) -> &BandCholesky {
        &self.factors[self.row_factor[t.min(self.rows) - 1]]
    }
}

impl ScalarRowFilter {
    /// The filter of a 2-axis `model`; `ar_order` = m (None: [`default_ar_order`]); `modes`:
    /// where the band of P_e comes from (`row_modes`; `Ends` picks its W' here, `ends_modes`).
    pub fn new(
        model: &FieldModel,
        noise_var: f64,
        width: usize,
        ar_order: Option<usize>,
        modes: ModeSet,
    ) -> Result<Self> {
        let (y, x) = crate::vector_row_filter::row_axes(model)?;
        crate::error::check_noise_var(noise_var)?;
        if width == 0 {
            return Err(FieldError::Shape("width must be positive".into()));
        }
        let ar_order = ar_order.unwrap_or(default_ar_order(y.order(), x.order()));
        if ar_order == 0 || ar_order > MAX_AR_ORDER {
            return Err(FieldError::InvalidParameter(format!(
                "ar_order must lie in 1..={MAX_AR_ORDER}, got {ar_order}"
            )));
        }
        let dynamics = RowDynamics::new(y);
        let whitened = dynamics.whitened()?;
        let chosen = match modes {
            ModeSet::Exact => RowModes::exact(x, width)?,
            // provisional: the Fourier modes carry the width until `ends_modes` has chosen
            ModeSet::Ends | ModeSet::Toeplitz => RowModes::toeplitz(x, width),
        };
        let mut filter = Self {
            whitened,
            dynamics,
            mode_var: Vec::new(),
            modes: chosen,
            ar_order,
            noise_var,
            row_models: RowModels::Propagated,
            start: None,
            plan: Mutex::new(None),
        };
        if modes == ModeSet::Ends {
            filter.modes = filter.ends_modes(x, model.sigma())?;
        }
        filter.mode_var = variances(filter.modes.values(), model.sigma());
        filter.start = Some(filter.stationary_start(model.sigma())?);
        Ok(filter)
    }

    /// `start_systems` for the stationary prior (the band of row 1's prediction error). At
    /// σ_θ² ≲ 1e-16 σ_x² with n_y ≥ 3 the start rows' systems, Λ + Σ h hᵀ/σ_θ² with h dense
    /// rows of L, lose the Schur complements of their σ_θ⁻² terms in float64 and do not
    /// factor: refused here, with the way out (`sigma`: σ_x, for the message).
    fn stationary_start(&self, sigma: f64) -> Result<(SymmetricBand, Vec<BandCholesky>)> {
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

    /// Chooses where the row models of weighted images come from (default: propagated).
    pub fn with_row_models(mut self, row_models: RowModels) -> Self {
        self.row_models = row_models;
        self
    }

    /// The `Ends` modes for rows of the `x` axis: W' from `RowModes::first_span`, doubled until
    /// the splice holds on every row of the plan (`splice_holds`); the whole row's eigenbasis
    /// when W' would exceed half the row.
    fn ends_modes(&self, x: &AxisModel, sigma: f64) -> Result<RowModes> {
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
    fn splice_holds(&self, modes: &RowModes, x: &AxisModel, sigma: f64) -> bool {
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
        let mut previous: Option<Vec<Small>> = None;
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

    /// W' of the `Ends` modes' exact ends (None: the band has no splice).
    pub fn ends_span(&self) -> Option<usize> {
        self.modes.span()
    }

    /// Row width W.
    pub fn width(&self) -> usize {
        self.modes.width()
    }

    /// L (R_y[:n,:n] = L Lᵀ): row i reads the image row that state component i holds out of
    /// the whitened state.
    fn lower(&self) -> &Small {
        &self.whitened.readout
    }

    /// Half-bandwidth b = n(m+1) − 1 of the row systems.
    pub fn bandwidth(&self) -> usize {
        self.dynamics.order * (self.ar_order + 1) - 1
    }

    fn plan(&self, height: usize) -> Result<Arc<Plan>> {
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
    fn band(&self, modal: &[Small]) -> Vec<Mat<f64>> {
        self.modes.band(modal, self.dynamics.order, self.ar_order)
    }

    /// The band blocks (as `band`) of Q = σ² R_x ⊗ (I − S Sᵀ), the covariance the prediction
    /// of one row adds in the whitened basis (stationary state covariance σ² R_x ⊗ I).
    fn innovation_blocks(&self) -> Vec<Mat<f64>> {
        let n = self.dynamics.order;
        let mut unit = Small::zeros();
        unit.view_mut((0, 0), (n, n)).fill_with_identity();
        let added = unit - self.whitened.transition * self.whitened.transition.transpose();
        let modal: Vec<Small> = self.mode_var.iter().map(|v| added * *v).collect();
        self.band(&modal)
    }

    fn block(&self, band: &[Mat<f64>], i: usize, j: usize) -> DMatrix<f64> {
        let n = self.dynamics.order;
        let (d, at, transpose) = if i <= j {
            (j - i, i, false)
        } else {
            (i - j, j, true)
        };
        DMatrix::from_fn(n, n, |a, b| {
            let (a, b) = if transpose { (b, a) } else { (a, b) };
            band[d][(at, a * n + b)]
        })
    }

    /// Λ = Lᵀ D⁻¹ L of the block AR(m) model fitted to the band (interleaved (ℓ, i) ↦ ℓn+i).
    /// Where the band is Toeplitz (`RowModes::toeplitz_columns`), every column with a full
    /// past gives the same contribution, so it is computed once (the middle column's). Other
    /// columns: a column with a full past
    /// whose contribution lies within [`INTERIOR_TOLERANCE`] of the middle column's takes
    /// the middle one's: the interior columns' fits differ by rounding only (scattered up
    /// to ~6e-6 for n_y = 4, through the ill-conditioned whitened basis), and an exactly
    /// periodic interior of Λ gives factors that `steady_band` solves fastest. Each term
    /// stays a whole fit (Bᵀ D⁻¹ B, positive semi-definite): moving the entries of Γ or D
    /// separately by such amounts wrecks the n_y = 4 models.
    /// `jitter`: None for the direct fit (`column_contribution`), Some(ε) for the square-root
    /// one (`root_contribution`).
    fn precision(&self, band: &[Mat<f64>], jitter: Option<f64>) -> Result<SymmetricBand> {
        let (w, n, m) = (self.width(), self.dynamics.order, self.ar_order);
        let mut out = SymmetricBand::zeros(w * n, self.bandwidth());
        // columns with a full past that reaches a Toeplitz row (`Ends`: also those whose past
        // straddles the splice) take the Toeplitz fit, the middle column's term: a fit mixing
        // the two sources, which differ by their rounding (~1e-9 for n_y = 4), can be
        // indefinite
        let toeplitz = self.modes.toeplitz_columns();
        let steady = |ell: usize| ell >= m.max(toeplitz.start) && ell < toeplitz.end + m;
        let central = if w / 2 < m {
            None
        } else {
            Some(self.contribution(band, w / 2, jitter)?)
        };
        for ell in 0..w {
            let k = ell.min(m);
            let computed;
            let q = match &central {
                Some(c) if steady(ell) => c,
                _ => {
                    computed = self.contribution(band, ell, jitter)?;
                    match &central {
                        Some(c) if k == m && is_settled(&computed, c) => c,
                        _ => &computed,
                    }
                }
            };
            // columns ℓ, ℓ − 1, …, ℓ − k of the contribution, each n wide
            let column = |p: usize, r: usize| (ell - p) * n + r;
            for p in 0..=k {
                for q_col in 0..=k {
                    for r in 0..n {
                        for c in 0..n {
                            let (gi, gk) = (column(p, r), column(q_col, c));
                            if gi >= gk {
                                out.add(gi, gk, q[(p * n + r, q_col * n + c)]);
                            }
                        }
                    }
                }
            }
        }
        Ok(out)
    }

    fn contribution(
        &self,
        band: &[Mat<f64>],
        ell: usize,
        jitter: Option<f64>,
    ) -> Result<DMatrix<f64>> {
        match jitter {
            None => self.column_contribution(band, ell),
            Some(epsilon) => self.root_contribution(band, ell, epsilon),
        }
    }

    /// The past columns of column ℓ, newest first: ℓ − 1, …, ℓ − min(ℓ, m).
    fn past(&self, ell: usize) -> Vec<usize> {
        (ell.saturating_sub(self.ar_order)..ell).rev().collect()
    }

    /// Column ℓ's term of Λ in square-root form: C = L Lᵀ, C the joint covariance of the
    /// past ℓ − k, …, ℓ − 1 and column ℓ (in that order) plus ε max_i C_ii I; the last n_y
    /// rows of L⁻¹ are G = L_ℓℓ⁻¹ [−Γ_ℓ, I] with D = L_ℓℓ L_ℓℓᵀ (the fit of
    /// `column_contribution` to the jittered C), so the term Bᵀ D⁻¹ B = GᵀG is positive
    /// semi-definite whatever the rounding ([P 3.34–3.36] by the inverse Cholesky factor).
    fn root_contribution(
        &self,
        band: &[Mat<f64>],
        ell: usize,
        epsilon: f64,
    ) -> Result<DMatrix<f64>> {
        let n = self.dynamics.order;
        // joint order: past (oldest first), then ℓ; the term is returned in (ℓ, ℓ − 1, …)
        let mut columns = self.past(ell);
        columns.reverse();
        columns.push(ell);
        let size = columns.len() * n;
        let mut joint = DMatrix::from_fn(size, size, |r, c| {
            self.block(band, columns[r / n], columns[c / n])[(r % n, c % n)]
        });
        joint = (&joint + joint.transpose()) * 0.5;
        let top = joint.diagonal().max();
        for i in 0..size {
            joint[(i, i)] += epsilon * top;
        }
        let lower = joint.cholesky().ok_or_else(singular_model)?.l();
        let inverse = lower
            .solve_lower_triangular(&DMatrix::identity(size, size))
            .ok_or_else(singular_model)?;
        let rows = inverse.rows(size - n, n);
        // reorder the columns to (ℓ, ℓ − 1, …, ℓ − k)
        let k = columns.len() - 1;
        let g = DMatrix::from_fn(n, size, |r, c| {
            let (block, i) = (c / n, c % n);
            rows[(r, (k - block) * n + i)]
        });
        Ok(g.transpose() * g)
    }

    /// Column ℓ's term Bᵀ D⁻¹ B of Λ, B = [I, −Γ_ℓ] over the columns ℓ, ℓ − 1, …, ℓ − k
    /// (k = min(ℓ, m)): Γ_ℓ = C_{ℓ,past} C_{past,past}⁻¹, D = C_ℓℓ − Γ_ℓ C_{past,ℓ}
    /// ([P 3.11, 3.12, 3.34–3.36]).
    fn column_contribution(&self, band: &[Mat<f64>], ell: usize) -> Result<DMatrix<f64>> {
        let n = self.dynamics.order;
        let past = self.past(ell);
        let k = past.len();
        let mut b = DMatrix::<f64>::zeros(n, (k + 1) * n);
        b.view_mut((0, 0), (n, n)).fill_with_identity();
        let mut noise = self.block(band, ell, ell);
        if k > 0 {
            let cpp = DMatrix::from_fn(k * n, k * n, |r, c| {
                self.block(band, past[r / n], past[c / n])[(r % n, c % n)]
            });
            let clp = DMatrix::from_fn(n, k * n, |r, c| {
                self.block(band, ell, past[c / n])[(r, c % n)]
            });
            let gamma_t = cpp
                .clone()
                .cholesky()
                .map(|ch| ch.solve(&clp.transpose()))
                .or_else(|| cpp.lu().solve(&clp.transpose()))
                .ok_or_else(singular_model)?;
            let gamma = gamma_t.transpose();
            noise -= &gamma * clp.transpose();
            b.view_mut((0, n), (n, k * n)).copy_from(&(-gamma));
        }
        let noise = (&noise + noise.transpose()) * 0.5;
        // by its Cholesky factor: nalgebra's try_inverse takes the cofactor formula for
        // n ≤ 4, which loses every digit at D's condition (~1e8 for n_y = 4 at high SNR:
        // an indefinite D⁻¹, a negative diagonal of Λ and "not positive definite")
        let inverse = noise
            .clone()
            .cholesky()
            .map(|c| c.inverse())
            .or_else(|| noise.lu().try_inverse())
            .ok_or_else(singular_model)?;
        Ok(b.transpose() * inverse * b)
    }

    /// [`MAX_ROW_MODELS`], or fewer for rows so wide that their models would take more than
    /// [`ROW_MODELS_BYTES`] (each ~5 W n_y (b + 1) doubles: Λ, the factor and its
    /// substitution tables), but at least [`MIN_ROW_MODELS`].
    fn max_models(&self) -> usize {
        let doubles = 5 * self.width() * self.dynamics.order * (self.bandwidth() + 1);
        (ROW_MODELS_BYTES / (8 * doubles)).clamp(MIN_ROW_MODELS, MAX_ROW_MODELS)
    }

    /// Λ fitted to a prediction row's band and the factor of its system (row 0 observed).
    fn row_system(&self, band: &[Mat<f64>]) -> Result<(SymmetricBand, BandCholesky)> {
        let (precision, mut factors) = self.sound_systems(band, &[vec![0]])?;
        Ok((precision, factors.remove(0)))
    }

    /// The start's prior Λ (the stationary one, fitted to the first band) and the factors of
    /// the start rows' systems, row t ≤ n_y observing the state rows n_y − 1, …, n_y − t.
    fn start_systems(&self, band: &[Mat<f64>]) -> Result<(SymmetricBand, Vec<BandCholesky>)> {
        let n = self.dynamics.order;
        let observed: Vec<Vec<usize>> = (1..=n).map(|t| (1..=t).map(|i| n - i).collect()).collect();
        self.sound_systems(band, &observed)
    }

    /// Λ fitted to `band` and the factors of its systems for each set of `observed` state
    /// rows. If the direct fit or one of its systems fails in float64, the square-root fit
    /// (`root_contribution`) with the smallest jitter of [`JITTERS`] for which Λ itself and
    /// every system factor (so the weighted rows' systems, Λ plus non-negative terms, factor
    /// too); the jitter bounds D from below, i.e. adds a white component of ε times the
    /// variance along the row to the model the filter assumes. Without one that works, the
    /// direct fit's failure is returned.
    fn sound_systems(
        &self,
        band: &[Mat<f64>],
        observed: &[Vec<usize>],
    ) -> Result<(SymmetricBand, Vec<BandCholesky>)> {
        let systems = |p: SymmetricBand| -> Result<(SymmetricBand, Vec<BandCholesky>)> {
            let factors = observed
                .iter()
                .map(|o| self.system(&p, o))
                .collect::<Result<_>>()?;
            Ok((p, factors))
        };
        let failure = match self.precision(band, None).and_then(systems) {
            Ok(found) => return Ok(found),
            Err(e) => e,
        };
        for epsilon in JITTERS {
            let root = self.precision(band, Some(epsilon));
            if let Ok(found) = root.and_then(|p| p.cholesky().and_then(|_| systems(p))) {
                return Ok(found);
            }
        }
        Err(failure)
    }

    /// A = Λ + I_W ⊗ h hᵀ/σ_θ² for each observed row h in `observed`.
    fn system(&self, precision: &SymmetricBand, observed: &[usize]) -> Result<BandCholesky> {
        let mut a = precision.clone();
        for &index in observed {
            self.add_observation(&mut a, index, |_| 1.0 / self.noise_var);
        }
        a.cholesky()
    }

    /// a += Σ_ℓ weight(ℓ) h hᵀ on the block of column ℓ, h = row `index` of L (the observed
    /// row of the state in the whitened basis).
    fn add_observation(&self, a: &mut SymmetricBand, index: usize, weight: impl Fn(usize) -> f64) {
        let n = self.dynamics.order;
        let h = self.lower().row(index);
        for ell in 0..self.width() {
            let r_ell = weight(ell);
            for r in 0..n {
                for c in 0..=r {
                    a.add(ell * n + r, ell * n + c, h[r] * h[c] * r_ell);
                }
            }
        }
    }

    fn build_plan(&self, height: usize) -> Result<Plan> {
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
            innovation: propagated_models::lags_of(&innovation, n),
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

    /// The causal filter's own per-pixel error variance (row-major height × width):
    /// h_tᵀ [A_t⁻¹]_ℓℓ h_t for column ℓ of row t, [·]_ℓℓ the n_y × n_y block of the column's
    /// state (whitened basis) and h_t the row of L that reads the image row out of it (the
    /// start rows t ≤ n_y read row n_y − t, the later ones row 0). A_t⁻¹ is the posterior
    /// covariance the filter assumes (its model Λ_t fitted to the optimal P_e,t): exact for
    /// the start rows, where Λ is the stationary prior's (m ≥ n_x); after them an
    /// approximation of the filter's MSE (measured within −2.7 %…+0.13 % of it, README). The
    /// band of A_t⁻¹ by selected inversion (`band_inverse`), O(W n_y b²) per factor: once per
    /// distinct factor of the plan for the nominal noise (`weights` None), per row (in
    /// parallel) for per-pixel 1/σ_θ² `weights` (0 = missing pixel), the systems the filter
    /// solves for such an image.
    pub fn error_variance(&self, height: usize, weights: Option<&[f64]>) -> Result<Vec<f64>> {
        let w = self.width();
        let implied = self.implied_weights(weights, height * w);
        let weights = weights.or(implied.as_deref());
        if let Some(r) = weights {
            if r.len() != height * w {
                return Err(FieldError::Shape(format!(
                    "the weights must hold {height}×{w} values, got {}",
                    r.len()
                )));
            }
            Self::check_weights(r)?;
        }
        let mut out = try_zeros(height * w, "the error-variance map")?;
        if height == 0 {
            return Ok(out);
        }
        let plan = self.plan(height)?;
        let Some(r) = weights else {
            // each distinct factor inverted once, when a row first uses it
            let mut inverses: Vec<Option<SymmetricBand>> = vec![None; plan.factors.len()];
            for (t, row) in (1..=height).zip(out.chunks_exact_mut(w)) {
                let index = plan.row_factor[t.min(plan.rows) - 1];
                let z = inverses[index].get_or_insert_with(|| plan.factors[index].inverse_band());
                self.read_variances(z, t, row);
            }
            return Ok(out);
        };
        if self.row_models.propagates() {
            let mut propagation = Propagation::new(self, &plan, r)?;
            for row in out.chunks_exact_mut(w) {
                let mut read = |t: usize, z: &SymmetricBand| self.read_variances(z, t, row);
                propagation.next_row(Some(&mut read))?;
            }
            return Ok(out);
        }
        let n = self.dynamics.order;
        out.par_chunks_mut(w)
            .enumerate()
            .try_for_each(|(i, row)| -> Result<()> {
                let t = i + 1;
                let mut a = plan.precision(t).clone();
                let observed = if t > n { t..=t } else { 1..=t };
                for s in observed {
                    let row_weights = &r[(s - 1) * w..s * w];
                    self.add_observation(&mut a, n.saturating_sub(s), |ell| row_weights[ell]);
                }
                self.read_variances(&a.inverse_band()?, t, row);
                Ok(())
            })?;
        Ok(out)
    }

    /// row[ℓ] = h_tᵀ [Z]_ℓℓ h_t for the band Z of A_t⁻¹ (see `error_variance`).
    fn read_variances(&self, z: &SymmetricBand, t: usize, row: &mut [f64]) {
        let n = self.dynamics.order;
        let h = self.readout_row(n.saturating_sub(t));
        for (ell, v) in row.iter_mut().enumerate() {
            let at = ell * n;
            *v = (0..n)
                .map(|r| h[r] * (0..n).map(|c| z.get(at + r, at + c) * h[c]).sum::<f64>())
                .sum();
        }
    }

    /// Filters one image (row-major height × width) into `out`; `smooth` adds the RTS pass.
    /// `weights`: per-pixel 1/σ_θ² (0 = missing pixel, whose value is ignored), same layout as
    /// `z`; None = the filter's own noise variance everywhere.
    pub fn filter_image(
        &self,
        z: &[f64],
        weights: Option<&[f64]>,
        out: &mut [f64],
        height: usize,
        smooth: bool,
    ) -> Result<()> {
        self.check(z, weights, out, height * self.width())?;
        if height == 0 {
            return Ok(());
        }
        let implied = self.implied_weights(weights, z.len());
        let weights = weights.or(implied.as_deref());
        let plan = self.plan(height)?;
        self.run(&plan, z, weights, out, height, smooth)?;
        self.check_estimate(out)
    }

    /// With [`RowModels::Implied`] and no weights: `size` nominal weights 1/σ_θ², so the image
    /// takes the propagated rows (None otherwise: the plan's systems serve).
    fn implied_weights(&self, weights: Option<&[f64]>, size: usize) -> Option<Vec<f64>> {
        (weights.is_none() && self.row_models == RowModels::Implied)
            .then(|| vec![1.0 / self.noise_var; size])
    }

    /// Error when the estimate left float64: pixels far from the mean at a tiny noise ratio
    /// (|z − mean|·σ_x²/σ_θ² beyond ~1e308, e.g. 1e10 at 1e-300) overflow the innovations.
    /// An overflow in any row reaches the last row of the causal pass (the state carries it
    /// down) and the first row of the smoothed one, so those two rows tell.
    fn check_estimate(&self, out: &[f64]) -> Result<()> {
        let w = self.width();
        let ends = [&out[..w], &out[out.len() - w..]];
        if ends.iter().all(|row| row.iter().all(|v| v.is_finite())) {
            return Ok(());
        }
        Err(FieldError::InvalidParameter(
            "the estimate overflowed float64: the pixels lie too far from the mean for this \
             noise ratio (|z − mean|·σ_x²/σ_θ² must stay well inside float64); rescale the \
             image, raise noise_var or use VectorRowFilter"
                .into(),
        ))
    }

    /// Filters `frames` images in parallel (`weights` as in `filter_image`, one map per frame).
    pub fn filter_stack(
        &self,
        z: &[f64],
        weights: Option<&[f64]>,
        out: &mut [f64],
        frames: usize,
        height: usize,
        smooth: bool,
    ) -> Result<()> {
        let size = height * self.width();
        self.check(z, weights, out, frames * size)?;
        if size == 0 {
            return Ok(());
        }
        let plan = self.plan(height)?;
        let implied = self.implied_weights(weights, size);
        out.par_chunks_mut(size)
            .zip(z.par_chunks(size))
            .enumerate()
            .try_for_each(|(k, (o, f))| {
                let frame_weights = match (weights, &implied) {
                    (Some(w), _) => Some(&w[k * size..(k + 1) * size]),
                    (None, Some(uniform)) => Some(&uniform[..]),
                    (None, None) => None,
                };
                self.run(&plan, f, frame_weights, o, height, smooth)?;
                self.check_estimate(o)
            })
    }

    /// Sizes (the values are checked row by row in `run`, while they are in cache).
    fn check(
        &self,
        z: &[f64],
        weights: Option<&[f64]>,
        out: &[f64],
        expected: usize,
    ) -> Result<()> {
        let Some(weights) = weights else {
            return check_sizes(z, out, expected);
        };
        if z.len() != expected || out.len() != expected || weights.len() != expected {
            return Err(FieldError::Shape(format!(
                "the images and weights must hold {expected} values, got {} and {}",
                z.len(),
                weights.len()
            )));
        }
        Ok(())
    }

    /// The weighted rows' values (checked row by row as the filter reaches them, while they
    /// are in cache): weights finite and ≥ 0, pixels in range ([`pixel_in_range`]) where the
    /// weight is > 0.
    fn check_weighted_row(row: &[f64], weights: &[f64]) -> Result<()> {
        Self::check_weights(weights)?;
        let observed_in_range = row
            .iter()
            .zip(weights)
            .fold(true, |ok, (v, w)| ok & (pixel_in_range(*v) | (*w == 0.0)));
        if !observed_in_range {
            return Err(FieldError::NonFinite(
                "a pixel with a finite noise variance is NaN, infinite or beyond ±2^1000 ≈ 1e301"
                    .into(),
            ));
        }
        Ok(())
    }

    /// Per-pixel weights (1/noise variance) finite and ≥ 0.
    fn check_weights(weights: &[f64]) -> Result<()> {
        let valid = weights
            .iter()
            .fold(true, |ok, w| ok & (*w >= 0.0) & w.is_finite());
        if !valid {
            return Err(FieldError::InvalidParameter(
                "the pixel weights (1/noise variance) must be finite and ≥ 0".into(),
            ));
        }
        Ok(())
    }

    /// h = row `index` of L: the readout of the image row held in that state row.
    #[inline(always)]
    fn readout_row(&self, index: usize) -> [f64; 4] {
        let h = self.lower().row(index);
        std::array::from_fn(|a| if a < self.dynamics.order { h[a] } else { 0.0 })
    }

    /// Prediction and innovation in one pass over the columns (`row_columns::predict`):
    /// state_ℓ ← S state_ℓ, gain_in_ℓ = ((z_ℓ − state_ℓ[0]) r_ℓ, 0, …), r_ℓ = 1/σ²_θ,ℓ
    /// (`weights`; None: 1/σ_θ² everywhere). False when `weights` is None and a pixel of the
    /// row is NaN, infinite or beyond ±2^1000 (`pixel_in_range`).
    #[inline(always)]
    fn predict(
        &self,
        state: &mut [f64],
        row: &[f64],
        gain_in: &mut [f64],
        weights: Option<&[f64]>,
    ) -> bool {
        let s = &self.whitened.transition;
        for_order!(self.dynamics.order, |N, K| match weights {
            None => columns::predict::<N, K, _>(s, state, row, gain_in, self.nominal()),
            Some(r) => columns::predict::<N, K, _>(s, state, row, gain_in, PerPixel(r)),
        })
    }

    /// 1/σ_θ² for every pixel.
    fn nominal(&self) -> Nominal {
        Nominal(1.0 / self.noise_var)
    }

    /// The filter's correction of a row after the start: state_ℓ += d_ℓ, and out[ℓ] = the
    /// estimate h · state_ℓ (h = e₀: row 0 of L).
    #[inline(always)]
    fn correct(&self, d: &[f64], state: &mut [f64], out: &mut [f64]) {
        let h = self.readout_row(0);
        for_order!(self.dynamics.order, |N, K| columns::correct::<N, K>(
            d, state, &h, out
        ))
    }

    /// row[ℓ] = h · state_ℓ with h = row `index` of L (the image row held in that state row).
    #[inline(always)]
    fn readout(&self, state: &[f64], index: usize, row: &mut [f64]) {
        let h = self.readout_row(index);
        for_order!(self.dynamics.order, |N, K| columns::readout::<N, K>(
            state, &h, row
        ))
    }

    /// One row t > n of the RTS pass (`row_columns::smooth`): ŷˢ_t = ŷ_t + δ_t, its image row
    /// h · ŷˢ_t = h · ŷ_t + h · δ_t (h · ŷ_t, the filtered row, is all the pass needs of the
    /// forward pass: it is in `out`), and the right-hand side of row t − 1,
    /// d_{t−1} = (I ⊗ Sᵀ) Λ_t (ŷˢ_t − ŷ_e,t), without a product by Λ_t: A_t = Λ_t + Hᵀ R⁻¹ H,
    /// and both the forward gain (A_t (ŷ_t − ŷ_e,t) = Hᵀ R⁻¹ (z_t − H ŷ_e,t)) and this step
    /// (A_t (ŷˢ_t − ŷ_t) = d_t) were solved with A_t's factor, so
    /// Λ_t (ŷˢ_t − ŷ_e,t) = d_t + Hᵀ R⁻¹ (z_t − H ŷˢ_t), H = e₀ per column (rows t > n).
    /// `weights`: row t's (None: nominal).
    #[inline(always)]
    fn smooth_row(&self, weights: Option<&[f64]>, row: RtsRow) {
        let (s, h0) = (&self.whitened.transition, self.lower()[(0, 0)]);
        for_order!(self.dynamics.order, |N, K| match weights {
            None => columns::smooth::<N, K>(s, h0, self.nominal(), row),
            Some(r) => columns::smooth::<N, K>(s, h0, PerPixel(r), row),
        })
    }

    /// Factors the weighted systems A_t of rows t ∈ `rows` (1-based, at most LANES; spare
    /// lanes repeat the last row) into `batch`, one lane per row: Λ_t (`precisions`, by lane)
    /// plus Σ_ℓ w_sℓ h_s h_sᵀ over the rows s observed in the state at t (start rows t ≤ n:
    /// s = 1..t, observed through state row n − s; later rows: s = t, through state row 0).
    /// The rows are checked (`check_weighted_row`) before: the only error is a system that
    /// does not factor.
    fn weighted_factors(
        &self,
        precisions: [&SymmetricBand; LANES],
        rows: Range<usize>,
        weights: &[f64],
        batch: &mut BandLdlBatch,
    ) -> Result<()> {
        let (w, n) = (self.width(), self.dynamics.order);
        let lane_row = |j: usize| (rows.start + j).min(rows.end - 1);
        let mut blocks = vec![[0.0; LANES]; w * n * n];
        for j in 0..LANES {
            let t = lane_row(j);
            let observed = if t > n { t..=t } else { 1..=t };
            for s in observed {
                let at = (s - 1) * w..s * w;
                let h = self.lower().row(n.saturating_sub(s));
                for (block, &r) in blocks.chunks_exact_mut(n * n).zip(&weights[at]) {
                    for a in 0..n {
                        for c in 0..n {
                            block[a * n + c][j] += h[a] * h[c] * r;
                        }
                    }
                }
            }
        }
        batch.factor(precisions, &blocks, n)
    }

    /// The forward pass and, when `smooth`, the RTS pass of one image.
    fn run(
        &self,
        plan: &Plan,
        z: &[f64],
        weights: Option<&[f64]>,
        out: &mut [f64],
        height: usize,
        smooth: bool,
    ) -> Result<()> {
        let job = Job {
            plan,
            z,
            weights,
            height,
            smooth,
        };
        simd::dispatch(Passes {
            filter: self,
            job,
            out,
        })
    }

    #[inline(always)]
    fn passes(&self, job: Job, out: &mut [f64]) -> Result<()> {
        simd::clear_upper_state();
        let Job {
            plan,
            z,
            weights,
            height,
            smooth,
        } = job;
        let (w, n) = (self.width(), self.dynamics.order);
        let size = w * n;
        let mut state = vec![0.0; size];
        let mut info = vec![0.0; size];
        let mut gain_in = vec![0.0; size];
        // the state after the start rows (ŷ_n), from which the RTS pass reads them out
        let mut start = if smooth { vec![0.0; size] } else { Vec::new() };
        // A_t x = rhs: the plan's factor, or this row's weighted system, whose Λ_t is the
        // plan's or propagated: made as the forward pass reaches it when causal, every row's
        // kept for the RTS pass when smoothed
        let kept = match weights {
            Some(all) if smooth && self.row_models.propagates() => {
                self.propagated_precisions(plan, all, height)?
            }
            _ => Vec::new(),
        };
        let mut weighted = match weights {
            None => None,
            Some(all) => {
                let models = match self.row_models {
                    RowModels::Nominal => RowModelSource::Plan,
                    _ if smooth => RowModelSource::Kept(&kept),
                    RowModels::Propagated | RowModels::Implied => {
                        RowModelSource::Made(Propagation::new(self, plan, all)?, Vec::new())
                    }
                };
                Some(WeightedRows::new(self, plan, models, z, all))
            }
        };
        // `innovation`: x is zero outside each column's component 0 (a prediction row)
        let mut solve = |t: usize, x: &mut [f64], innovation: bool| match weighted.as_mut() {
            Some(rows) => rows.solve(t, x),
            None if innovation => {
                plan.factor(t).solve_observed_in_place(x, n);
                Ok(())
            }
            None => {
                plan.factor(t).solve_in_place(x);
                Ok(())
            }
        };
        let observed = |t: usize| n.saturating_sub(t);
        let row_of = |t: usize| (t - 1) * w..t * w;
        for t in 1..=height {
            let row = &z[row_of(t)];
            let out_row = &mut out[row_of(t)];
            let row_weights = weights.map(|r| &r[row_of(t)]);
            if t <= n && weights.is_none() && !all_in_range(row) {
                return Err(out_of_range_pixels());
            }
            // 1/σ_θ² per pixel; a pixel of weight 0 is ignored (its value may be NaN)
            let weight = |ell: usize| row_weights.map_or(self.nominal().0, |r| r[ell]);
            if t <= n {
                let h = self.lower().row(n - t);
                for (ell, zl) in row.iter().enumerate() {
                    let r_ell = weight(ell);
                    if r_ell > 0.0 {
                        for a in 0..n {
                            info[ell * n + a] += h[a] * zl * r_ell;
                        }
                    }
                }
                state.copy_from_slice(&info);
                solve(t, &mut state, false)?;
                self.readout(&state, observed(t), out_row);
            } else {
                if !self.predict(&mut state, row, &mut gain_in, row_weights) {
                    return Err(out_of_range_pixels());
                }
                if t < height {
                    columns::prefetch(&z[t * w..(t + 1) * w]);
                    weights.inspect(|r| columns::prefetch(&r[t * w..(t + 1) * w]));
                }
                solve(t, &mut gain_in, true)?;
                self.correct(&gain_in, &mut state, out_row);
            }
            if smooth && t == n.min(height) {
                start.copy_from_slice(&state);
            }
        }
        if !smooth {
            return Ok(());
        }
        let first = n.min(height);
        // d_t, carried from one step to the next; the solve turns `delta` from d_t into δ_t
        let mut carried = vec![0.0; size];
        let mut delta = vec![0.0; size];
        // rows H (δ_H = 0, d_H = 0) down to n + 1; then δ_n, whose ŷˢ_n = ŷ_n + δ_n gives the
        // start rows 1..n (their A_t are not Λ_t + Hᵀ R⁻¹ H: ŷˢ_n is read off the state)
        for t in (first + 1..=height).rev() {
            if t < height {
                solve(t, &mut delta, false)?;
            }
            if t > first + 1 {
                columns::prefetch(&z[row_of(t - 1)]);
                columns::prefetch(&out[row_of(t - 1)]);
            }
            let rts = RtsRow {
                delta: &mut delta,
                carried: &mut carried,
                row: &z[row_of(t)],
                out: &mut out[row_of(t)],
            };
            self.smooth_row(weights.map(|r| &r[row_of(t)]), rts);
        }
        if height > first {
            solve(first, &mut delta, false)?;
            for (x, d) in start.iter_mut().zip(&delta) {
                *x += d;
            }
        }
        for t in 1..=first {
            self.readout(&start, observed(t), &mut out[row_of(t)]);
        }
        Ok(())
    }
}

/// Where the weighted rows' Λ_t come from (`RowModels`); a row without a propagated model
/// takes the plan's.
enum RowModelSource<'a> {
    /// The plan's (`RowModels::Nominal`).
    Plan,
    /// Propagated, every row's, kept for the RTS pass.
    Kept(&'a [Option<SymmetricBand>]),
    /// Propagated as the forward pass reaches the rows: the current batch's (causal pass).
    Made(Propagation<'a>, Vec<Option<SymmetricBand>>),
}

/// The factors of the weighted rows' systems, made LANES rows at a time as the passes reach
/// them (the RTS pass refactors rather than keeping a factor per row).
struct WeightedRows<'a> {
    filter: &'a ScalarRowFilter,
    plan: &'a Plan,
    models: RowModelSource<'a>,
    z: &'a [f64],
    weights: &'a [f64],
    height: usize,
    /// First row (1-based) of the rows in `batch`; 0: none.
    first: usize,
    batch: BandLdlBatch,
    /// The batch's rows factored one by one (Cholesky) where its LDLᵀ lanes failed with
    /// propagated models; empty otherwise.
    fallback: Vec<BandCholesky>,
}

impl<'a> WeightedRows<'a> {
    fn new(
        filter: &'a ScalarRowFilter,
        plan: &'a Plan,
        models: RowModelSource<'a>,
        z: &'a [f64],
        weights: &'a [f64],
    ) -> Self {
        let size = filter.width() * filter.dynamics.order;
        Self {
            filter,
            plan,
            models,
            z,
            weights,
            height: weights.len() / filter.width(),
            first: 0,
            batch: BandLdlBatch::new(size, filter.bandwidth()),
            fallback: Vec::new(),
        }
    }

    /// Solves A_t x = rhs (1-based row t).
    fn solve(&mut self, t: usize, x: &mut [f64]) -> Result<()> {
        let first = (t - 1) / LANES * LANES + 1;
        if first != self.first {
            self.first = 0;
            let rows = first..(first + LANES).min(self.height + 1);
            let w = self.filter.width();
            for s in rows.clone() {
                let at = (s - 1) * w..s * w;
                ScalarRowFilter::check_weighted_row(&self.z[at.clone()], &self.weights[at])?;
            }
            let rows_len = rows.len();
            if let RowModelSource::Made(propagation, batch) = &mut self.models {
                // the causal pass reaches each batch once, in order
                *batch = rows
                    .clone()
                    .map(|_| propagation.next_row(None))
                    .collect::<Result<_>>()?;
            }
            let (plan, models) = (self.plan, &self.models);
            let lane_row = |j: usize| (rows.start + j).min(rows.end - 1);
            let precisions = std::array::from_fn(|j| {
                let t = lane_row(j);
                let propagated = match models {
                    RowModelSource::Plan => None,
                    RowModelSource::Kept(all) => all[t - 1].as_ref(),
                    RowModelSource::Made(_, batch) => batch[t - rows.start].as_ref(),
                };
                propagated.unwrap_or_else(|| plan.precision(t))
            });
            let factored =
                self.filter
                    .weighted_factors(precisions, rows, self.weights, &mut self.batch);
            self.fallback.clear();
            match (factored, models) {
                (Err(e), RowModelSource::Plan) => {
                    return Err(FieldError::InvalidParameter(format!(
                        "{e}; row_models=\"propagated\" fits the row models to these weights"
                    )));
                }
                // the propagation factored each of these systems (Cholesky) to invert it
                (Err(_), _) => {
                    self.fallback = (0..rows_len)
                        .map(|j| {
                            let t = first + j;
                            let system =
                                self.filter.weighted_system(precisions[j], t, self.weights);
                            system.cholesky()
                        })
                        .collect::<Result<_>>()?;
                }
                (factored, _) => factored?,
            }
            self.first = first;
        }
        match self.fallback.get(t - first) {
            Some(factor) => factor.solve_in_place(x),
            None => self.batch.solve_in_place(t - first, x),
        }
        Ok(())
    }
}

/// σ² λ_j of every mode.
fn variances(values: &[f64], sigma: f64) -> Vec<f64> {
    values.iter().map(|l| sigma * sigma * l).collect()
}

/// Largest entry-wise difference between two bands of blocks.
fn band_change(band: &[Mat<f64>], other: &[Mat<f64>]) -> f64 {
    band.iter()
        .zip(other)
        .fold(0.0, |most, (a, b)| most.max(max_abs_difference(a, Some(b))))
}

/// The scale the row-to-row changes of the band of P_e,t are measured against: the largest
/// entry of the band of P_e,t − Q = S P_f,t−1 Sᵀ, the part of the prediction error that
/// changes from row to row (the innovation Q is the same on every row), at least
/// [`DRIFT_FLOOR`] times the band's largest entry. Against the band's largest entry alone, at
/// high SNR (where P_e ≈ Q) the changes that matter looked 10²–10⁴ times smaller than they
/// are and the models froze early: (1,2), ρ = 0.99, σ_x²/σ_θ² = 1e4 lost 16 % instead of 12 %
/// against the optimal filter (32²).
fn drift_scale(band: &[Mat<f64>], innovation: &[Mat<f64>]) -> f64 {
    let varying = max_abs_difference(&band[0], Some(&innovation[0]));
    varying.max(DRIFT_FLOOR * max_abs_difference(&band[0], None))
}

/// The default order m of the block AR model along the row for multiplicities (n_y, n_x):
/// 8 for n_y = 1, [`model_ar_order`] = max(n_x, 2) (at most 8) otherwise. With one row in
/// the state nothing absorbs the AR model's misfit to P_e (a smooth part plus a near-white
/// one whose precision is not banded), and the loss grows as ρ → 1: (1,1) at ρ = 0.99, σ_x²/σ_θ² = 3 loses +10.7 %
/// with m = 2, +4.7 % with m = 4, +1.4 % with m = 8 (48², exact MSEs), and m = 8 was never
/// worse over ρ ≤ 0.999, σ_θ² ≥ 1e-10; the band b = m stays narrow (1.6× the time of m = 2,
/// still > 100 Mpixel/s smoothed). For n_y ≥ 2 the older rows of the state absorb most of
/// it and a wider band costs more (b = n_y(m + 1) − 1): max(n_x, 2) is within 0.4 % of
/// n_x + 1 on the grid.
pub fn default_ar_order(n_y: usize, n_x: usize) -> usize {
    if n_y == 1 {
        MAX_AR_ORDER
    } else {
        model_ar_order(n_x)
    }
}

/// m = n_x, at least 2 and at most [`MAX_AR_ORDER`] (a field of n_x > 8 gets the longest row
/// model there is): the default for n_y ≥ 2, and `denoise`'s for every model (its rows are
/// weighted, refitted at O(W m³), or its model identified from a real image, README).
pub fn model_ar_order(n_x: usize) -> usize {
    n_x.clamp(2, MAX_AR_ORDER)
}

/// Whether a sequence whose latest relative change is `change` (the two before: `previous`,
/// `earlier`) lies within `tolerance` of its limit: change / (1 − q) ≤ tolerance, q = change /
/// previous, the geometric tail the last two changes imply, provided q is not rising (by
/// more than [`RATIO_RISE`] against previous / earlier: a contraction that slows down is a
/// slower mode taking over, and its tail is longer); at q ≥ 0.999 (not contracting yet, or
/// changes at the rounding floor) change ≤ 1e-3 tolerance. One row's change ≤ tolerance
/// alone froze slowly converging Riccatis (ρ = 0.999) far from their limit: (2,2) at
/// σ_x²/σ_θ² = 1 lost 33 % against the optimal filter (48², now 0.1 %); the tail without
/// the rising check froze (2,2) at ρ_y = 0.9999, σ_θ²/σ_x² = 0.01 at its fifth row, while
/// its band drifts for ~600 rows (changes 1.0e-3, 5.5e-4, 3.5e-4, then growing again):
/// +38 % causal, +84 % smoothed against the optimal filter and the bound (32²; now +1.2 % /
/// +5.1 %, and `RowModels::Implied` +0.00 %).
fn settled(change: f64, previous: Option<f64>, earlier: Option<f64>, tolerance: f64) -> bool {
    if change == 0.0 {
        return true;
    }
    let Some(previous) = previous else {
        return false;
    };
    let ratio = |a: f64, b: f64| if b > 0.0 { (a / b).min(1.0) } else { 1.0 };
    let q = ratio(change, previous);
    if q < 0.999 {
        match earlier {
            Some(earlier) if q <= ratio(previous, earlier) + RATIO_RISE => {}
            _ => return false,
        }
    }
    change <= tolerance * (1.0 - q).max(1e-3)
}

/// The recent row-to-row changes of a converging sequence, for [`settled`].
#[derive(Debug, Default)]
struct Settling {
    previous: Option<f64>,
    earlier: Option<f64>,
}

impl Settling {
    /// Records `change`; whether the sequence now lies within `tolerance` of its limit.
    fn settled_after(&mut self, change: f64, tolerance: f64) -> bool {
        let done = settled(change, self.previous, self.earlier, tolerance);
        (self.earlier, self.previous) = (self.previous, Some(change));
        done
    }
}

/// max |a − b| over the entries (max |a| without b).
fn max_abs_difference(a: &Mat<f64>, b: Option<&Mat<f64>>) -> f64 {
    let mut most = 0.0f64;
    for c in 0..a.ncols() {
        for r in 0..a.nrows() {
            let other = b.map_or(0.0, |b| b[(r, c)]);
            most = most.max((a[(r, c)] - other).abs());
        }
    }
    most
}

/// Whether a column's term of Λ lies within [`INTERIOR_TOLERANCE`] of the middle column's
/// (largest entry difference relative to the middle one's largest entry).
fn is_settled(own: &DMatrix<f64>, central: &DMatrix<f64>) -> bool {
    (own - central).amax() <= INTERIOR_TOLERANCE * central.amax()
}

fn singular_model() -> FieldError {
    FieldError::InvalidParameter(
        "the row model's covariance is singular (ill-conditioned model)".into(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sequence_is_settled_when_its_geometric_tail_is_within_the_tolerance() {
        assert!(settled(0.0, None, None, 1e-3));
        assert!(!settled(1e-9, None, None, 1e-3)); // one change says nothing of the tail
        let steady = Some(1.6e-3); // q = 0.5 on the row before
        assert!(settled(4e-4, Some(8e-4), steady, 1e-3)); // q = 0.5: tail 8e-4
        assert!(!settled(4e-4, Some(8e-4), None, 1e-3)); // one ratio: not yet a tail
        assert!(!settled(6e-4, Some(1.2e-3), Some(2.4e-3), 1e-3)); // q = 0.5: tail 1.2e-3
        assert!(!settled(1e-4, Some(1.01e-4), steady, 1e-3)); // q ≈ 0.99: tail 1e-2
        assert!(!settled(1e-4, Some(0.5e-4), steady, 1e-3)); // growing: 1e-4 > 1e-6
        assert!(settled(1e-7, Some(0.5e-7), None, 1e-3)); // growing at the rounding floor

        // the ρ_y = 0.9999 rows: q 0.53 → 0.63, slowing down (the band drifts ~600 rows)
        assert!(!settled(3.48e-4, Some(5.54e-4), Some(1.038e-3), 1e-3));
        assert!(settled(3.48e-4, Some(5.54e-4), Some(0.95e-3), 1e-3)); // q steady at 0.6
    }

    #[test]
    fn a_one_row_state_takes_the_longest_row_model_by_default() {
        let bandwidth = |order: &[usize], m: Option<usize>| {
            let model = FieldModel::new(&[0.9, 0.9], order, 1.0).unwrap();
            ScalarRowFilter::new(&model, 1.0, 32, m, ModeSet::Toeplitz)
                .unwrap()
                .bandwidth()
        };
        assert_eq!(bandwidth(&[1, 1], None), MAX_AR_ORDER); // b = n_y (m + 1) − 1
        assert_eq!(bandwidth(&[1, 4], None), MAX_AR_ORDER);
        assert_eq!(bandwidth(&[1, 1], Some(2)), 2);
        assert_eq!(bandwidth(&[2, 1], None), 5); // m = max(n_x, 2)
        assert_eq!(bandwidth(&[3, 4], None), 14);
    }

    #[test]
    fn implied_row_models_propagate_on_nominal_images() {
        // (2,2), ρ_y = 0.9999, σ_θ²/σ_x² = 0.01: the plan's models drift from the filter's
        // own covariance, the implied ones follow it; no weights = the nominal weights
        let model = FieldModel::new(&[0.9999, 0.9], &[2, 2], 1.0).unwrap();
        let (height, width) = (12, 10);
        let make = |row_models| {
            ScalarRowFilter::new(&model, 0.01, width, None, ModeSet::Exact)
                .unwrap()
                .with_row_models(row_models)
        };
        let z: Vec<f64> = (0..height * width)
            .map(|i| ((i * 7919) % 101) as f64 / 50.0 - 1.0)
            .collect();
        let run = |f: &ScalarRowFilter, weights: Option<&[f64]>, smooth| {
            let mut out = vec![0.0; z.len()];
            f.filter_image(&z, weights, &mut out, height, smooth)
                .unwrap();
            out
        };
        let uniform = vec![100.0; z.len()];
        let (implied, plan) = (make(RowModels::Implied), make(RowModels::Propagated));
        let apart = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .fold(0.0f64, |d, (x, y)| d.max((x - y).abs()))
        };
        for smooth in [false, true] {
            let got = run(&implied, None, smooth);
            assert_eq!(got, run(&implied, Some(&uniform), smooth));
            // the plan's systems, or the same models in weighted systems: equal to rounding
            let nominal = run(&plan, None, smooth);
            assert!(apart(&nominal, &run(&plan, Some(&uniform), smooth)) < 1e-12);
            assert!(apart(&got, &nominal) > 1e-6);
        }
        let map = implied.error_variance(height, None).unwrap();
        assert_eq!(map, implied.error_variance(height, Some(&uniform)).unwrap());
    }

    #[test]
    fn very_wide_rows_fit_fewer_row_models() {
        let model = FieldModel::new(&[0.9, 0.9], &[4, 4], 1.0).unwrap();
        let models = |w| {
            ScalarRowFilter::new(&model, 1.0, w, None, ModeSet::Toeplitz)
                .unwrap()
                .max_models()
        };
        // 5 W n_y (b + 1) doubles per model, b = 19: 1 GiB holds 64 up to W = 5242
        assert_eq!(models(2048), MAX_ROW_MODELS);
        assert_eq!(models(5242), MAX_ROW_MODELS);
        assert_eq!(models(8192), 40);
        assert_eq!(models(1 << 20), MIN_ROW_MODELS);
    }

    #[test]
    fn the_drift_is_measured_on_the_part_of_the_band_that_changes() {
        // σ_x²/σ_θ² = 1e4: P_e ≈ Q, so against the band's largest entry the rows' changes
        // looked ~1e3 times smaller than they are, and the models froze after a few rows
        let model = FieldModel::new(&[0.95, 0.95], &[1, 2], 1.0).unwrap();
        let filter = ScalarRowFilter::new(&model, 1e-4, 32, None, ModeSet::Exact).unwrap();
        let innovation = filter.innovation_blocks();
        let (second, third) = (band_of_row(&filter, 2), band_of_row(&filter, 3));
        let largest = max_abs_difference(&second[0], None);
        let varying = drift_scale(&second, &innovation);
        assert!(varying < 1e-2 * largest, "{varying:e} vs {largest:e}");
        assert!(band_change(&third, &second) > SETTLE_TOLERANCE * varying);
        // P_e − Q is S P_f Sᵀ: positive on the diagonal, below the noise variance there
        let diagonal = (0..32).map(|ell| second[0][(ell, 0)] - innovation[0][(ell, 0)]);
        assert!(diagonal.clone().all(|d| d > 0.0 && d < 1e-4));
        assert_eq!(varying, diagonal.fold(0.0, f64::max));
        assert!(filter.plan(32).unwrap().precisions.len() > 10);
        // a band equal to Q: the floor, not zero
        let floor = drift_scale(&innovation, &innovation);
        assert_eq!(
            floor,
            DRIFT_FLOOR * max_abs_difference(&innovation[0], None)
        );
    }

    /// The band of P_e of prediction row `t` (1-based), whitened.
    fn band_of_row(filter: &ScalarRowFilter, t: usize) -> Vec<Mat<f64>> {
        let (_, modal) = filter
            .whitened
            .prediction_errors(filter.noise_var, &filter.mode_var)
            .nth(t - 1)
            .unwrap();
        filter.band(&modal)
    }

    #[test]
    fn the_whitened_riccati_is_the_whitened_modal_one() {
        let model = FieldModel::new(&[0.9, 0.8], &[3, 2], 1.0).unwrap();
        let filter = ScalarRowFilter::new(&model, 0.5, 12, None, ModeSet::Exact).unwrap();
        let rows = filter
            .whitened
            .prediction_errors(filter.noise_var, &filter.mode_var)
            .zip(
                filter
                    .dynamics
                    .prediction_errors(filter.noise_var, &filter.mode_var),
            );
        let whitening = filter.lower().solve_lower_triangular(&Small::identity());
        let whitening = whitening.unwrap();
        for ((t, whitened), (_, modal)) in rows.take(9) {
            for (got, p) in whitened.iter().zip(&modal) {
                let want = whitening * p * whitening.transpose();
                let gap = (got - want).amax();
                assert!(gap < 1e-10 * want.amax(), "row {t}: {gap}");
            }
        }
    }

    #[test]
    fn the_square_root_fit_is_the_direct_one() {
        let model = FieldModel::new(&[0.9, 0.8], &[2, 2], 1.0).unwrap();
        let filter = ScalarRowFilter::new(&model, 0.5, 20, None, ModeSet::Exact).unwrap();
        for t in [1, 3, 6] {
            let band = band_of_row(&filter, t);
            let direct = filter.precision(&band, None).unwrap();
            let root = filter.precision(&band, Some(0.0)).unwrap();
            let size = direct.size();
            let top = (0..size).map(|i| direct.get(i, i)).fold(0.0, f64::max);
            for i in 0..size {
                for k in i.saturating_sub(filter.bandwidth())..=i {
                    let gap = (direct.get(i, k) - root.get(i, k)).abs();
                    assert!(gap < 1e-10 * top, "row {t}, ({i}, {k}): {gap}");
                }
            }
        }
    }

    #[test]
    fn a_row_beyond_float64_takes_the_square_root_fit() {
        // ρ = 0.999, n_x = 3: D of the direct fit is ~6e-15 of the variance, its inverse
        // rounding noise, and some rows' systems cannot be factored
        let model = FieldModel::new(&[0.999, 0.999], &[4, 3], 1.0).unwrap();
        let filter = ScalarRowFilter::new(&model, 1e-4, 16, None, ModeSet::Exact).unwrap();
        let mut refitted = 0;
        for (t, modal) in filter
            .whitened
            .prediction_errors(filter.noise_var, &filter.mode_var)
            .take(40)
        {
            let band = filter.band(&modal);
            let direct = filter.precision(&band, None);
            if direct.is_ok_and(|d| filter.system(&d, &[0]).is_ok()) {
                continue;
            }
            let (prior, factors) = filter.sound_systems(&band, &[vec![0]]).unwrap();
            assert!(prior.cholesky().is_ok(), "row {t}");
            assert_eq!(factors.len(), 1);
            refitted += 1;
        }
        assert!(refitted > 0);
    }

    #[test]
    fn high_snr_fits_of_four_rows_stay_positive_definite() {
        // σ_x²/σ_θ² = 1e8: D of the block AR fit has a condition of ~1e8; nalgebra's
        // cofactor inverse (n ≤ 4) made D⁻¹ indefinite and the row system "not positive
        // definite"
        for nx in [1, 2, 3] {
            let model = FieldModel::new(&[0.5, 0.5], &[4, nx], 1.0).unwrap();
            let filter = ScalarRowFilter::new(&model, 1e-8, 16, None, ModeSet::Exact).unwrap();
            let z: Vec<f64> = (0..12 * 16).map(|i| (i as f64 * 0.3).sin()).collect();
            let mut out = vec![0.0; z.len()];
            filter.filter_image(&z, None, &mut out, 12, true).unwrap();
            // nearly noise-free: the estimate is the image
            let worst = z
                .iter()
                .zip(&out)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(worst < 1e-3, "n_x = {nx}: {worst}");
        }
    }

    #[test]
    fn a_noise_variance_too_small_for_the_start_is_refused_by_new() {
        let model = FieldModel::new(&[0.9, 0.9], &[3, 3], 1.0).unwrap();
        let refused = ScalarRowFilter::new(&model, 1e-30, 16, None, ModeSet::Ends);
        let message = refused.unwrap_err().to_string();
        assert!(message.contains("too small for this filter"), "{message}");
        let filter = ScalarRowFilter::new(&model, 1e-12, 16, None, ModeSet::Ends).unwrap();
        // the plan takes the start made by `new`
        let plan = filter.plan(8).unwrap();
        assert_eq!(plan.precisions[0], filter.start.as_ref().unwrap().0);
    }

    #[test]
    fn a_non_finite_or_out_of_range_pixel_in_any_row_is_an_error() {
        let model = FieldModel::new(&[0.9, 0.8], &[2, 2], 1.0).unwrap();
        let (h, w) = (12usize, 16usize);
        let filter = ScalarRowFilter::new(&model, 0.5, w, None, ModeSet::Exact).unwrap();
        let z: Vec<f64> = (0..h * w).map(|i| (i as f64 * 0.3).sin()).collect();
        let mut out = vec![0.0; h * w];
        filter.filter_image(&z, None, &mut out, h, true).unwrap();
        // the largest pixel taken, in a start row and in a predicted row
        for at in [3usize, 9 * w + 5] {
            let mut z = z.clone();
            z[at] = -crate::vector_row_filter::MAX_PIXEL;
            filter.filter_image(&z, None, &mut out, h, true).unwrap();
            assert!(out.iter().all(|v| v.is_finite()), "{at}");
        }
        // a start row (1..=n) and a predicted row: NaN, infinite, beyond 2^1000
        for (at, bad) in [
            (3usize, f64::NAN),
            (9 * w + 5, f64::INFINITY),
            (11 * w, f64::NAN),
            (2, 2f64.powi(1001)),
            (7 * w + 1, -f64::MAX),
        ] {
            let mut z = z.clone();
            z[at] = bad;
            let err = filter
                .filter_image(&z, None, &mut out, h, false)
                .unwrap_err();
            assert!(matches!(err, FieldError::NonFinite(_)), "{at}: {err}");
        }
    }

    /// Max over the rows i of |Λ_i − Λ_{i − n}| in `range` (block columns), relative to Λ's
    /// largest entry.
    fn periodic_defect(precision: &SymmetricBand, n: usize, range: Range<usize>) -> f64 {
        let (size, b) = (precision.size(), precision.bandwidth());
        let scale = (0..size).fold(0.0f64, |m, i| m.max(precision.get(i, i).abs()));
        let mut most = 0.0f64;
        for i in range.start * n..range.end * n {
            for k in i.saturating_sub(b)..=i {
                if k >= n && i - n >= b {
                    let d = precision.get(i, k) - precision.get(i - n, k - n);
                    most = most.max(d.abs() / scale);
                }
            }
        }
        most
    }

    #[test]
    fn the_row_models_interior_is_exactly_periodic_and_its_factors_steady() {
        // wide rows of n_y = 3 and 4: Λ's interior rows repeat bit for bit (the columns'
        // fits, scattered by rounding, take the middle one's), the edges keep their effects;
        // both factors get the steady solve (n_y = 4 once its rounding scatter, ~2e-9, is
        // snapped, see `steady_band`)
        for (order, width) in [(3usize, 512usize), (4, 1024)] {
            let model = FieldModel::new(&[0.9, 0.9], &[order, order], 1.0).unwrap();
            let filter = ScalarRowFilter::new(&model, 1.0, width, None, ModeSet::Exact).unwrap();
            let plan = filter.plan(64).unwrap();
            let (first, last) = (plan.precision(1), plan.precision(64));
            for precision in [first, last] {
                assert_eq!(periodic_defect(precision, order, 80..width - 80), 0.0);
            }
            // (the start rows' prior is stationary: its AR fit has no edge effects)
            assert!(periodic_defect(last, order, 0..20) > 1e-6);
            assert!(plan.factor(64).is_steady());
        }
    }

    #[test]
    fn every_wide_order_solves_by_blocks_as_the_plain_substitution_does() {
        // n_y = 3, 4 with every n_x: B = n_y(m + 1) − 1 = 8, 11, 14, 15, 19 (8, 14 and 15
        // stored padded to a fixed band), blocks of n_y with K = m blocks per step; (2,4):
        // B = 9 padded to 11, blocks of 4 (two columns), K = 2
        let cases = [
            (3usize, 1usize),
            (3, 2),
            (3, 4),
            (4, 1),
            (4, 2),
            (4, 3),
            (2, 4),
        ];
        for (n_y, n_x) in cases {
            let model = FieldModel::new(&[0.9, 0.8], &[n_y, n_x], 1.0).unwrap();
            let filter = ScalarRowFilter::new(&model, 0.7, 512, None, ModeSet::Ends).unwrap();
            let factor = filter.plan(64).unwrap().factor(64).clone();
            let blocks = factor.block_plan().expect("a block plan");
            let expected = if n_y == 2 { (4, 2) } else { (n_y, n_x.max(2)) };
            assert_eq!((blocks.size(), blocks.reach()), expected, "{n_y},{n_x}");
            let size = 512 * n_y;
            let dense: Vec<f64> = (0..size).map(|i| (i as f64 * 0.37).sin()).collect();
            let observed: Vec<f64> = dense
                .iter()
                .enumerate()
                .map(|(i, v)| if i % n_y == 0 { *v } else { 0.0 })
                .collect();
            for (rhs, first_only) in [(dense, false), (observed, true)] {
                let (mut planned, mut plain) = (rhs.clone(), rhs);
                if first_only {
                    factor.solve_observed_in_place(&mut planned, n_y);
                } else {
                    factor.solve_in_place(&mut planned);
                }
                factor.solve_unplanned(&mut plain);
                let scale = plain.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let most = planned
                    .iter()
                    .zip(&plain)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                // (the two summation orders' rounding, amplified by the systems' condition:
                // up to ~3e-12 for (3,4))
                assert!(most < 1e-10 * scale, "{n_y},{n_x} {first_only}: {most:e}");
            }
        }
    }

    #[test]
    fn the_splice_check_refuses_ends_too_short_for_the_edge_effects() {
        // (2,2) at ρ = 0.95: the edge effects of P_e reach ~200 columns, so the ends of a
        // 256-point row (spliced 96 columns from its end) are refused; the first W' from the
        // correlation's reach holds and is taken; a row narrower than 2W' stays whole
        let model = FieldModel::new(&[0.95, 0.95], &[2, 2], 1.0).unwrap();
        let x = &model.axes()[1];
        let width = 4096;
        let filter = ScalarRowFilter::new(&model, 1.0, width, None, ModeSet::Ends).unwrap();
        let first = RowModes::first_span(x, width).unwrap();
        assert_eq!(filter.ends_span(), Some(first));
        let ends = |span| RowModes::ends(x, width, span).unwrap();
        assert!(filter.splice_holds(&ends(first), x, 1.0));
        assert!(!filter.splice_holds(&ends(256), x, 1.0));
        let narrow = ScalarRowFilter::new(&model, 1.0, 2 * first - 1, None, ModeSet::Ends);
        assert_eq!(narrow.unwrap().ends_span(), None);
    }

    #[test]
    fn a_reused_filter_gives_the_fresh_filters_bits() {
        let model = FieldModel::new(&[0.9, 0.7], &[2, 1], 1.0).unwrap();
        let w = 24usize;
        let image = |h: usize, phase: f64| -> Vec<f64> {
            (0..h * w)
                .map(|i| (i as f64 * 0.37 + phase).sin())
                .collect()
        };
        let reused = ScalarRowFilter::new(&model, 0.5, w, None, ModeSet::Exact).unwrap();
        // images of other heights in turn: a reused filter (its cached plan) changes nothing
        for (h, phase) in [(30usize, 0.0), (17, 1.0), (40, 2.0)] {
            let z = image(h, phase);
            let fresh = ScalarRowFilter::new(&model, 0.5, w, None, ModeSet::Exact).unwrap();
            let (mut a, mut b) = (vec![0.0; h * w], vec![0.0; h * w]);
            reused.filter_image(&z, None, &mut a, h, true).unwrap();
            fresh.filter_image(&z, None, &mut b, h, true).unwrap();
            assert_eq!(a, b, "height {h}");
            assert!(a.iter().zip(&z).any(|(x, y)| x != y));
        }
    }

    #[test]
    fn the_error_variance_is_the_optimal_filters_on_the_start_rows_and_near_it_after() {
        use crate::vector_row_filter::VectorRowFilter;
        for (rhos, orders) in [([0.9, 0.8], [1usize, 1usize]), ([0.8, 0.9], [3, 2])] {
            let model = FieldModel::new(&rhos, &orders, 1.3).unwrap();
            let (h, w, noise_var) = (20usize, 40usize, 0.7);
            let scalar = ScalarRowFilter::new(&model, noise_var, w, None, ModeSet::Exact).unwrap();
            let got = scalar.error_variance(h, None).unwrap();
            // the nominal weights as a map: the same systems, factored per row
            let nominal = vec![1.0 / noise_var; h * w];
            let weighted = scalar.error_variance(h, Some(&nominal)).unwrap();
            for (a, b) in weighted.iter().zip(&got) {
                assert!((a - b).abs() <= 1e-12 * b, "{a} vs {b}");
            }
            let mut optimal = vec![0.0; h * w];
            VectorRowFilter::new(&model, noise_var, w)
                .unwrap()
                .error_variance(h, false, &mut optimal)
                .unwrap();
            for (i, (g, o)) in got.iter().zip(&optimal).enumerate() {
                // the start rows' model is the stationary prior itself (m ≥ n_x); after them
                // Λ_t is a band fit of the optimal P_e,t
                let tolerance = if i < orders[0] * w { 1e-9 } else { 0.02 };
                assert!(
                    (g - o).abs() <= tolerance * o,
                    "{orders:?} pixel {i}: {g} vs {o}"
                );
            }
        }
    }
}
