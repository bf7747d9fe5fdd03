//! Checks of a probability vector (priors, mode probabilities, transition rows).

use crate::{FieldError, Result};

/// Largest |Σp − 1| accepted as rounding.
pub const SUM_TOLERANCE: f64 = 1e-9;

/// Ok when `p` has `k` finite entries in [0, 1] summing to 1 within [`SUM_TOLERANCE`].
pub fn check_probabilities(p: &[f64], k: usize, name: &str) -> Result<()> {
    if p.len() != k {
        return Err(FieldError::Shape(format!(
            "{name} must have {k} entries (one per model), got {}",
            p.len()
        )));
    }
    if p.iter().any(|v| !(0.0..=1.0).contains(v)) {
        return Err(FieldError::InvalidParameter(format!(
            "{name} must lie in [0, 1], got {p:?}"
        )));
    }
    let sum: f64 = p.iter().sum();
    if (sum - 1.0).abs() > SUM_TOLERANCE {
        return Err(FieldError::InvalidParameter(format!(
            "{name} must sum to 1, got {sum}"
        )));
    }
    Ok(())
}
