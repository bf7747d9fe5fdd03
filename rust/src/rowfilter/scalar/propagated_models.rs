//! Row models propagated through the weighted systems (SPEC §2.3 with per-pixel noise and
//! missing pixels). The plan's Λ_t is fitted to the prediction error of an image observed
//! everywhere at the nominal σ_θ². Below a missing pixel (or a much noisier one) the actual
//! prediction error is far larger: for n_y ≥ 2 the older rows of the state keep an O(1) error
//! at that column which the nominal model takes for ~σ_θ², and the RTS gain A_t⁻¹ Sᵀ Λ_{t+1}
//! then pairs the actual A_t with a Λ_{t+1} that does not follow from it (measured: 2–1e4×
//! the exact posterior's MSE at σ_x²/σ_θ² = 1e4 with 10 % of the pixels missing).
//!
//! Here, from the first row whose weights depart from the nominal ones, every predicted row's
//! model is refitted to the covariance the filter itself implies:
//!
//!   P_e,t = S A_{t−1}⁻¹ Sᵀ + Q,   Q = σ² R_x ⊗ (I − S Sᵀ)   (whitened basis),
//!
//! the band of A_{t−1}⁻¹ by selected inversion (`band_inverse`) and Λ_t by the same block
//! AR(m) fit along the row as the plan's ([P 3.11, 3.12, 3.34–3.36]), column by column (the
//! band is not Toeplitz). Both passes use these Λ_t, so the pair (A_t, Λ_{t+1}) of every RTS
//! step is consistent. The start rows keep the plan's exact stationary prior. A fit that
//! fails in float64 takes the square-root fit with the smallest working jitter, and failing
//! that the plan's Λ_t. Cost: O(W n_y b²) for the inversion and O(W (m n_y)³) for the fits
//! per row, and W n_y (b + 1) doubles per row kept for the RTS pass.

use super::plan::{Lags, Plan};
use super::row_model::JITTERS;
use super::ScalarRowFilter;
use crate::error::Result;
use crate::linalg::SymmetricBand;

/// The largest joint order of a column and its past: (m + 1) n_y for m ≤ 8, n_y ≤ 4.
const MAX_JOINT: usize = 36;

/// Sees (t, band of A_t⁻¹) of the row that [`Propagation::next_row`] makes.
pub(super) type InverseVisitor<'a> = &'a mut dyn FnMut(usize, &SymmetricBand);

/// The row models of an image with per-pixel 1/σ_θ² `weights` (0 = missing), made row after
/// row (each needs the previous row's A⁻¹, nothing below it): None where it is the plan's,
/// i.e. every row down to the first whose weights depart from the nominal 1/σ_θ² (beyond
/// 1e-12 relative: a constant map is the plain filter), and the start rows; after a
/// departure, every row's model is fitted to S A_{t−1}⁻¹ Sᵀ + Q (module doc). Only the
/// previous row's band of A⁻¹ is kept, so the causal pass and the error map hold no model
/// beyond the rows they are at.
pub(super) struct Propagation<'a> {
    filter: &'a ScalarRowFilter,
    plan: &'a Plan,
    weights: &'a [f64],
    innovation: &'a Lags,
    /// The band of S A_{t−1}⁻¹ Sᵀ + Q (reused storage).
    predicted: Lags,
    /// The band of A_{t−1}⁻¹ once the weights have departed from the nominal ones.
    inverse: Option<SymmetricBand>,
    departed: bool,
    /// The rows made so far.
    rows: usize,
}

impl<'a> Propagation<'a> {
    pub(super) fn new(
        filter: &'a ScalarRowFilter,
        plan: &'a Plan,
        weights: &'a [f64],
    ) -> Result<Self> {
        ScalarRowFilter::check_weights(weights)?;
        let innovation = &plan.innovation;
        Ok(Self {
            filter,
            plan,
            weights,
            innovation,
            predicted: innovation.clone(),
            inverse: None,
            departed: filter.row_models == super::RowModels::Implied,
            rows: 0,
        })
    }

