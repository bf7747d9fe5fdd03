//! Exactly stationary recursion along one axis, edges included (SPEC §1.3, [P 4.1–4.4]).
//!
//! Element l < n of a line is predicted from the l elements before it by the order-l model
//! fitted to the true R (Levinson–Durbin on R); from element n on the full AR(n) model runs.
//! Started this way, every line has covariance exactly Toeplitz(R) (it is the Cholesky
//! factor of that matrix applied to white noise).

use super::axis_model::AxisModel;
use crate::error::{FieldError, Result};
use num_traits::Float;

/// Per-position coefficients of the stationary-start recursion of one axis.
///
/// Position l uses `coeffs[min(l, n)]` (a_1..a_m, most recent first) and `gains[min(l, n)]`:
/// x_l = gains[m] ξ_l + Σ_{i=1..m} coeffs[m][i-1] x_{l-i}.
#[derive(Debug, Clone)]
pub struct AxisRecursion<T> {
    coeffs: Vec<Vec<T>>,
    gains: Vec<T>,
}

impl<T: Float> AxisRecursion<T> {
    /// Builds the recursion of `axis` with every gain multiplied by `scale` (σ_x for the axis
    /// that is applied last, 1 otherwise). Refused (InvalidParameter) when a prediction error
    /// of orders 0..n − 1 of the start rounds to ≤ 0 (order n's is the analytic β̃²):
    /// successive elements correlate too closely for float64 (e.g. ρ = 0.99 with
    /// multiplicity 8), and its square root would be NaN.
    ///
    /// Also refused, measured against 60-digit Levinson recursions and long-double runs: a
    /// start whose prediction errors change by more than [`MAX_START_SENSITIVITY`]
    /// (relative) when R moves by 4 ulps (they are then wrong by
    /// ~1 % to ×1e4: the exact start's R[:n,:n] is singular to float64, e.g. n = 4 at
    /// ρ ≥ 0.995), and a steady recursion whose rounding errors, amplified ~(10–100) × 1/β̃,
    /// exceed ~1e-3 σ in the precision T (refused when ε_T / β̃ > [`MAX_ROUNDING_GAIN`]).
    pub fn new(axis: &AxisModel, scale: f64) -> Result<Self> {
        let n = axis.order();
        let (mut coeffs, mut errors) = levinson(axis);
        // The order-n fit is the model itself: use the analytic values, not rounded ones.
        coeffs[n] = axis.ar_coefficients();
        errors[n] = axis.beta_tilde_sq();
        if let Some((m, e)) = errors
            .iter()
            .enumerate()
            .find(|(_, e)| e.is_nan() || **e <= 0.0)
        {
            return Err(FieldError::InvalidParameter(format!(
                "the exactly stationary start of an axis with rho = {} and multiplicity {n} is \
                 beyond float64: its order-{m} prediction error rounds to {e:.1e} (successive \
                 elements correlate too closely); lower rho or the multiplicity",
                axis.rho()
            )));
        }
        check_start_accuracy(axis, &errors)?;
        check_rounding_gain::<T>(axis)?;
        let cast = |v: f64| T::from(v).expect("f64 converts to every float type");
        Ok(Self {
            coeffs: coeffs
                .into_iter()
                .map(|c| c.into_iter().map(cast).collect())
                .collect(),
            gains: errors.into_iter().map(|e| cast(scale * e.sqrt())).collect(),
        })
    }

    /// The multiplicity n of the axis.
    pub fn order(&self) -> usize {
        self.gains.len() - 1
    }

    /// (coefficients, gain) used at position `l` along the axis.
    pub fn at(&self, l: usize) -> (&[T], T) {
        let m = l.min(self.order());
        (&self.coeffs[m], self.gains[m])
    }
}

/// Largest relative change of the start's prediction errors under 4-ulp changes of R.
pub const MAX_START_SENSITIVITY: f64 = 0.1;
/// ε_T / β̃ at most 1e-5: the steady recursion's rounding errors stay below ~1e-3 σ.
pub const MAX_ROUNDING_GAIN: f64 = 1e-5;

