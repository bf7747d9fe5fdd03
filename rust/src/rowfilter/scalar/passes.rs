//! The passes over an image: the forward filter row by row (one banded solve per row) and
//! the RTS pass back up the rows, run in `simd::dispatch`'s best build.

use super::column_steps::{self as columns, for_order, Nominal, PerPixel, RtsRow};
use super::plan::Plan;
use super::propagated_models::Propagation;
use super::weighted_rows::{RowModelSource, WeightedRows};
use super::{RowModels, ScalarRowFilter};
use crate::error::Result;
use crate::rowfilter::{all_in_range, out_of_range_pixels};
use crate::simd::{self, Arith, Kernel};

/// One run of the filter: the plan, the image (row-major height × W), its per-pixel
/// 1/σ_θ² (None: nominal) and whether the RTS pass follows.
#[derive(Clone, Copy)]
pub(super) struct Job<'a> {
    plan: &'a Plan,
    z: &'a [f64],
    weights: Option<&'a [f64]>,
    height: usize,
    smooth: bool,
}

/// The passes of one run into `out`, a [`Kernel`] of `simd::dispatch` (the per-column
/// loops run four columns per instruction where AVX2 runs).
pub(super) struct Passes<'a> {
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

impl ScalarRowFilter {
    /// h = row `index` of L: the readout of the image row held in that state row.
    #[inline(always)]
    pub(super) fn readout_row(&self, index: usize) -> [f64; 4] {
        let h = self.lower().row(index);
        std::array::from_fn(|a| if a < self.dynamics.order { h[a] } else { 0.0 })
    }

    /// Prediction and innovation in one pass over the columns (`column_steps::predict`):
    /// state_ℓ ← S state_ℓ, gain_in_ℓ = ((z_ℓ − state_ℓ[0]) r_ℓ, 0, …), r_ℓ = 1/σ²_θ,ℓ
    /// (`weights`; None: 1/σ_θ² everywhere). False when `weights` is None and a pixel of the
    /// row is NaN, infinite or beyond ±2^1000 (`pixel_in_range`).
    #[inline(always)]
    pub(super) fn predict(
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
    pub(super) fn nominal(&self) -> Nominal {
        Nominal(1.0 / self.noise_var)
    }

    /// The filter's correction of a row after the start: state_ℓ += d_ℓ, and out[ℓ] = the
    /// estimate h · state_ℓ (h = e₀: row 0 of L).
    #[inline(always)]
    pub(super) fn correct(&self, d: &[f64], state: &mut [f64], out: &mut [f64]) {
        let h = self.readout_row(0);
        for_order!(self.dynamics.order, |N, K| columns::correct::<N, K>(
            d, state, &h, out
        ))
    }

    /// row[ℓ] = h · state_ℓ with h = row `index` of L (the image row held in that state row).
    #[inline(always)]
    pub(super) fn readout(&self, state: &[f64], index: usize, row: &mut [f64]) {
        let h = self.readout_row(index);
        for_order!(self.dynamics.order, |N, K| columns::readout::<N, K>(
            state, &h, row
        ))
    }

    /// One row t > n of the RTS pass (`column_steps::smooth`): ŷˢ_t = ŷ_t + δ_t, its image row
    /// h · ŷˢ_t = h · ŷ_t + h · δ_t (h · ŷ_t, the filtered row, is all the pass needs of the
    /// forward pass: it is in `out`), and the right-hand side of row t − 1,
    /// d_{t−1} = (I ⊗ Sᵀ) Λ_t (ŷˢ_t − ŷ_e,t), without a product by Λ_t: A_t = Λ_t + Hᵀ R⁻¹ H,
    /// and both the forward gain (A_t (ŷ_t − ŷ_e,t) = Hᵀ R⁻¹ (z_t − H ŷ_e,t)) and this step
    /// (A_t (ŷˢ_t − ŷ_t) = d_t) were solved with A_t's factor, so
    /// Λ_t (ŷˢ_t − ŷ_e,t) = d_t + Hᵀ R⁻¹ (z_t − H ŷˢ_t), H = e₀ per column (rows t > n).
    /// `weights`: row t's (None: nominal).
    #[inline(always)]
    pub(super) fn smooth_row(&self, weights: Option<&[f64]>, row: RtsRow) {
        let (s, h0) = (&self.whitened.transition, self.lower()[(0, 0)]);
        for_order!(self.dynamics.order, |N, K| match weights {
            None => columns::smooth::<N, K>(s, h0, self.nominal(), row),
            Some(r) => columns::smooth::<N, K>(s, h0, PerPixel(r), row),
        })
    }

    /// The forward pass and, when `smooth`, the RTS pass of one image.
    pub(super) fn run(
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
    pub(super) fn passes(&self, job: Job, out: &mut [f64]) -> Result<()> {
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
