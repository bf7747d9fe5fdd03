//! χ² tail probabilities and quantiles (statrs): residual whiteness (SPEC §1.6) and the
//! likelihood-index test of the trackers (SPEC §3.2).

use crate::error::{FieldError, Result};
use statrs::distribution::{ChiSquared, ContinuousCDF};

fn distribution(dof: f64) -> Result<ChiSquared> {
    if !(dof.is_finite() && dof > 0.0) {
        return Err(FieldError::InvalidParameter(format!(
            "degrees of freedom must be positive and finite, got {dof}"
        )));
    }
    ChiSquared::new(dof).map_err(|e| FieldError::InvalidParameter(e.to_string()))
}

/// P(χ²_dof > x).
pub fn chi_squared_sf(x: f64, dof: f64) -> Result<f64> {
    if x.is_nan() {
        return Err(FieldError::NonFinite("the χ² statistic is NaN".into()));
    }
    Ok(distribution(dof)?.sf(x.max(0.0)))
}

/// The quantile q with P(χ²_dof ≤ q) = p, 0 < p < 1.
pub fn chi_squared_quantile(p: f64, dof: f64) -> Result<f64> {
    if !(p > 0.0 && p < 1.0) {
        return Err(FieldError::InvalidParameter(format!(
            "the probability must lie strictly between 0 and 1, got {p}"
        )));
    }
    Ok(distribution(dof)?.inverse_cdf(p))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_degrees_of_freedom_are_exponential() {
        for x in [0.1, 1.0, 5.0, 20.0] {
            let sf = chi_squared_sf(x, 2.0).unwrap();
            assert!((sf - (-x / 2.0f64).exp()).abs() < 1e-12);
        }
        let q = chi_squared_quantile(0.99, 2.0).unwrap();
        assert!((q - (-2.0 * 0.01f64.ln())).abs() < 1e-9);
    }

    #[test]
    fn bad_arguments_are_errors() {
        assert!(chi_squared_sf(f64::NAN, 2.0).is_err());
        assert!(chi_squared_sf(1.0, 0.0).is_err());
        assert!(chi_squared_quantile(1.0, 2.0).is_err());
    }
}