    /// Λ_t of the next row t (None: the plan's); `each` sees its band of A_t⁻¹.
    pub(super) fn next_row(
        &mut self,
        mut each: Option<InverseVisitor<'_>>,
    ) -> Result<Option<SymmetricBand>> {
        let filter = self.filter;
        let (w, n) = (filter.width(), filter.dynamics.order);
        self.rows += 1;
        let t = self.rows;
        let row_weights = &self.weights[(t - 1) * w..t * w];
        let observed = filter.observed_band(t, self.weights);
        let nominal = 1.0 / filter.noise_var;
        self.departed |= row_weights
            .iter()
            .any(|&r| (r - nominal).abs() > 1e-12 * nominal);
        let plan_model = self.plan.precision(t);
        let (precision, z) = match (&self.inverse, t > n) {
            (Some(previous), true) => {
                filter.predicted_band(previous, self.innovation, &mut self.predicted);
                let (p, z) = filter.propagated_model(plan_model, &self.predicted, &observed)?;
                (Some(p), Some(z))
            }
            _ if self.departed || each.is_some() => {
                let z = sum(plan_model, &observed).inverse_band()?;
                (None, Some(z))
            }
            _ => (None, None),
        };
        if let (Some(f), Some(z)) = (each.as_mut(), &z) {
            f(t, z);
        }
        self.inverse = if self.departed { z } else { None };
        Ok(precision)
    }
}

impl ScalarRowFilter {
    /// The band of Q = σ² R_x ⊗ (I − S Sᵀ), the covariance the prediction of one row adds in
    /// the whitened basis (stationary state covariance σ² R_x ⊗ I, from the row's modes).
    #[cfg(test)]
    pub(super) fn innovation_band(&self) -> Lags {
        super::plan::lags_of(&self.innovation_blocks(), self.dynamics.order)
    }

    /// Hᵀ R⁻¹ H of row t (1-based) of an image with per-pixel 1/σ_θ² `weights`: the
    /// observations of the rows the state holds at t (start rows: 1..=t) onto a zero band.
    fn observed_band(&self, t: usize, weights: &[f64]) -> SymmetricBand {
        let (w, n) = (self.width(), self.dynamics.order);
        let mut observed = SymmetricBand::zeros(w * n, self.bandwidth());
        let rows = if t > n { t..=t } else { 1..=t };
        for s in rows {
            let row_weights = &weights[(s - 1) * w..s * w];
            self.add_observation(&mut observed, n.saturating_sub(s), |ell| row_weights[ell]);
        }
        observed
    }

    /// A_t = `precision` + Hᵀ R⁻¹ H of row t, summed as [`Propagation`] sums it, so that it
    /// factors wherever the propagation's did: the passes' Cholesky fallback for a batch of
    /// rows whose LDLᵀ lanes fail at the rounding of a condition ~1e17.
    pub(super) fn weighted_system(
        &self,
        precision: &SymmetricBand,
        t: usize,
        weights: &[f64],
    ) -> SymmetricBand {
        sum(precision, &self.observed_band(t, weights))
    }

    /// Λ_t for rows t = 1..=height of an image with per-pixel 1/σ_θ² `weights`, None where
    /// it is the plan's ([`Propagation`]), kept for the RTS pass.
    pub(super) fn propagated_precisions(
        &self,
        plan: &Plan,
        weights: &[f64],
        height: usize,
    ) -> Result<Vec<Option<SymmetricBand>>> {
        let mut propagation = Propagation::new(self, plan, weights)?;
        (0..height).map(|_| propagation.next_row(None)).collect()
    }

    /// (Λ_t, band of A_t⁻¹) for a row after the start: Λ_t fitted to the `predicted` band
    /// S Z Sᵀ + Q; the direct fit, else the square-root fit with the smallest jitter of
    /// [`JITTERS`] for which A_t = Λ_t + `observed` factors, else the plan's Λ_t (`nominal`).
    fn propagated_model(
        &self,
        nominal: &SymmetricBand,
        predicted: &Lags,
        observed: &SymmetricBand,
    ) -> Result<(SymmetricBand, SymmetricBand)> {
        // JITTERS[0] = 0: the plain fit first
        for jitter in JITTERS {
            if let Some(precision) = self.column_fits(predicted, jitter) {
                if let Ok(z) = sum(&precision, observed).inverse_band() {
                    return Ok((precision, z));
                }
            }
        }
        let z = sum(nominal, observed).inverse_band()?;
        Ok((nominal.clone(), z))
    }

