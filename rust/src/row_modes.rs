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
use crate::banded::{Arith, Plain};
use crate::error::Result;
use crate::vector_row_filter::Small;
use faer::Mat;

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
        let (w, last) = (self.width(), max_lag.min(self.width() - 1));
        match self {
            Self::Exact(modes) => exact_band(modes, modal, n, last),
            Self::Toeplitz { weights, .. } => {
                let step = std::f64::consts::PI / (weights.len() - 1) as f64;
                (0..=last)
                    .map(|d| {
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

/// Rows ℓ of the band accumulated at once by [`exact_band`] (their sums stay in L1).
const BAND_ROWS: usize = 32;

/// [`RowModes::band`] of the eigenbasis: block (ℓ, ℓ + d) = Σ_j u_ℓj u_(ℓ+d)j M_j. Rows ℓ
/// in groups of [`BAND_ROWS`], the modes j in order: column j of U is contiguous, the
/// group's sums stay in L1, and nothing W × W is formed (a matrix product through the W × W
/// products u_ℓj u_(ℓ+d)j per lag made and faulted in 32 MB per lag at W = 2048, ~3/4 of
/// building a plan).
fn exact_band(modes: &AxisModes, modal: &[Small], n: usize, lags: usize) -> Vec<Mat<f64>> {
    #[cfg(target_arch = "x86_64")]
    if crate::banded::fused_available() {
        // SAFETY: the CPU has FMA and AVX2.
        return unsafe { exact_band_fused(modes, modal, n, lags) };
    }
    exact_band_with::<Plain>(modes, modal, n, lags)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma,avx2")]
unsafe fn exact_band_fused(
    modes: &AxisModes,
    modal: &[Small],
    n: usize,
    lags: usize,
) -> Vec<Mat<f64>> {
    exact_band_with::<crate::banded::Fused>(modes, modal, n, lags)
}

#[inline(always)]
fn exact_band_with<A: Arith>(
    modes: &AxisModes,
    modal: &[Small],
    n: usize,
    lags: usize,
) -> Vec<Mat<f64>> {
    let (u, w, blocks) = (&modes.vectors, modes.size(), n * n);
    let mut band: Vec<Mat<f64>> = (0..=lags).map(|d| Mat::zeros(w - d, blocks)).collect();
    // sums[d · n² + ab][k] for row start + k; pairs[d][k] = u_(start+k)j u_(start+k+d)j
    let mut sums = vec![[0.0; BAND_ROWS]; (lags + 1) * blocks];
    let mut pairs = vec![[0.0; BAND_ROWS]; lags + 1];
    for start in (0..w).step_by(BAND_ROWS) {
        sums.fill([0.0; BAND_ROWS]);
        for (j, m) in modal.iter().enumerate() {
            let column = u.col_as_slice(j);
            for (d, pair) in pairs.iter_mut().enumerate() {
                pair_products(column, start, d, pair);
            }
            for (d, pair) in pairs.iter().enumerate() {
                let rows = sums[d * blocks..(d + 1) * blocks].iter_mut();
                for (ab, sum) in rows.enumerate() {
                    add_scaled::<A>(sum, m[(ab / n, ab % n)], pair);
                }
            }
        }
        for (d, lag) in band.iter_mut().enumerate() {
            for l in start..(start + BAND_ROWS).min(w - d) {
                for ab in 0..blocks {
                    lag[(l, ab)] = sums[d * blocks + ab][l - start];
                }
            }
        }
    }
    band
}

/// pair[k] = u_ℓ u_(ℓ+d) for ℓ = start + k (0 past the end of the column).
#[inline(always)]
fn pair_products(column: &[f64], start: usize, d: usize, pair: &mut [f64; BAND_ROWS]) {
    if let Some(run) = column.get(start..start + BAND_ROWS + d) {
        for (k, p) in pair.iter_mut().enumerate() {
            *p = run[k] * run[k + d];
        }
    } else {
        for (k, p) in pair.iter_mut().enumerate() {
            let l = start + k;
            *p = if l + d < column.len() {
                column[l] * column[l + d]
            } else {
                0.0
            };
        }
    }
}

/// sum += c · pair, entry by entry.
#[inline(always)]
fn add_scaled<A: Arith>(sum: &mut [f64; BAND_ROWS], c: f64, pair: &[f64; BAND_ROWS]) {
    // a local accumulator: updated in place, LLVM keeps the loop scalar
    let mut acc = *sum;
    for (s, p) in acc.iter_mut().zip(pair) {
        *s = A::add_product(*s, c, *p);
    }
    *sum = acc;
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
    fn exact_band_is_the_sum_over_the_modes() {
        // widths around the row groups (one short group, a tail), both arithmetic builds
        let axis = AxisModel::new(0.8, 2).unwrap();
        for (w, n, lags) in [(7usize, 1usize, 2usize), (33, 2, 3), (70, 4, 4)] {
            let RowModes::Exact(modes) = RowModes::exact(&axis, w).unwrap() else {
                unreachable!()
            };
            let modal: Vec<Small> = (0..w)
                .map(|j| Small::from_fn(|a, b| ((j + 3 * a + 7 * b) as f64 * 0.37).sin()))
                .collect();
            let want = |d: usize, l: usize, ab: usize| -> f64 {
                (0..w)
                    .map(|j| {
                        let u = &modes.vectors;
                        u[(l, j)] * u[(l + d, j)] * modal[j][(ab / n, ab % n)]
                    })
                    .sum()
            };
            let mut builds = vec![exact_band_with::<Plain>(&modes, &modal, n, lags)];
            #[cfg(target_arch = "x86_64")]
            if crate::banded::fused_available() {
                builds.push(unsafe { exact_band_fused(&modes, &modal, n, lags) });
            }
            for band in builds {
                assert_eq!(band.len(), lags + 1);
                for (d, lag) in band.iter().enumerate() {
                    assert_eq!((lag.nrows(), lag.ncols()), (w - d, n * n));
                    for l in 0..w - d {
                        for ab in 0..n * n {
                            let err = (lag[(l, ab)] - want(d, l, ab)).abs();
                            assert!(err < 1e-13, "w {w} d {d} l {l} ab {ab}: {err:e}");
                        }
                    }
                }
            }
        }
    }

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
