//! Motion models per spatial axis, block-diagonal over `ndim` axes, positions observed with
//! independent noise of std `measurement_std` (method page *Kalman filter bank*, "Motion
//! models": the exact F and Q of each).
//!
//! State order: axis after axis, each axis (position, velocity[, acceleration]); H picks
//! the positions; R = measurement_std² I.

use super::linear_gaussian::LinearGaussian;
use crate::{FieldError, Result};
use nalgebra::DMatrix;

fn invalid(message: String) -> FieldError {
    FieldError::InvalidParameter(message)
}

fn check_positive(value: f64, name: &str) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        return Ok(());
    }
    Err(invalid(format!(
        "{name} must be positive and finite, got {value}"
    )))
}

fn check_nonnegative(value: f64, name: &str) -> Result<()> {
    if value.is_finite() && value >= 0.0 {
        return Ok(());
    }
    Err(invalid(format!(
        "{name} must be non-negative and finite, got {value}"
    )))
}

fn check_correlation(rho: f64) -> Result<()> {
    if (-1.0..=1.0).contains(&rho) {
        return Ok(());
    }
    Err(invalid(format!("rho must lie in [-1, 1], got {rho}")))
}

/// The model with `f_axis`, `q_axis` (d × d, row-major) on each of `ndim` axes.
fn per_axis(
    f_axis: &[f64],
    q_axis: &[f64],
    ndim: usize,
    measurement_std: f64,
) -> Result<LinearGaussian> {
    if ndim == 0 {
        return Err(invalid("ndim must be at least 1".into()));
    }
    check_positive(measurement_std, "measurement_std")?;
    let d = (f_axis.len() as f64).sqrt() as usize;
    let n = d * ndim;
    let block = |axis: &[f64]| {
        DMatrix::from_fn(n, n, |i, j| {
            if i / d == j / d {
                axis[(i % d) * d + j % d]
            } else {
                0.0
            }
        })
    };
    let h = DMatrix::from_fn(ndim, n, |a, j| if j == a * d { 1.0 } else { 0.0 });
    let r = DMatrix::identity(ndim, ndim) * (measurement_std * measurement_std);
    LinearGaussian::new(block(f_axis), block(q_axis), h, r)
}

/// Constant velocity with continuous white-noise acceleration of power spectral density `q`:
/// F = [[1, T], [0, 1]], Q = q [[T³/3, T²/2], [T²/2, T]] per axis.
pub fn constant_velocity(
    dt: f64,
    q: f64,
    ndim: usize,
    measurement_std: f64,
) -> Result<LinearGaussian> {
    check_positive(dt, "dt")?;
    check_nonnegative(q, "q")?;
    let (t, t2, t3) = (dt, dt * dt, dt * dt * dt);
    let f = [1.0, t, 0.0, 1.0];
    let qm = [q * t3 / 3.0, q * t2 / 2.0, q * t2 / 2.0, q * t];
    per_axis(&f, &qm, ndim, measurement_std)
}

/// Constant acceleration with continuous white-noise jerk of power spectral density `q`:
/// F = [[1, T, T²/2], [0, 1, T], [0, 0, 1]],
/// Q = q [[T⁵/20, T⁴/8, T³/6], [T⁴/8, T³/3, T²/2], [T³/6, T²/2, T]] per axis.
pub fn constant_acceleration(
    dt: f64,
    q: f64,
    ndim: usize,
    measurement_std: f64,
) -> Result<LinearGaussian> {
    check_positive(dt, "dt")?;
    check_nonnegative(q, "q")?;
    let t = [1.0, dt, dt.powi(2), dt.powi(3), dt.powi(4), dt.powi(5)];
    let f = [1.0, t[1], t[2] / 2.0, 0.0, 1.0, t[1], 0.0, 0.0, 1.0];
    let qm = [
        q * t[5] / 20.0,
        q * t[4] / 8.0,
        q * t[3] / 6.0,
        q * t[4] / 8.0,
        q * t[3] / 3.0,
        q * t[2] / 2.0,
        q * t[3] / 6.0,
        q * t[2] / 2.0,
        q * t[1],
    ];
    per_axis(&f, &qm, ndim, measurement_std)
}

/// Singer-type manoeuvre model (SPEC §6): acceleration a first-order Markov sequence
/// a(k) = ρ a(k−1) + w(k) of stationary std σ_a, Var w = σ_a²(1 − ρ²):
/// F = [[1, T, T²/2], [0, 1, T], [0, 0, ρ]], Q = diag(0, 0, σ_a²(1 − ρ²)) per axis.
pub fn singer(
    dt: f64,
    rho: f64,
    sigma_a: f64,
    ndim: usize,
    measurement_std: f64,
) -> Result<LinearGaussian> {
    check_positive(dt, "dt")?;
    check_correlation(rho)?;
    check_nonnegative(sigma_a, "sigma_a")?;
    let f = [1.0, dt, dt * dt / 2.0, 0.0, 1.0, dt, 0.0, 0.0, rho];
    let mut qm = [0.0; 9];
    qm[8] = sigma_a * sigma_a * (1.0 - rho * rho);
    per_axis(&f, &qm, ndim, measurement_std)
}

/// Velocity a first-order Markov sequence v(k) = ρ v(k−1) + w(k) of stationary std σ,
/// Var w = σ²(1 − ρ²): F = [[1, T], [0, ρ]], Q = diag(0, σ²(1 − ρ²)) per axis.
pub fn markov_velocity(
    dt: f64,
    rho: f64,
    sigma: f64,
    ndim: usize,
    measurement_std: f64,
) -> Result<LinearGaussian> {
    check_positive(dt, "dt")?;
    check_correlation(rho)?;
    check_nonnegative(sigma, "sigma")?;
    let f = [1.0, dt, 0.0, rho];
    let qm = [0.0, 0.0, 0.0, sigma * sigma * (1.0 - rho * rho)];
    per_axis(&f, &qm, ndim, measurement_std)
}
