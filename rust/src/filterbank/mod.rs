//! Identification of an object's type from its trajectory by a bank of Kalman filters
//! (SPEC §6, source [I]; method page *Kalman filter bank*), and the interacting-multiple-model
//! estimator over the same bank.
//!
//! A bank runs K linear-Gaussian models (domain `kalman`) on every trajectory and accumulates
//! each model's innovation log-likelihood; the decision is the maximum posterior type, or for
//! two types Wald's sequential probability-ratio test. Batches of trajectories run at once:
//! without missed frames the covariance recursion does not depend on the data, so the gains of
//! every frame are computed once per model ([`schedule`]) and shared by all trajectories,
//! whose means are updated sixteen at a time ([`lanes`]); a trajectory with a missed frame gets
//! its own covariances. Every trajectory's result depends on its own data only, bit for bit,
//! whatever the batch and the thread count.

mod codec;
mod decision;
mod identifier;
mod imm;
mod lanes;
mod model;
mod probabilities;
mod schedule;
mod validation;

#[cfg(test)]
mod tests;

pub use decision::DecisionRule;
pub use identifier::{RunOutput, TypeIdentifier};
pub use imm::{ImmEstimator, ImmOutput};
pub use model::BankModel;
pub use probabilities::check_probabilities;
pub use validation::MAX_MEASUREMENT;