    /// `out` = the band of S Z Sᵀ + Q: block (ℓ, ℓ + d) is S Z_{ℓ,ℓ+d} Sᵀ + Q_d[ℓ], Z_{ℓ,ℓ+d}
    /// the n × n block of the symmetric band `z`.
    fn predicted_band(&self, z: &SymmetricBand, innovation: &Lags, out: &mut Lags) {
        let n = self.dynamics.order;
        let s: [[f64; 4]; 4] =
            std::array::from_fn(|a| std::array::from_fn(|b| self.whitened.transition[(a, b)]));
        for (d, (lag, q)) in out.iter_mut().zip(innovation).enumerate() {
            lag.copy_from_slice(q);
            for (ell, block) in lag.chunks_exact_mut(n * n).enumerate() {
                // z_ij = Z(ℓn + i, (ℓ + d)n + j), then S z Sᵀ through S z
                let mut zb = [[0.0; 4]; 4];
                for (i, row) in zb.iter_mut().enumerate().take(n) {
                    for (j, value) in row.iter_mut().enumerate().take(n) {
                        *value = z.get(ell * n + i, (ell + d) * n + j);
                    }
                }
                // only the n × n corners: the sums run over 0..n
                let mut sz = [[0.0; 4]; 4];
                for (a, row) in sz.iter_mut().enumerate().take(n) {
                    for (j, value) in row.iter_mut().enumerate().take(n) {
                        for i in 0..n {
                            *value += s[a][i] * zb[i][j];
                        }
                    }
                }
                for a in 0..n {
                    for b in 0..n {
                        let mut value = 0.0;
                        for j in 0..n {
                            value += sz[a][j] * s[b][j];
                        }
                        block[a * n + b] += value;
                    }
                }
            }
        }
    }

    /// Λ = Σ_ℓ B_ℓᵀ D_ℓ⁻¹ B_ℓ fitted to a band of no row structure, every column its own fit
    /// (`fit_columns`). None if some column's joint covariance does not factor.
    fn column_fits(&self, lags: &Lags, jitter: f64) -> Option<SymmetricBand> {
        let mut out = SymmetricBand::zeros(self.width() * self.dynamics.order, self.bandwidth());
        let size = (self.ar_order + 1) * self.dynamics.order;
        self.fit_columns(lags, jitter, &mut out, size)?;
        Some(out)
    }

    /// Adds every column's term of Λ to `out` (`size` = (m + 1) n_y, the joint order of a column
    /// and its full past): C = L D Lᵀ (L unit lower), C the joint covariance of the past
    /// ℓ − m, …, ℓ − 1 and column ℓ (in that order) plus `jitter` max_i C_ii I; the last n_y
    /// rows of L⁻¹ are [−Γ_ℓ, I] and their D the innovation variances of the block AR fit
    /// ([P 3.34–3.36]), so the term is Σ_k m_kᵀ m_k / D_k over those rows m_k: the
    /// square-root fit of `root_contribution` without its square roots and allocations (this
    /// runs for every column of every weighted row), four columns at a time, one per vector
    /// lane (`fit_lanes`).
    fn fit_columns(
        &self,
        lags: &Lags,
        jitter: f64,
        out: &mut SymmetricBand,
        size: usize,
    ) -> Option<()> {
        let s = size.min(MAX_JOINT);
        let mut fit = LaneFit::new();
        for ell0 in (0..self.width()).step_by(LANES) {
            self.fit_lanes(lags, jitter, out, s, ell0, &mut fit)?;
        }
        Some(())
    }

