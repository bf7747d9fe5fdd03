//! The modes on which the quasi-optimal row filter computes the band of the optimal
//! prediction-error covariance P_e (SPEC §2.3 generalised).
//!
//! Every matrix of the row-state filter is a Kronecker product with V_x = σ² Toeplitz(R_x)
//! (SPEC §2.2), so P_e = Σ_j u_j u_jᵀ ⊗ v_j M_j over the modes (u_j, v_j) of V_x, each mode
//! running its own n_y-dimensional Riccati (M_j in units of v_j). Two mode sets:
//! - `Exact`: the eigenbasis of Toeplitz(R_x) on the W points of the row (faer, O(W³) once),
//!   edges included;
//! - `Toeplitz`: the Fourier modes of the infinite row. The band is then Toeplitz,
//!   C_d = (1/π) ∫₀^π cos(dω) v(ω) M(ω) dω with v(ω) = σ² S_x(ω),
//!   S_x(ω) ∝ (1 − 2ρ_x cos ω + ρ_x²)^(−n_x) the spectral density of the x axis [P 2.11]:
//!   trapezoid rule on G + 1 frequencies (exponentially accurate for a periodic analytic
//!   integrand; G ≥ 24/(1 − ρ_x)), O(G) per row and no O(W³) step. Exact in the interior of
//!   wide rows; near the ends of a row the true P_e is larger (fewer neighbours), which this
//!   set ignores (the loss is measured in the README).

use crate::axis_model::AxisModel;
use crate::axis_modes::AxisModes;
use crate::error::Result;
use crate::vector_row_filter::Small;
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};

/// Fewest and most trapezoid intervals of the Toeplitz mode set.
const MIN_INTERVALS: usize = 256;
const MAX_INTERVALS: usize = 1 << 16;

/// A mode set of one row width.
#[derive(Debug, Clone)]
pub enum RowModes {
    /// Eigenbasis of Toeplitz(R_x) on the row.
    Exact(AxisModes),
    /// Fourier modes of the infinite row (trapezoid nodes ω_g = πg/G).
    Toeplitz {
        /// Row width W.
        width: usize,
        /// Normalised spectral density λ_g = S_x(ω_g) (trapezoid mean 1).
        values: Vec<f64>,
        /// Trapezoid weights 1/G (1/(2G) at both ends).
        weights: Vec<f64>,
    },
}

impl RowModes {
    /// The eigenbasis of the `axis` correlation on `width` points.
    pub fn exact(axis: &AxisModel, width: usize) -> Result<Self> {
        Ok(Self::Exact(AxisModes::new(axis, width)?))
    }

    /// The Fourier modes of the infinite row of the `axis` model, for rows of `width` points.
    pub fn toeplitz(axis: &AxisModel, width: usize) -> Self {
        let intervals = quadrature_intervals(axis.rho());
        let step = std::f64::consts::PI / intervals as f64;
        let weights: Vec<f64> = (0..=intervals)
            .map(|g| {
                let end = g == 0 || g == intervals;
                if end {
                    0.5 / intervals as f64
                } else {
                    1.0 / intervals as f64
                }
            })
            .collect();
        let (rho, order) = (axis.rho(), axis.order() as i32);
        let raw: Vec<f64> = (0..=intervals)
            .map(|g| (1.0 - 2.0 * rho * (step * g as f64).cos() + rho * rho).powi(-order))
            .collect();
        let mean: f64 = raw.iter().zip(&weights).map(|(s, w)| s * w).sum();
        Self::Toeplitz {
            width,
            values: raw.iter().map(|s| s / mean).collect(),
            weights,
        }
    }

    /// Whether the band is Toeplitz (the same blocks at every column of the row).
    pub fn is_toeplitz(&self) -> bool {
        matches!(self, Self::Toeplitz { .. })
    }

    /// Row width W.
    pub fn width(&self) -> usize {
        match self {
            Self::Exact(modes) => modes.size(),
            Self::Toeplitz { width, .. } => *width,
        }
    }

    /// λ_j of every mode (mode variance σ² λ_j).
    pub fn values(&self) -> &[f64] {
        match self {
            Self::Exact(modes) => &modes.values,
            Self::Toeplitz { values, .. } => values,
        }
    }

    /// Band blocks of Σ_j u_j u_jᵀ ⊗ M_j for the lags d = 0..=max_lag: block (ℓ, ℓ + d) is row
    /// ℓ of the d-th matrix ((W − d) × n², row-major n×n blocks); `modal` = M_j per mode.
    pub fn band(&self, modal: &[Small], n: usize, max_lag: usize) -> Vec<Mat<f64>> {
        let w = self.width();
        let lags = 0..=max_lag.min(w - 1);
        match self {
            Self::Exact(modes) => {
                let u = &modes.vectors;
                let flat = Mat::from_fn(w, n * n, |j, ab| modal[j][(ab / n, ab % n)]);
                lags.map(|d| {
                    let pairs = Mat::from_fn(w - d, w, |l, j| u[(l, j)] * u[(l + d, j)]);
                    let mut out = Mat::<f64>::zeros(w - d, n * n);
                    matmul(&mut out, Accum::Replace, &pairs, &flat, 1.0, Par::Seq);
                    crate::vector_state::clear_upper_state();
                    out
                })
                .collect()
            }
            Self::Toeplitz { weights, .. } => {
                let step = std::f64::consts::PI / (weights.len() - 1) as f64;
                lags.map(|d| {
                    let mut block = Small::zeros();
                    for (g, (m, wg)) in modal.iter().zip(weights).enumerate() {
                        block += m * (wg * (step * (d * g) as f64).cos());
                    }
                    Mat::from_fn(w - d, n * n, |_, ab| block[(ab / n, ab % n)])
                })
                .collect()
            }
        }
    }
}

/// Trapezoid intervals G for ρ_x: the error decays like ρ_x^(2G), so G = 24/(1 − ρ_x)
/// leaves ~e^(−48).
fn quadrature_intervals(rho: f64) -> usize {
    ((24.0 / (1.0 - rho)).ceil() as usize).clamp(MIN_INTERVALS, MAX_INTERVALS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toeplitz_band_of_the_prior_is_the_correlation() {
        for (rho, order) in [(0.5, 1), (0.9, 2), (0.95, 4), (0.99, 1)] {
            let axis = AxisModel::new(rho, order).unwrap();
            let modes = RowModes::toeplitz(&axis, 40);
            let identity = vec![Small::identity(); modes.values().len()];
            let scaled: Vec<Small> = identity
                .iter()
                .zip(modes.values())
                .map(|(m, v)| m * *v)
                .collect();
            let band = modes.band(&scaled, 1, 6);
            for (d, lag) in band.iter().enumerate() {
                let want = axis.correlation(d as f64);
                for l in 0..lag.nrows() {
                    assert!((lag[(l, 0)] - want).abs() < 1e-12, "{rho} {order} {d}");
                }
            }
        }
    }

    #[test]
    fn exact_band_of_the_prior_is_the_correlation() {
        let axis = AxisModel::new(0.8, 2).unwrap();
        let modes = RowModes::exact(&axis, 30).unwrap();
        let scaled: Vec<Small> = modes
            .values()
            .iter()
            .map(|v| Small::identity() * *v)
            .collect();
        let band = modes.band(&scaled, 1, 3);
        for (d, lag) in band.iter().enumerate() {
            for l in 0..lag.nrows() {
                assert!((lag[(l, 0)] - axis.correlation(d as f64)).abs() < 1e-12);
            }
        }
    }
}
