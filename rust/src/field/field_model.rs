//! The N-axis separable autoregressive field model (SPEC §1.2):
//! Π_k (1 - ρ_k z_k⁻¹)^{n_k} x = β ξ, with R(r̄) = σ² Π_k R_k(r_k).

use super::axis_model::AxisModel;
use super::stationary_start::AxisRecursion;
use crate::error::{FieldError, Result};
use num_traits::Float;

/// Smallest σ accepted, 2⁻⁵¹⁰ ≈ 3.0e-154: σ² = 2⁻¹⁰²⁰ is still a normal float64.
pub const MIN_SIGMA: f64 = 2.983336292480083e-154;
/// Largest σ accepted, 2⁵¹⁰ ≈ 3.4e153: σ² = 2¹⁰²⁰ ≈ 1.1e307 is finite (σ = 1e300 made the
/// correlation inf and NaN).
pub const MAX_SIGMA: f64 = 3.3519519824856493e153;

/// A separable multiple-root autoregression over any number of axes.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldModel {
    axes: Vec<AxisModel>,
    sigma: f64,
}

impl FieldModel {
    /// One (ρ, n) per axis and the standard deviation σ of the field.
    pub fn new(rho: &[f64], order: &[usize], sigma: f64) -> Result<Self> {
        if rho.is_empty() {
            return Err(FieldError::InvalidParameter(
                "a field model needs at least one axis (rho and order are empty)".into(),
            ));
        }
        if rho.len() != order.len() {
            return Err(FieldError::InvalidParameter(format!(
                "rho has {} axes but order has {}",
                rho.len(),
                order.len()
            )));
        }
        if !(sigma.is_finite() && sigma > 0.0) {
            return Err(FieldError::InvalidParameter(format!(
                "sigma must be a positive finite number, got {sigma}"
            )));
        }
        if !(MIN_SIGMA..=MAX_SIGMA).contains(&sigma) {
            return Err(FieldError::InvalidParameter(format!(
                "sigma must lie within [2^-510, 2^510] ≈ [3.0e-154, 3.4e153] (σ² must stay a \
                 normal float64 number; rescale the data), got {sigma:e}"
            )));
        }
        let axes = rho
            .iter()
            .zip(order)
            .enumerate()
            .map(|(k, (&r, &n))| {
                AxisModel::new(r, n)
                    .map_err(|e| FieldError::InvalidParameter(format!("axis {k}: {e}")))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self { axes, sigma })
    }

    pub fn axes(&self) -> &[AxisModel] {
        &self.axes
    }

    pub fn ndim(&self) -> usize {
        self.axes.len()
    }

    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// β = σ Π_k β̃_k  [P 2.16].
    pub fn beta(&self) -> f64 {
        self.sigma
            * self
                .axes
                .iter()
                .map(|a| a.beta_tilde_sq().sqrt())
                .product::<f64>()
    }

    /// The template c_j̄ = Π_k c_{k,j_k} over the (n_1+1)×…×(n_N+1) box, C order  [P 2.14].
    pub fn template(&self) -> (Vec<f64>, Vec<usize>) {
        let shape: Vec<usize> = self.axes.iter().map(|a| a.order() + 1).collect();
        let mut values = vec![1.0];
        for axis in &self.axes {
            let c = axis.template();
            values = values
                .iter()
                .flat_map(|v| c.iter().map(move |cj| v * cj))
                .collect();
        }
        (values, shape)
    }

    /// σ² Π_k R_k(r_k) for `lags` holding one lag vector of length N after another  [P 2.17].
    pub fn correlation(&self, lags: &[f64]) -> Result<Vec<f64>> {
        let n = self.ndim();
        if lags.len() % n != 0 {
            return Err(FieldError::Shape(format!(
                "lags must hold {n} values per point, got {} values",
                lags.len()
            )));
        }
        if lags.iter().any(|v| !v.is_finite()) {
            return Err(FieldError::NonFinite(
                "lags contain NaN or infinite values".into(),
            ));
        }
        let s2 = self.sigma * self.sigma;
        Ok(lags
            .chunks_exact(n)
            .map(|lag| {
                s2 * self
                    .axes
                    .iter()
                    .zip(lag)
                    .map(|(a, &r)| a.correlation(r))
                    .product::<f64>()
            })
            .collect())
    }

    /// The stationary-start recursions of all axes; σ is folded into axis 0, the one the
    /// cascade applies last.
    pub fn recursions<T: Float>(&self) -> Result<Vec<AxisRecursion<T>>> {
        self.axes
            .iter()
            .enumerate()
            .map(|(k, a)| AxisRecursion::new(a, if k == 0 { self.sigma } else { 1.0 }))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn template_is_outer_product_with_unit_origin() {
        let m = FieldModel::new(&[0.5, 0.8], &[1, 2], 1.0).unwrap();
        let (t, shape) = m.template();
        assert_eq!(shape, vec![2, 3]);
        // (1 - 0.5 z1)(1 - 1.6 z2 + 0.64 z2²)
        let want = [1.0, -1.6, 0.64, -0.5, 0.8, -0.32];
        for (a, b) in t.iter().zip(want) {
            assert!((a - b).abs() < 1e-14);
        }
    }

    #[test]
    fn correlation_is_product_of_axes() {
        let m = FieldModel::new(&[0.5, 0.8], &[1, 2], 2.0).unwrap();
        let r = m.correlation(&[0.0, 0.0, 1.0, 2.0]).unwrap();
        assert!((r[0] - 4.0).abs() < 1e-14);
        let want = 4.0 * 0.5 * m.axes()[1].correlation(2.0);
        assert!((r[1] - want).abs() < 1e-14);
    }

    #[test]
    fn rejects_mismatch() {
        assert!(FieldModel::new(&[0.5], &[1, 2], 1.0).is_err());
        assert!(FieldModel::new(&[], &[], 1.0).is_err());
        assert!(FieldModel::new(&[0.5], &[1], 0.0).is_err());
        assert!(FieldModel::new(&[0.5], &[1], f64::NAN).is_err());
    }
}
