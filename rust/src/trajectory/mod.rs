//! The possibility-theory ("fuzzy") filter of a parameter's trajectory, the Kalman filter of
//! the same model, and change-point detection (SPEC §4, source [K95]).
//!
//! Model per scalar parameter: x_n = x_{n-1} + x'_{n-1}τ_n + w_n, x'_n = x'_{n-1} + w'_n,
//! z_n = x_n + v_n ([`model`]); gains of either rule ([`fuzzy_gains`], [`kalman_gains`]);
//! one series sample by sample ([`series`]) or many at once ([`batch`]); change detectors
//! that restart the filter ([`detector`]). The twin is `kalmanfield.reference.trajectory`.

pub mod bank;
pub mod batch;
mod chi2_test;
mod cusum_test;
pub mod cusum_threshold;
pub mod detector;
mod fuzzy_gains;
mod fuzzy_test;
pub mod gain;
mod gain_recursion;
mod innovation_filter;
mod kalman_gains;
pub mod memory;
pub mod model;
pub mod series;
mod start;
mod state;

#[cfg(test)]
mod tests;

pub use bank::{Bank, FilterBank, Lane};
pub use batch::{filter_batch, Batch, Times};
pub use cusum_threshold::{cusum_arl, cusum_threshold};
pub use detector::{
    detect_batch, Detections, DetectorBank, DetectorConfig, DetectorLane, DetectorSettings, Method,
    Outcome,
};
pub use gain::Gain;
pub use gain_recursion::gain_sequence;
pub use memory::effective_memory;
pub use model::{GainRule, MotionModel};
pub use series::SeriesFilter;

use crate::{FieldError, Result};

/// τ = t - t_last (NaN for the first sample, when t_last is NaN); an error unless `t` is
/// finite and later than `t_last`.
pub(crate) fn time_step(t_last: f64, t: f64) -> Result<f64> {
    if !t.is_finite() {
        return Err(FieldError::InvalidParameter(format!(
            "times must be finite, got {t}"
        )));
    }
    if t_last.is_nan() {
        return Ok(f64::NAN);
    }
    let tau = t - t_last;
    if tau <= 0.0 {
        return Err(FieldError::InvalidParameter(format!(
            "times must increase strictly: {t} follows {t_last}"
        )));
    }
    if !tau.is_finite() {
        return Err(gain_recursion::overflow());
    }
    Ok(tau)
}