    /// The terms of columns ℓ₀ + l, l = 0..4, below the width, added to `out` (`fit_columns`,
    /// joint order `s`), column ℓ₀ + l in lane l of a packed lower triangle. For ℓ < m, with a
    /// shorter past, C is padded to order `s` by leading identity rows (uncorrelated with the
    /// rest: their terms vanish); a lane beyond the width holds the identity and adds nothing.
    fn fit_lanes(
        &self,
        lags: &Lags,
        jitter: f64,
        out: &mut SymmetricBand,
        s: usize,
        ell0: usize,
        fit: &mut LaneFit,
    ) -> Option<()> {
        let (w, n) = (self.width(), self.dynamics.order);
        let LaneFit {
            joint,
            pivots,
            rows,
            terms,
        } = fit;
        // (first column, leading identity rows) of each lane's past
        let mut pasts = [(0, s); LANES];
        for (l, past) in pasts.iter_mut().enumerate() {
            if ell0 + l < w {
                *past = self.joint_covariance(lags, s, ell0 + l, l, joint);
            } else {
                for q in 0..s {
                    for c in 0..=q {
                        joint[packed(q, c)][l] = if c == q { 1.0 } else { 0.0 };
                    }
                }
            }
        }
        let mut top = [0.0f64; LANES];
        for (l, &(_, lead)) in pasts.iter().enumerate() {
            top[l] = (lead..s)
                .map(|q| joint[packed(q, q)][l])
                .fold(0.0, f64::max);
        }
        for q in 0..s {
            let diagonal = &mut joint[packed(q, q)];
            for l in 0..LANES {
                diagonal[l] += jitter * top[l];
            }
        }
        if !ldl_lanes(joint, pivots, s) {
            return None;
        }
        terms_lanes(joint, pivots, rows, terms, s, n);
        // lane by lane, so that the terms of the columns reach each entry in column order
        let offset = out.bandwidth();
        for ((l, lane), &(first, lead)) in terms.iter().enumerate().zip(&pasts) {
            if ell0 + l >= w {
                break;
            }
            let base = first * n;
            for r in lead..s {
                // entry (base + r − lead, base + c − lead) sits at offset − r + c of its row
                let row = &mut out.lower_row_mut(base + r - lead)[offset - r + lead..=offset];
                for (entry, term) in row.iter_mut().zip(&lane[packed(r, lead)..]) {
                    *entry += term;
                }
            }
        }
        Some(())
    }

    /// Lane `l` of `joint` = C of column ℓ (`fit_columns`), padded to order `s` by leading
    /// identity rows; returns (the first column of ℓ's past, the number of those rows).
    fn joint_covariance(
        &self,
        lags: &Lags,
        s: usize,
        ell: usize,
        l: usize,
        joint: &mut [[f64; LANES]],
    ) -> (usize, usize) {
        let (n, m) = (self.dynamics.order, self.ar_order);
        let nn = n * n;
        let first = ell.saturating_sub(m);
        let blocks = ell - first + 1;
        let lead = s - blocks * n;
        for q in 0..s {
            for c in 0..q.min(lead) {
                joint[packed(q, c)][l] = 0.0;
            }
            if q < lead {
                joint[packed(q, q)][l] = 1.0;
            }
        }
        for i in 0..blocks {
            for j in 0..=i {
                // block (i, j) of C: Cov(v_{first+i}, v_{first+j}), the transpose of lag
                // i − j's block at column first + j
                let column = first + j;
                let at = &lags[i - j][column * nn..(column + 1) * nn];
                for r in 0..n {
                    let row = packed(lead + i * n + r, lead + j * n);
                    // the lower triangle only: c ≤ r within a diagonal block
                    let columns = if i == j { r + 1 } else { n };
                    for c in 0..columns {
                        joint[row + c][l] = if i == j {
                            0.5 * (at[c * n + r] + at[r * n + c])
                        } else {
                            at[c * n + r]
                        };
                    }
                }
            }
        }
        (first, lead)
    }
}

/// Columns fitted at once by `fit_lanes`.
const LANES: usize = 4;

/// Where entry (i, k), k ≤ i, of a lower triangle is kept in packed row-major order.
#[inline(always)]
fn packed(i: usize, k: usize) -> usize {
    i * (i + 1) / 2 + k
}

