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

use super::{ScalarRowFilter, JITTERS};
use crate::banded::SymmetricBand;
use crate::error::Result;
use crate::vector_row_filter::Small;

/// A band of blocks, lag by lag: `lags[d]` holds the n × n blocks Cov(v_ℓ, v_{ℓ+d}) of
/// ℓ = 0..W − d, row-major, one after the other (entry (ℓ, a, b) at ℓ n² + a n + b).
pub(super) type Lags = Vec<Vec<f64>>;

/// The largest joint order of a column and its past: (m + 1) n_y for m ≤ 8, n_y ≤ 4.
const MAX_JOINT: usize = 36;

/// Sees (t, band of A_t⁻¹) for every row t of `propagated_precisions`.
pub(super) type InverseVisitor<'a> = &'a mut dyn FnMut(usize, &SymmetricBand);

impl ScalarRowFilter {
    /// The band of Q = σ² R_x ⊗ (I − S Sᵀ), the covariance the prediction of one row adds in
    /// the whitened basis (stationary state covariance σ² R_x ⊗ I, from the row's modes).
    pub(super) fn innovation_band(&self) -> Lags {
        let n = self.dynamics.order;
        let mut unit = Small::zeros();
        unit.view_mut((0, 0), (n, n)).fill_with_identity();
        let added = unit - self.transition * self.transition.transpose();
        let modal: Vec<Small> = self.mode_var.iter().map(|v| added * *v).collect();
        self.band(&modal)
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

    /// Λ_t for rows t = 1..=height of an image with per-pixel 1/σ_θ² `weights` (0 = missing),
    /// None where it is the plan's: every row down to the first whose weights depart from
    /// the nominal 1/σ_θ² (beyond 1e-12 relative: a constant map is the plain filter), and
    /// the start rows; after a departure, every row's model is fitted to S A_{t−1}⁻¹ Sᵀ + Q
    /// (module doc). With `each`, it sees every row's band of A_t⁻¹ as it is made.
    pub(super) fn propagated_precisions(
        &self,
        plan: &super::Plan,
        weights: &[f64],
        height: usize,
        mut each: Option<InverseVisitor<'_>>,
    ) -> Result<Vec<Option<SymmetricBand>>> {
        let (w, n) = (self.width(), self.dynamics.order);
        Self::check_weights(weights)?;
        let nominal = 1.0 / self.noise_var;
        let departs = |row: &[f64]| row.iter().any(|&r| (r - nominal).abs() > 1e-12 * nominal);
        let innovation = plan.innovation.get_or_init(|| self.innovation_band());
        let mut predicted = innovation.clone();
        let mut out = Vec::with_capacity(height);
        let mut observed = SymmetricBand::zeros(w * n, self.bandwidth());
        // the band of A_{t−1}⁻¹ once the weights have departed from the nominal ones
        let mut inverse: Option<SymmetricBand> = None;
        let mut departed = false;
        for t in 1..=height {
            let row_weights = &weights[(t - 1) * w..t * w];
            if t > n {
                observed = SymmetricBand::zeros(w * n, self.bandwidth());
            }
            self.add_observation(&mut observed, n.saturating_sub(t), |ell| row_weights[ell]);
            departed |= departs(row_weights);
            let (precision, z) = match (&inverse, t > n) {
                (Some(previous), true) => {
                    self.predicted_band(previous, innovation, &mut predicted);
                    let (p, z) = self.propagated_model(plan.precision(t), &predicted, &observed)?;
                    (Some(p), Some(z))
                }
                _ if departed || each.is_some() => {
                    let z = sum(plan.precision(t), &observed).inverse_band()?;
                    (None, Some(z))
                }
                _ => (None, None),
            };
            if let (Some(f), Some(z)) = (each.as_mut(), &z) {
                f(t, z);
            }
            inverse = if departed { z } else { None };
            out.push(precision);
        }
        Ok(out)
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
            std::array::from_fn(|a| std::array::from_fn(|b| self.transition[(a, b)]));
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
                let sz: [[f64; 4]; 4] = std::array::from_fn(|a| {
                    std::array::from_fn(|j| (0..n).map(|i| s[a][i] * zb[i][j]).sum())
                });
                for a in 0..n {
                    for b in 0..n {
                        block[a * n + b] += (0..n).map(|j| sz[a][j] * s[b][j]).sum::<f64>();
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
    /// runs for every column of every weighted row). For the columns ℓ < m, with a shorter
    /// past, C is padded to order `size` by leading identity rows (uncorrelated with the rest:
    /// their terms vanish).
    fn fit_columns(
        &self,
        lags: &Lags,
        jitter: f64,
        out: &mut SymmetricBand,
        size: usize,
    ) -> Option<()> {
        let (w, n, m) = (self.width(), self.dynamics.order, self.ar_order);
        let nn = n * n;
        let s = size.min(MAX_JOINT);
        let mut joint = [[0.0f64; MAX_JOINT]; MAX_JOINT];
        let mut pivots = [0.0f64; MAX_JOINT];
        for ell in 0..w {
            let first = ell.saturating_sub(m);
            let blocks = ell - first + 1;
            let lead = s - blocks * n;
            for (q, row) in joint.iter_mut().enumerate().take(s) {
                row[..lead.min(q)].fill(0.0);
                if q < lead {
                    row[q] = 1.0;
                }
            }
            for i in 0..blocks {
                for j in 0..=i {
                    // block (i, j) of C: Cov(v_{first+i}, v_{first+j}), the transpose of lag
                    // i − j's block at column first + j
                    let column = first + j;
                    let at = &lags[i - j][column * nn..(column + 1) * nn];
                    for r in 0..n {
                        let row = &mut joint[lead + i * n + r];
                        for c in 0..n {
                            row[lead + j * n + c] = if i == j {
                                0.5 * (at[c * n + r] + at[r * n + c])
                            } else {
                                at[c * n + r]
                            };
                        }
                    }
                }
            }
            let top = (lead..s).map(|q| joint[q][q]).fold(0.0, f64::max);
            for (r, row) in joint.iter_mut().enumerate().take(s) {
                row[r] += jitter * top;
            }
            for i in 0..s {
                for k in 0..i {
                    let mut sum = joint[i][k];
                    for p in 0..k {
                        sum -= joint[i][p] * joint[k][p] * pivots[p];
                    }
                    joint[i][k] = sum / pivots[k];
                }
                let mut pivot = joint[i][i];
                for p in 0..i {
                    pivot -= joint[i][p] * joint[i][p] * pivots[p];
                }
                if !(pivot > 0.0 && pivot.is_finite()) {
                    return None;
                }
                pivots[i] = pivot;
            }
            // rows size − n.. of L⁻¹ (unit lower): m_r = 1, m_c = −Σ_{j=c+1..r} m_j L_jc
            let mut rows = [[0.0f64; MAX_JOINT]; 4];
            let mut scale = [0.0f64; 4];
            for (k, row) in rows.iter_mut().enumerate().take(n) {
                let r = s - n + k;
                row[r] = 1.0;
                for c in (0..r).rev() {
                    let sum: f64 = (c + 1..=r).map(|j| row[j] * joint[j][c]).sum();
                    row[c] = -sum;
                }
                scale[k] = 1.0 / pivots[r];
            }
            for r in lead..s {
                for c in lead..=r {
                    let value: f64 = (0..n).map(|k| rows[k][r] * rows[k][c] * scale[k]).sum();
                    out.add(first * n + r - lead, first * n + c - lead, value);
                }
            }
        }
        Some(())
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
    use crate::field_model::FieldModel;
    use crate::row_modes::ModeSet;
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
        let mut inverses = Vec::new();
        let mut keep = |_: usize, z: &SymmetricBand| inverses.push(z.clone());
        filter
            .propagated_precisions(&plan, &weights, height, Some(&mut keep))
            .unwrap();
        let innovation = filter.innovation_band();
        let mut lags = innovation.clone();
        filter.predicted_band(&inverses[height - 2], &innovation, &mut lags);
        (filter, lags)
    }

    #[test]
    fn the_unrolled_column_fits_equal_the_direct_fit() {
        for (order, rho) in [([1, 1], 0.9), ([2, 2], 0.9), ([3, 2], 0.8), ([2, 4], 0.7)] {
            let (filter, lags) = predicted(order, rho, 23);
            let n = filter.dynamics.order;
            let band: Vec<Mat<f64>> = lags
                .iter()
                .map(|lag| Mat::from_fn(lag.len() / (n * n), n * n, |l, ab| lag[l * n * n + ab]))
                .collect();
            let direct = filter.precision(&band, None).unwrap();
            let unrolled = filter.column_fits(&lags, 0.0).unwrap();
            let scale = (0..direct.size())
                .map(|i| direct.get(i, i))
                .fold(0.0, f64::max);
            for i in 0..direct.size() {
                for k in i.saturating_sub(direct.bandwidth())..=i {
                    let (a, b) = (direct.get(i, k), unrolled.get(i, k));
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
                filter.transition[(i % n, k % n)]
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
