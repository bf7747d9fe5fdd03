//! A Gaussian state estimate N(mean, cov).

use super::covariance::{check_covariance, Definiteness};
use crate::{FieldError, Result};
use nalgebra::{DMatrix, DVector};

/// A state estimate: mean and covariance.
#[derive(Clone, Debug, PartialEq)]
pub struct Gaussian {
    pub mean: DVector<f64>,
    pub cov: DMatrix<f64>,
}

impl Gaussian {
    /// Checked: finite mean, covariance of matching size, symmetric positive semi-definite
    /// (stored symmetrised).
    pub fn new(mean: DVector<f64>, cov: DMatrix<f64>) -> Result<Self> {
        if mean.iter().any(|v| !v.is_finite()) {
            return Err(FieldError::NonFinite("x0 must hold finite numbers".into()));
        }
        if cov.nrows() != mean.len() || cov.ncols() != mean.len() {
            return Err(FieldError::Shape(format!(
                "P0 must be {n}×{n} for a state of {n}, got {}×{}",
                cov.nrows(),
                cov.ncols(),
                n = mean.len()
            )));
        }
        let cov = check_covariance(&cov, "P0", Definiteness::SemiDefinite)?;
        Ok(Self { mean, cov })
    }

    /// The state dimension n.
    pub fn dim(&self) -> usize {
        self.mean.len()
    }
}