/// C = L D Lᵀ in place, lane by lane (L unit lower, below the diagonal of the packed `joint`;
/// D in `pivots`); false if some pivot is not positive and finite.
fn ldl_lanes(joint: &mut [[f64; LANES]], pivots: &mut [[f64; LANES]; MAX_JOINT], s: usize) -> bool {
    for i in 0..s {
        let row_i = packed(i, 0);
        for k in 0..i {
            let row_k = packed(k, 0);
            let mut sum = joint[row_i + k];
            for p in 0..k {
                let (a, b, d) = (joint[row_i + p], joint[row_k + p], pivots[p]);
                for l in 0..LANES {
                    sum[l] -= a[l] * b[l] * d[l];
                }
            }
            for l in 0..LANES {
                sum[l] /= pivots[k][l];
            }
            joint[row_i + k] = sum;
        }
        let mut pivot = joint[row_i + i];
        for p in 0..i {
            let (a, d) = (joint[row_i + p], pivots[p]);
            for l in 0..LANES {
                pivot[l] -= a[l] * a[l] * d[l];
            }
        }
        if !pivot.iter().all(|&v| v > 0.0 && v.is_finite()) {
            return false;
        }
        pivots[i] = pivot;
    }
    true
}

/// `terms` (packed, lane by lane) = Σ_k m_kᵀ m_k / D_k over the last `n` rows m_k of L⁻¹,
/// from the factor of `ldl_lanes`; `rows` keeps those rows.
fn terms_lanes(
    joint: &[[f64; LANES]],
    pivots: &[[f64; LANES]; MAX_JOINT],
    rows: &mut [[[f64; LANES]; MAX_JOINT]; 4],
    terms: &mut [Vec<f64>; LANES],
    s: usize,
    n: usize,
) {
    // rows s − n.. of L⁻¹ (unit lower): m_r = 1, m_c = −Σ_{j=c+1..r} m_j L_jc; entries
    // beyond r stay zero from `LaneFit::new`
    let mut scale = [[0.0f64; LANES]; 4];
    for (k, row) in rows.iter_mut().enumerate().take(n) {
        let r = s - n + k;
        row[r] = [1.0; LANES];
        for c in (0..r).rev() {
            let mut sum = [0.0f64; LANES];
            for j in c + 1..=r {
                let (a, b) = (row[j], joint[packed(j, c)]);
                for l in 0..LANES {
                    sum[l] += a[l] * b[l];
                }
            }
            row[c] = sum.map(|v| -v);
        }
        scale[k] = pivots[r].map(|d| 1.0 / d);
    }
    for r in 0..s {
        for c in 0..=r {
            let mut value = [0.0f64; LANES];
            for k in 0..n {
                for l in 0..LANES {
                    value[l] += rows[k][r][l] * rows[k][c][l] * scale[k][l];
                }
            }
            for (lane, v) in terms.iter_mut().zip(value) {
                lane[packed(r, c)] = v;
            }
        }
    }
}

/// The work space of `fit_lanes`, one lane per column: C packed and then its L D Lᵀ factor, D,
/// the last n_y rows of L⁻¹, and the columns' terms of Λ (packed likewise, lane by lane).
struct LaneFit {
    joint: Vec<[f64; LANES]>,
    pivots: [[f64; LANES]; MAX_JOINT],
    rows: [[[f64; LANES]; MAX_JOINT]; 4],
    terms: [Vec<f64>; LANES],
}

impl LaneFit {
    fn new() -> Self {
        Self {
            joint: vec![[0.0; LANES]; packed(MAX_JOINT, 0)],
            pivots: [[0.0; LANES]; MAX_JOINT],
            rows: [[[0.0; LANES]; MAX_JOINT]; 4],
            terms: std::array::from_fn(|_| vec![0.0; packed(MAX_JOINT, 0)]),
        }
    }
}

