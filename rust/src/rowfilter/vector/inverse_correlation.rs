//! The smoothed error variance of one mode of the optimal vector row filter in information
//! form (SPEC §2.2, §2.4): where the RTS recursion's covariances lose their digits.
//!
//! Mode j of the vector filter is a column process of covariance v_j R_y (R_y the H × H
//! Toeplitz correlation of the rows' axis) seen through white noise σ_θ², so its smoothed
//! error variance is, in units of v_j, with c = σ_θ²/v_j,
//!
//!   diag (R_y⁻¹ + I/c)⁻¹ = c diag (I + c R_y⁻¹)⁻¹.
//!
//! R_y⁻¹ is a band of width n_y, written without a subtraction from the exact stationary
//! start's density p(x_0..x_{n−1}) Π_t p(x_t | x_{t−n..t−1}) (SPEC §1.3): T_kᵀ T_k on the first
//! k = min(n, H) rows (T = L⁻¹, R_y[:n,:n] = L Lᵀ, the whitening of the filter's row basis)
//! plus g gᵀ / β̃² on rows t − n..t for every later row, g = (−α_n, …, −α_1, 1) [P 2.8, 2.11].
//! At c ≪ 1 the band is I plus a small term: its factor and the diagonal of its inverse
//! (`band_inverse`) keep every digit, while the RTS form P_t + J (Pˢ − P_e) Jᵀ works with
//! covariances whose entries along the observed rows are ~c of their largest and loses
//! ~ε/c of the map (relative errors of 1e-4 at σ_θ² = 1e-12 σ_x² for (2,2), orders of
//! magnitude at 1e-16). At c ≳ 1 the roles swap (I + c R_y⁻¹ takes R_y's condition), so the
//! filter uses this form for the modes with c ≤ [`INFORMATION_RATIO`] only.

use crate::error::Result;
use crate::field::AxisModel;
use crate::linalg::SymmetricBand;
use crate::rowfilter::{StateMatrix, MAX_ROW_ORDER};

/// σ_θ²/v_j at or below which a mode's smoothed map comes from the information form: 1e-4
/// was never worse, against an 80-digit posterior, than the RTS form or 1e-2 and 1e-6.
pub const INFORMATION_RATIO: f64 = 1e-4;

/// R_y⁻¹ of the rows' axis, for any number of rows (module doc).
#[derive(Debug, Clone)]
pub(crate) struct InverseCorrelation {
    order: usize,
    /// T = L⁻¹ of the first n rows' correlation R_y[:n,:n] = L Lᵀ.
    whitening: StateMatrix,
    /// g = (−α_n, …, −α_1, 1): the innovation of row t from rows t − n..t.
    difference: [f64; MAX_ROW_ORDER + 1],
    innovation: f64,
}

impl InverseCorrelation {
    /// The precision of the axis `y` whose first n rows' correlation R_y[:n,:n] = L Lᵀ has
    /// the inverse factor `whitening` T = L⁻¹ (`RowDynamics::whitened`'s).
    pub(crate) fn new(y: &AxisModel, whitening: &StateMatrix) -> Self {
        let order = y.order();
        let mut difference = [0.0; MAX_ROW_ORDER + 1];
        for (i, a) in y.ar_coefficients().iter().enumerate() {
            difference[order - 1 - i] = -a;
        }
        difference[order] = 1.0;
        Self {
            order,
            whitening: *whitening,
            difference,
            innovation: y.beta_tilde_sq(),
        }
    }

    /// I + c R_y⁻¹ for `height` rows (bandwidth n).
    fn system(&self, height: usize, c: f64) -> SymmetricBand {
        let n = self.order;
        let mut a = SymmetricBand::zeros(height, n);
        let k = n.min(height);
        let t = self.whitening.view((0, 0), (k, k));
        let start = t.transpose() * t;
        for i in 0..k {
            for j in 0..=i {
                a.add(i, j, c * start[(i, j)]);
            }
        }
        let g = &self.difference[..=n];
        let weight = c / self.innovation;
        for row in n..height {
            let first = row - n;
            for i in 0..=n {
                for j in 0..=i {
                    a.add(first + i, first + j, weight * g[i] * g[j]);
                }
            }
        }
        for i in 0..height {
            a.add(i, i, 1.0);
        }
        a
    }

    /// `out[t]` = the smoothed error variance of row t of a mode with noise ratio `c`, in
    /// units of the mode's variance: c [(I + c R_y⁻¹)⁻¹]_tt. Error: the band does not factor
    /// (not positive definite in float64).
    pub(crate) fn smoothed_variances(&self, c: f64, out: &mut [f64]) -> Result<()> {
        let inverse = self.system(out.len(), c).inverse_band()?;
        for (t, v) in out.iter_mut().enumerate() {
            *v = c * inverse.get(t, t);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rowfilter::row_dynamics::RowDynamics;
    use nalgebra::DMatrix;

    fn precision(rho: f64, order: usize) -> InverseCorrelation {
        let y = AxisModel::new(rho, order).unwrap();
        let whitening = RowDynamics::new(&y).whitened().unwrap().whitening;
        InverseCorrelation::new(&y, &whitening)
    }

    fn correlation(rho: f64, order: usize, height: usize) -> DMatrix<f64> {
        let y = AxisModel::new(rho, order).unwrap();
        DMatrix::from_fn(height, height, |i, j| y.correlation(i.abs_diff(j) as f64))
    }

    #[test]
    fn the_band_is_the_inverse_of_the_rows_correlation() {
        for order in 1..=MAX_ROW_ORDER {
            for height in [1, 2, order, order + 1, 12] {
                let q = precision(0.7, order).system(height, 1.0);
                let dense = DMatrix::from_fn(height, height, |i, j| {
                    q.get(i, j) - if i == j { 1.0 } else { 0.0 }
                });
                let product = dense * correlation(0.7, order, height);
                let error = (product - DMatrix::identity(height, height)).amax();
                assert!(error < 1e-9, "order {order}, height {height}: {error:e}");
            }
        }
    }

    #[test]
    fn the_variances_are_the_dense_posterior_and_r_at_extreme_snr() {
        for order in 1..=MAX_ROW_ORDER {
            let ry = correlation(0.8, order, 20);
            let c = 1e-3;
            let posterior =
                &ry - &ry * (&ry + DMatrix::identity(20, 20) * c).try_inverse().unwrap() * &ry;
            let mut out = vec![0.0; 20];
            precision(0.8, order)
                .smoothed_variances(c, &mut out)
                .unwrap();
            for (t, v) in out.iter().enumerate() {
                let rel = (v / posterior[(t, t)] - 1.0).abs();
                assert!(rel < 1e-8, "order {order}, row {t}: {rel:e}");
            }
            // at c = 1e-30 the posterior is c (1 − O(c)) to the last digit
            precision(0.8, order)
                .smoothed_variances(1e-30, &mut out)
                .unwrap();
            assert!(
                out.iter().all(|v| (v / 1e-30 - 1.0).abs() < 1e-14),
                "{out:?}"
            );
        }
    }
}
