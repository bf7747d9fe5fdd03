//! The effective memory of a filter with constant gains [K95, comparison]: the steady estimate
//! x̂_n = Σ_j w_j z_{n-j} with w_j = h^T A^j k, A = (I - k h^T) F, F = [[1, τ], [0, 1]],
//! k = (α, β/τ), h = (1, 0); the memory at level ω is the number of lags j ≥ 0 with
//! |w_j| > ω (the current sample included).

use crate::{FieldError, Result};

/// Lags examined at most.
const MAX_LAGS: usize = 10_000_000;

/// The number of past samples (the current one included) whose weight in the steady estimate
/// of gains (α, β) at time step τ exceeds `level` in magnitude.
pub fn effective_memory(alpha: f64, beta: f64, tau: f64, level: f64) -> Result<usize> {
    if !(alpha.is_finite() && beta.is_finite() && (0.0..=1.0).contains(&alpha) && beta >= 0.0) {
        return Err(FieldError::InvalidParameter(format!(
            "gains must satisfy 0 ≤ α ≤ 1 and β ≥ 0 (finite), got α = {alpha}, β = {beta}"
        )));
    }
    if !(tau.is_finite() && tau > 0.0) {
        return Err(FieldError::InvalidParameter(format!(
            "the time step must be positive and finite, got {tau}"
        )));
    }
    if !(level.is_finite() && level > 0.0) {
        return Err(FieldError::InvalidParameter(format!(
            "level must be positive and finite, got {level}"
        )));
    }
    let (kx, kv) = (alpha, beta / tau);
    // A = (I - k h^T) F
    let a = [[1.0 - kx, (1.0 - kx) * tau], [-kv, 1.0 - kv * tau]];
    let (mut x, mut v) = (kx, kv);
    let mut count = 0;
    // a stopping rule, not a bound: for the gains of these filters (stable A) the weights
    // decay geometrically once they are this small
    let negligible = level * 1e-6;
    for _ in 0..MAX_LAGS {
        if x.abs() > level {
            count += 1;
        }
        if x.abs().max((v * tau).abs()) < negligible {
            return Ok(count);
        }
        (x, v) = (a[0][0] * x + a[0][1] * v, a[1][0] * x + a[1][1] * v);
    }
    Err(FieldError::InvalidParameter(format!(
        "the weights of gains α = {alpha}, β = {beta} do not decay within {MAX_LAGS} lags"
    )))
}