/// a + b for bands of the same order and bandwidth.
fn sum(a: &SymmetricBand, b: &SymmetricBand) -> SymmetricBand {
    let mut out = a.clone();
    out.add_band(b);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::FieldModel;
    use crate::rowfilter::row_modes::ModeSet;
    use faer::Mat;

    /// A filter and the predicted band of its row `t` for pixel weights varying 30× about
    /// the nominal one (so that no two columns have the same model).
    fn predicted(order: [usize; 2], rho: f64, width: usize) -> (ScalarRowFilter, Lags) {
        let model = FieldModel::new(&[rho, rho], &order, 1.0).unwrap();
        let filter = ScalarRowFilter::new(&model, 0.5, width, None, ModeSet::Exact).unwrap();
        let height = 6;
        let weights: Vec<f64> = (0..height * width)
            .map(|k| 2.0 * 30f64.powf(((k * 7919) % 97) as f64 / 96.0 - 0.5))
            .collect();
        let plan = filter.plan(height).unwrap();
        let mut propagation = Propagation::new(&filter, &plan, &weights).unwrap();
        let mut previous = None;
        for _ in 0..height - 1 {
            let mut store = |_: usize, z: &SymmetricBand| previous = Some(z.clone());
            propagation.next_row(Some(&mut store)).unwrap();
        }
        let innovation = filter.innovation_band();
        let mut lags = innovation.clone();
        filter.predicted_band(&previous.unwrap(), &innovation, &mut lags);
        (filter, lags)
    }

    #[test]
    fn the_lane_fits_equal_the_direct_fit() {
        // width 23: the first lanes with a shorter past, the last group one lane short
        for (order, rho) in [
            ([1, 1], 0.9),
            ([2, 2], 0.9),
            ([3, 2], 0.8),
            ([2, 4], 0.7),
            ([4, 4], 0.6),
        ] {
            let (filter, lags) = predicted(order, rho, 23);
            let n = filter.dynamics.order;
            let band: Vec<Mat<f64>> = lags
                .iter()
                .map(|lag| Mat::from_fn(lag.len() / (n * n), n * n, |l, ab| lag[l * n * n + ab]))
                .collect();
            let direct = filter.precision(&band, None).unwrap();
            let lanes = filter.column_fits(&lags, 0.0).unwrap();
            let scale = (0..direct.size())
                .map(|i| direct.get(i, i))
                .fold(0.0, f64::max);
            for i in 0..direct.size() {
                for k in i.saturating_sub(direct.bandwidth())..=i {
                    let (a, b) = (direct.get(i, k), lanes.get(i, k));
                    assert!(
                        (a - b).abs() <= 1e-10 * scale,
                        "{order:?} ({i}, {k}): {a} vs {b}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_predicted_band_is_the_dense_product() {
        let (filter, _) = predicted([2, 2], 0.9, 9);
        let n = filter.dynamics.order;
        let size = 9 * n;
        // a symmetric band Z and the band of S Z Sᵀ (I ⊗ S per column) formed densely
        let mut z = SymmetricBand::zeros(size, filter.bandwidth());
        for i in 0..size {
            for k in i.saturating_sub(filter.bandwidth())..=i {
                z.add(
                    i,
                    k,
                    if i == k {
                        3.0
                    } else {
                        0.1 * ((i * 31 + k * 17) % 13) as f64 - 0.6
                    },
                );
            }
        }
        let dense = nalgebra::DMatrix::from_fn(size, size, |i, k| z.get(i, k));
        let s = nalgebra::DMatrix::from_fn(size, size, |i, k| {
            if i / n == k / n {
                filter.whitened.transition[(i % n, k % n)]
            } else {
                0.0
            }
        });
        let moved = &s * dense * s.transpose();
        let zeros: Lags = filter
            .innovation_band()
            .iter()
            .map(|l| vec![0.0; l.len()])
            .collect();
        let mut lags = zeros.clone();
        filter.predicted_band(&z, &zeros, &mut lags);
        for (d, lag) in lags.iter().enumerate() {
            for (ell, block) in lag.chunks_exact(n * n).enumerate() {
                for a in 0..n {
                    for b in 0..n {
                        let want = moved[(ell * n + a, (ell + d) * n + b)];
                        assert!(
                            (block[a * n + b] - want).abs() < 1e-12,
                            "lag {d} column {ell}"
                        );
                    }
                }
            }
        }
    }
}
