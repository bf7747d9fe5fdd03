//! Eigendecomposition of one axis' correlation matrix Toeplitz(R(|i-j|)) (SPEC §1.1) with
//! faer: the basis in which the row filters of SPEC §2 decouple.

use crate::axis_model::AxisModel;
use crate::error::{FieldError, Result};
use faer::{Mat, Side};

/// Toeplitz(R) = U diag(λ) Uᵀ on `size` points of one axis.
#[derive(Debug, Clone)]
pub struct AxisModes {
    /// Eigenvectors, one per column (size × size).
    pub vectors: Mat<f64>,
    /// Eigenvalues λ_j, non-decreasing, clamped to ≥ 1e-15·max λ (they are ≥ 0 exactly; the
    /// clamp keeps every mode's Kalman filter well defined).
    pub values: Vec<f64>,
}

impl AxisModes {
    /// The modes of `axis` on a line of `size` points.
    pub fn new(axis: &AxisModel, size: usize) -> Result<Self> {
        let correlation: Vec<f64> = (0..size).map(|k| axis.correlation(k as f64)).collect();
        let toeplitz = Mat::from_fn(size, size, |i, j| correlation[i.abs_diff(j)]);
        let eigen = toeplitz.self_adjoint_eigen(Side::Lower).map_err(|e| {
            FieldError::InvalidParameter(format!("eigendecomposition failed: {e:?}"))
        })?;
        crate::vector_state::clear_upper_state();
        let raw = eigen.S().column_vector();
        let largest = (0..size).map(|j| raw[j]).fold(0.0f64, f64::max);
        let values = (0..size).map(|j| raw[j].max(1e-15 * largest)).collect();
        Ok(Self {
            vectors: eigen.U().to_owned(),
            values,
        })
    }

    /// Number of points of the axis.
    pub fn size(&self) -> usize {
        self.values.len()
    }

    /// (U∘U)[i, j] = U[i, j]²: maps per-mode variances to per-point variances.
    pub fn squared_vectors(&self) -> Mat<f64> {
        let n = self.size();
        Mat::from_fn(n, n, |i, j| self.vectors[(i, j)] * self.vectors[(i, j)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reconstructs_the_toeplitz_matrix() {
        let axis = AxisModel::new(0.8, 2).unwrap();
        let modes = AxisModes::new(&axis, 12).unwrap();
        for i in 0..12 {
            for k in 0..12 {
                let v: f64 = (0..12)
                    .map(|j| modes.vectors[(i, j)] * modes.values[j] * modes.vectors[(k, j)])
                    .sum();
                let want = axis.correlation(i.abs_diff(k) as f64);
                assert!((v - want).abs() < 1e-12, "{v} vs {want}");
            }
        }
    }
}