/// Refuses a start whose prediction errors of orders 0..n − 1 are sensitive to the rounding
/// of R (its Toeplitz section is singular to float64): R(k)·(1 ± 4ε) in three sign patterns.
fn check_start_accuracy(axis: &AxisModel, errors: &[f64]) -> Result<()> {
    let n = axis.order();
    let r: Vec<f64> = (0..=n).map(|k| axis.correlation(k as f64)).collect();
    let patterns: [fn(usize) -> f64; 3] = [
        |k| if k % 2 == 0 { 1.0 } else { -1.0 },
        |k| if k % 2 == 0 { 1.0 } else { 0.0 },
        |k| if (k / 2) % 2 == 0 { 1.0 } else { -1.0 },
    ];
    let mut sensitivity = 0.0_f64;
    for sign in patterns {
        let moved: Vec<f64> = r
            .iter()
            .enumerate()
            .map(|(k, v)| v * (1.0 + 4.0 * f64::EPSILON * sign(k)))
            .collect();
        let (_, e) = levinson_of(&moved);
        for m in 0..n {
            let change = ((e[m] - errors[m]) / errors[m]).abs();
            sensitivity = sensitivity.max(if change.is_nan() {
                f64::INFINITY
            } else {
                change
            });
        }
    }
    if sensitivity > MAX_START_SENSITIVITY {
        return Err(FieldError::InvalidParameter(format!(
            "the exactly stationary start of an axis with rho = {} and multiplicity {n} is \
             beyond float64: its prediction errors change by {sensitivity:.1e} (relative) when \
             the correlations move by 4 ulps (successive elements correlate too closely); \
             lower rho or the multiplicity",
            axis.rho()
        )));
    }
    Ok(())
}

/// Refuses a model whose steady recursion amplifies rounding beyond ~1e-3 σ in precision T.
fn check_rounding_gain<T: Float>(axis: &AxisModel) -> Result<()> {
    let gain = 1.0 / axis.beta_tilde_sq().sqrt();
    let eps = T::epsilon().to_f64().unwrap_or(f64::EPSILON);
    if gain * eps > MAX_ROUNDING_GAIN {
        let (name, advice) = if eps > 1e-10 {
            ("float32", "use float64")
        } else {
            ("float64", "lower rho or the multiplicity")
        };
        return Err(FieldError::InvalidParameter(format!(
            "an axis with rho = {} and multiplicity {} amplifies the rounding of {name} \
             recursions {gain:.1e}-fold (errors ≳ 1e-3 σ): {advice}",
            axis.rho(),
            axis.order()
        )));
    }
    Ok(())
}

/// Levinson–Durbin on R(0..n): prediction coefficients and error variances of orders 0..n.
fn levinson(axis: &AxisModel) -> (Vec<Vec<f64>>, Vec<f64>) {
    let n = axis.order();
    let r: Vec<f64> = (0..=n).map(|k| axis.correlation(k as f64)).collect();
    levinson_of(&r)
}

