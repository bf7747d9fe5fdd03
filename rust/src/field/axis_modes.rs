//! Eigendecomposition of one axis' correlation matrix Toeplitz(R(|i-j|)) (SPEC §1.1) with
//! faer: the basis in which the row filters of SPEC §2 decouple.

use super::axis_model::AxisModel;
use crate::error::{FieldError, Result};
use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::evd::{self_adjoint_evd, self_adjoint_evd_scratch, ComputeEigenvectors};
use faer::{Mat, Par};

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
    /// The modes of `axis` on a line of `size` points. One thread (the same bits whatever
    /// the thread count); the workspace is allocated fallibly (an `OutOfMemory` error, not an
    /// abort, when it does not fit).
    pub fn new(axis: &AxisModel, size: usize) -> Result<Self> {
        let correlation: Vec<f64> = (0..size).map(|k| axis.correlation(k as f64)).collect();
        let out_of_memory = || {
            FieldError::OutOfMemory(format!(
                "cannot allocate the eigendecomposition of a {size}×{size} correlation matrix"
            ))
        };
        let square = |entry: &dyn Fn(usize, usize) -> f64| {
            let mut m = Mat::<f64>::new();
            m.try_reserve(size, size).map_err(|_| out_of_memory())?;
            m.resize_with(size, size, entry);
            Ok::<_, FieldError>(m)
        };
        let toeplitz = square(&|i, j| correlation[i.abs_diff(j)])?;
        let mut vectors = square(&|_, _| 0.0)?;
        let mut raw = Diag::<f64>::zeros(size);
        let (par, params) = (Par::Seq, Default::default());
        let scratch = self_adjoint_evd_scratch::<f64>(size, ComputeEigenvectors::Yes, par, params);
        let mut buffer = MemBuffer::try_new(scratch).map_err(|_| out_of_memory())?;
        self_adjoint_evd(
            toeplitz.as_ref(),
            raw.as_mut(),
            Some(vectors.as_mut()),
            par,
            MemStack::new(&mut buffer),
            params,
        )
        .map_err(|e| FieldError::InvalidParameter(format!("eigendecomposition failed: {e:?}")))?;
        crate::simd::clear_upper_state();
        let raw = raw.column_vector();
        let largest = (0..size).map(|j| raw[j]).fold(0.0f64, f64::max);
        let values = (0..size).map(|j| raw[j].max(1e-15 * largest)).collect();
        Ok(Self { vectors, values })
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
