//! The systems of rows with per-pixel weights (missing pixels, noise maps): A_t = Λ_t +
//! Σ_ℓ w h hᵀ, factored LANES rows at a time (`BandLdlBatch`) as the passes reach them.

use super::plan::Plan;
use super::propagated_models::Propagation;
use super::ScalarRowFilter;
use crate::error::{FieldError, Result};
use crate::linalg::{BandCholesky, BandLdlBatch, SymmetricBand, LDL_LANES as LANES};
use std::ops::Range;

/// Where the weighted rows' Λ_t come from (`RowModels`); a row without a propagated model
/// takes the plan's.
pub(super) enum RowModelSource<'a> {
    /// The plan's (`RowModels::Nominal`).
    Plan,
    /// Propagated, every row's, kept for the RTS pass.
    Kept(&'a [Option<SymmetricBand>]),
    /// Propagated as the forward pass reaches the rows: the current batch's (causal pass).
    Made(Propagation<'a>, Vec<Option<SymmetricBand>>),
}

/// The factors of the weighted rows' systems, made LANES rows at a time as the passes reach
/// them (the RTS pass refactors rather than keeping a factor per row).
pub(super) struct WeightedRows<'a> {
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
    pub(super) fn new(
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
    pub(super) fn solve(&mut self, t: usize, x: &mut [f64]) -> Result<()> {
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

impl ScalarRowFilter {
    /// Factors the weighted systems A_t of rows t ∈ `rows` (1-based, at most LANES; spare
    /// lanes repeat the last row) into `batch`, one lane per row: Λ_t (`precisions`, by lane)
    /// plus Σ_ℓ w_sℓ h_s h_sᵀ over the rows s observed in the state at t (start rows t ≤ n:
    /// s = 1..t, observed through state row n − s; later rows: s = t, through state row 0).
    /// The rows are checked (`check_weighted_row`) before: the only error is a system that
    /// does not factor.
    pub(super) fn weighted_factors(
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
}