/// Levinson–Durbin on the correlations `r` (lags 0..n).
fn levinson_of(r: &[f64]) -> (Vec<Vec<f64>>, Vec<f64>) {
    let n = r.len() - 1;
    let mut coeffs = vec![Vec::new()];
    let mut errors = vec![r[0]];
    for m in 1..=n {
        let prev = &coeffs[m - 1];
        let e = errors[m - 1];
        let k = (r[m] - (1..m).map(|i| prev[i - 1] * r[m - i]).sum::<f64>()) / e;
        let mut next: Vec<f64> = (1..m).map(|i| prev[i - 1] - k * prev[m - i - 1]).collect();
        next.push(k);
        coeffs.push(next);
        errors.push(e * (1.0 - k * k));
    }
    (coeffs, errors)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levinson_reaches_the_model() {
        for n in 1..=4 {
            let axis = AxisModel::new(0.85, n).unwrap();
            let (coeffs, errors) = levinson(&axis);
            for (a, b) in coeffs[n].iter().zip(axis.ar_coefficients()) {
                assert!((a - b).abs() < 1e-9, "order {n}: {a} vs {b}");
            }
            assert!((errors[n] - axis.beta_tilde_sq()).abs() < 1e-10);
        }
    }

    #[test]
    fn a_start_beyond_float64_is_refused() {
        // ρ = 0.99, n = 8: the order-7 prediction error rounds to −4e-15 (its square root was
        // NaN, and so was every sample); n = 4 still has positive errors
        let refused = AxisRecursion::<f64>::new(&AxisModel::new(0.99, 8).unwrap(), 1.0);
        assert!(matches!(refused, Err(FieldError::InvalidParameter(m)) if m.contains("float64")));
        let rec = AxisRecursion::<f64>::new(&AxisModel::new(0.99, 4).unwrap(), 1.0).unwrap();
        assert!((0..=4).all(|l| rec.at(l).1 > 0.0 && rec.at(l).0.iter().all(|c| c.is_finite())));
    }

    #[test]
    fn a_start_that_float64_cannot_resolve_is_refused() {
        // n = 4, ρ = 0.995: the start's errors are off by 23 % against a 60-digit Levinson
        // (positive, so the sign check passed them); ρ = 0.99 is off by 0.25 % and kept
        let refused = AxisRecursion::<f64>::new(&AxisModel::new(0.995, 4).unwrap(), 1.0);
        assert!(matches!(refused, Err(FieldError::InvalidParameter(m)) if m.contains("4 ulps")));
        assert!(AxisRecursion::<f64>::new(&AxisModel::new(0.99, 4).unwrap(), 1.0).is_ok());
        for (rho, n) in [(0.998, 4), (0.999, 4), (0.98, 7), (0.95, 6), (0.9, 8)] {
            let axis = AxisModel::new(rho, n).unwrap();
            assert!(AxisRecursion::<f64>::new(&axis, 1.0).is_err(), "{rho} {n}");
        }
    }

    #[test]
    fn rounding_gain_is_checked_per_precision() {
        // 1/β̃ = 4e6 for (0.99, 4): float32 states drift by O(σ), float64 ones by ~1e-8 σ
        let axis = AxisModel::new(0.99, 4).unwrap();
        let refused = AxisRecursion::<f32>::new(&axis, 1.0);
        assert!(matches!(refused, Err(FieldError::InvalidParameter(m)) if m.contains("float32")));
        assert!(AxisRecursion::<f64>::new(&axis, 1.0).is_ok());
        assert!(AxisRecursion::<f32>::new(&AxisModel::new(0.95, 2).unwrap(), 1.0).is_ok());
        // 1/β̃ = 1.4e12 for (0.99999, 3): float64 too (samples reached 56 σ)
        let axis = AxisModel::new(0.99999, 3).unwrap();
        let refused = AxisRecursion::<f64>::new(&axis, 1.0);
        assert!(matches!(refused, Err(FieldError::InvalidParameter(m)) if m.contains("float64")));
    }

    /// The recursion written as a lower-triangular matrix L must satisfy L Lᵀ = Toeplitz(R).
    #[test]
    fn recursion_is_cholesky_of_toeplitz() {
        let axis = AxisModel::new(0.7, 3).unwrap();
        let rec = AxisRecursion::<f64>::new(&axis, 1.0).unwrap();
        let len = 9;
        // column j of L = response of the recursion to a unit impulse at j
        let columns: Vec<Vec<f64>> = (0..len)
            .map(|j| {
                let mut x = vec![0.0; len];
                for i in 0..len {
                    let (a, b) = rec.at(i);
                    let xi = if i == j { 1.0 } else { 0.0 };
                    x[i] = b * xi
                        + a.iter()
                            .enumerate()
                            .map(|(p, c)| c * x[i - 1 - p])
                            .sum::<f64>();
                }
                x
            })
            .collect();
        for i in 0..len {
            for j in 0..len {
                let c: f64 = columns.iter().map(|col| col[i] * col[j]).sum();
                let want = axis.correlation(i as f64 - j as f64);
                assert!((c - want).abs() < 1e-12, "({i},{j}): {c} vs {want}");
            }
        }
    }
}
