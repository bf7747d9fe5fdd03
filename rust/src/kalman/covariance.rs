//! Checks of a covariance matrix: finite, square, symmetric to rounding, positive
//! (semi-)definite. The checked matrix is returned symmetrised, (A + Aᵀ)/2.

use crate::{FieldError, Result};
use nalgebra::{DMatrix, SymmetricEigen};

/// Largest relative asymmetry |a_ij − a_ji| / max|a| accepted as rounding.
const SYMMETRY_TOLERANCE: f64 = 1e-10;
/// Most negative eigenvalue, relative to the largest |eigenvalue|, accepted as rounding.
const DEFINITENESS_TOLERANCE: f64 = 1e-10;

/// What a covariance must be beyond symmetric.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Definiteness {
    /// Eigenvalues ≥ 0 (to rounding): a process-noise or prior covariance.
    SemiDefinite,
    /// Eigenvalues > 0 (a Cholesky factor exists): a measurement-noise covariance.
    Definite,
}

/// `a` symmetrised, or the error naming `name` and what is wrong with it.
pub(crate) fn check_covariance(
    a: &DMatrix<f64>,
    name: &str,
    kind: Definiteness,
) -> Result<DMatrix<f64>> {
    if !a.is_square() {
        return Err(FieldError::Shape(format!(
            "{name} must be square, got {}×{}",
            a.nrows(),
            a.ncols()
        )));
    }
    if a.iter().any(|v| !v.is_finite()) {
        return Err(FieldError::NonFinite(format!(
            "{name} must hold finite numbers"
        )));
    }
    let scale = a.amax();
    let asymmetry = (a - a.transpose()).amax();
    if asymmetry > SYMMETRY_TOLERANCE * scale {
        return Err(FieldError::InvalidParameter(format!(
            "{name} must be symmetric (largest |a_ij − a_ji| = {asymmetry:e})"
        )));
    }
    let sym = (a + a.transpose()) * 0.5;
    let eigenvalues = SymmetricEigen::new(sym.clone()).eigenvalues;
    let lowest = eigenvalues.min();
    let floor = -DEFINITENESS_TOLERANCE * eigenvalues.amax();
    match kind {
        Definiteness::SemiDefinite if lowest < floor => Err(FieldError::InvalidParameter(format!(
            "{name} must be positive semi-definite (lowest eigenvalue {lowest:e})"
        ))),
        Definiteness::Definite if lowest <= 0.0 || sym.clone().cholesky().is_none() => {
            Err(FieldError::InvalidParameter(format!(
                "{name} must be positive definite (lowest eigenvalue {lowest:e})"
            )))
        }
        _ => Ok(sym),
    }
}
