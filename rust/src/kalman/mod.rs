//! Generic linear-Gaussian Kalman recursions (method page *Kalman filter bank*, SPEC §6):
//! the model x(k) = F x(k−1) + w, w ~ N(0, Q); z(k) = H x(k) + v, v ~ N(0, R); one predict
//! step, one Joseph-form update step with its innovation log-likelihood, and the motion models
//! used by the filter bank and the trackers (block-diagonal over the spatial axes, positions
//! observed).
//!
//! Conventions: matrices are `nalgebra` `DMatrix<f64>`; a model's covariances are checked at
//! construction (finite, symmetric, Q positive semi-definite, R positive definite) and stored
//! symmetrised, so the recursions never meet a bad matrix.

mod covariance;
mod gaussian;
mod linear_gaussian;
mod motion;
mod recursion;

#[cfg(test)]
mod tests;

pub use gaussian::Gaussian;
pub use linear_gaussian::LinearGaussian;
pub use motion::{constant_acceleration, constant_velocity, markov_velocity, singer};
pub use recursion::{gain, predict, predict_cov, update, Gain, Update};
