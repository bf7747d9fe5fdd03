//! The linear-Gaussian state-space model (F, Q, H, R).

use super::covariance::{check_covariance, Definiteness};
use crate::{FieldError, Result};
use nalgebra::DMatrix;

/// x(k) = F x(k−1) + w, w ~ N(0, Q); z(k) = H x(k) + v, v ~ N(0, R).
#[derive(Clone, Debug, PartialEq)]
pub struct LinearGaussian {
    pub f: DMatrix<f64>,
    pub q: DMatrix<f64>,
    pub h: DMatrix<f64>,
    pub r: DMatrix<f64>,
}

impl LinearGaussian {
    /// Checked: F n×n, Q n×n, H m×n, R m×m (n, m ≥ 1), all finite, Q symmetric positive
    /// semi-definite, R symmetric positive definite (Q and R stored symmetrised).
    pub fn new(f: DMatrix<f64>, q: DMatrix<f64>, h: DMatrix<f64>, r: DMatrix<f64>) -> Result<Self> {
        let n = f.nrows();
        let m = h.nrows();
        if n == 0 || f.ncols() != n {
            return Err(FieldError::Shape(format!(
                "F must be a non-empty square matrix, got {}×{}",
                f.nrows(),
                f.ncols()
            )));
        }
        if m == 0 || h.ncols() != n {
            return Err(FieldError::Shape(format!(
                "H must be m×{n} (m ≥ 1) for a state of {n}, got {}×{}",
                h.nrows(),
                h.ncols()
            )));
        }
        for (a, name, rows) in [(&q, "Q", n), (&r, "R", m)] {
            if a.nrows() != rows || a.ncols() != rows {
                return Err(FieldError::Shape(format!(
                    "{name} must be {rows}×{rows}, got {}×{}",
                    a.nrows(),
                    a.ncols()
                )));
            }
        }
        if f.iter().chain(h.iter()).any(|v| !v.is_finite()) {
            return Err(FieldError::NonFinite(
                "F and H must hold finite numbers".into(),
            ));
        }
        let q = check_covariance(&q, "Q", Definiteness::SemiDefinite)?;
        let r = check_covariance(&r, "R", Definiteness::Definite)?;
        Ok(Self { f, q, h, r })
    }

    /// n, the length of the state.
    pub fn state_dim(&self) -> usize {
        self.f.nrows()
    }

    /// m, the length of a measurement.
    pub fn measurement_dim(&self) -> usize {
        self.h.nrows()
    }
}
