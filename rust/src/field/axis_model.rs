//! One axis of a separable autoregression with a multiple root: (1 - ρ z⁻¹)ⁿ x_i = β ξ_i.
//!
//! SPEC §1.1 ([P 2.6–2.12]): AR coefficients, the unit-variance driving gain β̃ and the
//! normalised correlation function R(k), extended to real lags as ρ^|r|·(polynomial in |r|).

use crate::error::{FieldError, Result};

/// Largest multiplicity accepted: beyond it the boundary (Levinson) recursion loses accuracy
/// for ρ close to 1 and nobody needs such smooth fields.
pub const MAX_ORDER: usize = 16;

/// The 1-D model of one axis: root 1/ρ of multiplicity `order`, unit variance.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisModel {
    rho: f64,
    order: usize,
    /// R(r) = ρ^|r| Σ_m poly[m] |r|^m  (SPEC §1.1).
    poly: Vec<f64>,
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

fn factorial(n: usize) -> f64 {
    (1..=n).fold(1.0, |acc, i| acc * i as f64)
}

impl AxisModel {
    /// Validates 0 < ρ < 1 and 1 ≤ order ≤ [`MAX_ORDER`].
    pub fn new(rho: f64, order: usize) -> Result<Self> {
        if !(rho.is_finite() && rho > 0.0 && rho < 1.0) {
            return Err(FieldError::InvalidParameter(format!(
                "rho must lie strictly between 0 and 1, got {rho}"
            )));
        }
        if rho < f64::MIN_POSITIVE {
            return Err(FieldError::InvalidParameter(format!(
                "rho must be at least {:e} (a normal float64), got {rho:e}",
                f64::MIN_POSITIVE
            )));
        }
        if order == 0 || order > MAX_ORDER {
            return Err(FieldError::InvalidParameter(format!(
                "order (root multiplicity) must be an integer in 1..={MAX_ORDER}, got {order}"
            )));
        }
        let poly = correlation_polynomial(rho, order);
        Ok(Self { rho, order, poly })
    }

    pub fn rho(&self) -> f64 {
        self.rho
    }

    pub fn order(&self) -> usize {
        self.order
    }

    /// α_j = (-1)^{j+1} C(n,j) ρ^j, j = 1..n, so that x_i = Σ_j α_j x_{i-j} + β ξ_i  [P 2.8].
    pub fn ar_coefficients(&self) -> Vec<f64> {
        self.template()[1..].iter().map(|c| -c).collect()
    }

    /// c_j = (-1)^j C(n,j) ρ^j, j = 0..n: the operator (1 - ρ z⁻¹)ⁿ = Σ_j c_j z⁻ʲ  [P 2.14].
    pub fn template(&self) -> Vec<f64> {
        let n = self.order;
        (0..=n)
            .map(|j| {
                let sign = if j % 2 == 0 { 1.0 } else { -1.0 };
                sign * binomial(n, j) * self.rho.powi(j as i32)
            })
            .collect()
    }

    /// β̃² = (1-ρ²)^{2n-1} / Σ_l (C(n-1,l) ρ^l)², the gain giving unit variance  [P 2.11, 2.12].
    pub fn beta_tilde_sq(&self) -> f64 {
        let n = self.order;
        let r2 = self.rho * self.rho;
        (1.0 - r2).powi(2 * n as i32 - 1) / self.norm_sum()
    }

    fn norm_sum(&self) -> f64 {
        let n = self.order;
        (0..n)
            .map(|l| (binomial(n - 1, l) * self.rho.powi(l as i32)).powi(2))
            .sum()
    }

    /// Coefficients p_m of R(r) = ρ^|r| Σ_m p_m |r|^m.
    pub fn polynomial(&self) -> &[f64] {
        &self.poly
    }

    /// Normalised correlation R(r) at a real lag r (R(0) = 1, even in r)  [P 2.9, 2.10].
    pub fn correlation(&self, lag: f64) -> f64 {
        let r = lag.abs();
        let decay = self.rho.powf(r);
        if decay == 0.0 {
            // (the polynomial of a far lag may overflow: 0 · inf would be NaN)
            return 0.0;
        }
        let p = self.poly.iter().rev().fold(0.0, |acc, c| acc * r + c);
        decay * p
    }
}

/// R_{n,ρ}(lag) for every ρ of `rhos` (rows) and lag of `lags` (columns), row-major: the
/// candidates of a fit over ρ (`model_from_noisy`) in one call.
pub fn correlation_table(rhos: &[f64], order: usize, lags: &[f64]) -> Result<Vec<f64>> {
    if let Some(bad) = lags.iter().find(|l| !l.is_finite()) {
        return Err(FieldError::NonFinite(format!(
            "lags must be finite, got {bad}"
        )));
    }
    let mut table = Vec::with_capacity(rhos.len() * lags.len());
    for &rho in rhos {
        let axis = AxisModel::new(rho, order)?;
        table.extend(lags.iter().map(|&lag| axis.correlation(lag)));
    }
    Ok(table)
}

/// Expands [P 2.9] into powers of the lag. With β̃² substituted, the l-th term is
/// ρ^{2(n-l-1)} (1-ρ²)^l / S · (2n-l-2)! / (l! (n-1)! (n-l-1)!) · Π_{i<l} (r + n - 1 - i),
/// which stays well scaled for ρ → 1 (no (1-ρ²)^{-(2n-1)} blow-up).
fn correlation_polynomial(rho: f64, n: usize) -> Vec<f64> {
    let r2 = rho * rho;
    let s: f64 = (0..n)
        .map(|l| (binomial(n - 1, l) * rho.powi(l as i32)).powi(2))
        .sum();
    let mut poly = vec![0.0; n];
    for l in 0..n {
        let weight = r2.powi((n - l - 1) as i32) * (1.0 - r2).powi(l as i32) / s
            * factorial(2 * n - l - 2)
            / (factorial(l) * factorial(n - 1) * factorial(n - l - 1));
        // rising product Π_{i<l} (r + n-1-i) as coefficients in r
        let mut factor = vec![1.0];
        for i in 0..l {
            let shift = (n - 1 - i) as f64;
            let mut next = vec![0.0; factor.len() + 1];
            for (m, c) in factor.iter().enumerate() {
                next[m] += c * shift;
                next[m + 1] += c;
            }
            factor = next;
        }
        for (m, c) in factor.iter().enumerate() {
            poly[m] += weight * c;
        }
    }
    poly
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The MA(∞) impulse response h_i = C(n+i-1, i) ρ^i of (1-ρz⁻¹)^{-n}.
    fn impulse(rho: f64, n: usize) -> Vec<f64> {
        let mut h = vec![1.0];
        for i in 1..4000 {
            h.push(h[i - 1] * rho * (n + i - 1) as f64 / i as f64);
        }
        h
    }

    fn impulse_correlation(rho: f64, n: usize, k: usize) -> f64 {
        let h = impulse(rho, n);
        let c = |lag: usize| -> f64 { h.iter().zip(&h[lag..]).map(|(a, b)| a * b).sum() };
        c(k) / c(0)
    }

    #[test]
    fn correlation_table_rows_are_each_rhos_correlations() {
        // row-major, one row per ρ, against the impulse response's sums (independent of the
        // closed form)
        let (rhos, lags) = ([0.3, 0.9, 0.95], [0.0, 1.0, 3.0, 7.0]);
        let table = correlation_table(&rhos, 3, &lags).unwrap();
        assert_eq!(table.len(), rhos.len() * lags.len());
        for (row, &rho) in table.chunks_exact(lags.len()).zip(&rhos) {
            for (got, &lag) in row.iter().zip(&lags) {
                let want = impulse_correlation(rho, 3, lag as usize);
                assert!(
                    (got - want).abs() < 1e-10,
                    "ρ {rho} lag {lag}: {got} vs {want}"
                );
            }
        }
        assert!(correlation_table(&[0.5, 1.0], 2, &lags).is_err());
        assert!(correlation_table(&[0.5], 0, &lags).is_err());
        assert!(correlation_table(&[0.5], 2, &[1.0, f64::NAN]).is_err());
    }

    #[test]
    fn correlation_matches_impulse_response() {
        for n in 1..=4 {
            for &rho in &[0.3, 0.7, 0.9] {
                let m = AxisModel::new(rho, n).unwrap();
                for k in 0..12 {
                    let want = impulse_correlation(rho, n, k);
                    assert!(
                        (m.correlation(k as f64) - want).abs() < 1e-10,
                        "n={n} rho={rho} k={k} {} {want}",
                        m.correlation(k as f64)
                    );
                }
            }
        }
    }

    #[test]
    fn beta_gives_unit_variance() {
        for n in 1..=4 {
            let rho = 0.8;
            let m = AxisModel::new(rho, n).unwrap();
            let h2: f64 = impulse(rho, n).iter().map(|h| h * h).sum();
            assert!((m.beta_tilde_sq() * h2 - 1.0).abs() < 1e-10);
        }
    }

    #[test]
    fn second_order_closed_form() {
        let rho: f64 = 0.6;
        let m = AxisModel::new(rho, 2).unwrap();
        for k in [0.0, 0.5, 1.0, 2.5, 7.0] {
            let want = rho.powf(k) * (1.0 + k * (1.0 - rho * rho) / (1.0 + rho * rho));
            assert!((m.correlation(k) - want).abs() < 1e-14);
            assert!((m.correlation(-k) - want).abs() < 1e-14);
        }
        assert_eq!(m.ar_coefficients().len(), 2);
        assert!((m.ar_coefficients()[0] - 2.0 * rho).abs() < 1e-15);
        assert!((m.ar_coefficients()[1] + rho * rho).abs() < 1e-15);
    }

    #[test]
    fn rejects_bad_parameters() {
        assert!(AxisModel::new(1.0, 1).is_err());
        assert!(AxisModel::new(0.0, 1).is_err());
        assert!(AxisModel::new(f64::NAN, 1).is_err());
        assert!(AxisModel::new(0.5, 0).is_err());
        assert!(AxisModel::new(0.5, MAX_ORDER + 1).is_err());
    }
}
