//! The interacting-multiple-model estimator over a bank (Blom & Bar-Shalom; method page
//! *Kalman filter bank*, "IMM"): per frame, mix the models' estimates with the mode
//! transition probabilities, predict and update each model, reweight the modes by their
//! likelihoods, and combine. Same conventions as FilterPy's `IMMEstimator`; a missed frame
//! predicts the modes (μ = c̄) and the states.

use super::decision::normalised;
use super::model::{bank_measurement_dim, BankModel};
use super::probabilities::check_probabilities;
use super::validation::checked_batch;
use crate::kalman::{predict, update, Gaussian};
use crate::{FieldError, Result};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// Per trajectory: each model's estimate and the mode probabilities.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ImmTrajectory {
    pub estimates: Vec<Gaussian>,
    pub mu: Vec<f64>,
}

/// What a run returns (C order).
#[derive(Clone, Debug, PartialEq)]
pub struct ImmOutput {
    /// Combined state estimate per trajectory and frame (n_traj × n_frames × n).
    pub state: Vec<f64>,
    /// Mode probabilities per trajectory and frame (n_traj × n_frames × K).
    pub mode_probabilities: Vec<f64>,
    /// ln p(z_k | z_1..z_(k−1)) per trajectory and frame (0 on missed frames).
    pub log_likelihood: Vec<f64>,
}

/// The IMM estimator of a batch of trajectories.
#[derive(Clone, Debug)]
pub struct ImmEstimator {
    pub(crate) models: Vec<BankModel>,
    /// M_ij = P(mode j at k | mode i at k − 1).
    pub(crate) transition: DMatrix<f64>,
    pub(crate) initial_mu: Vec<f64>,
    pub(crate) n: usize,
    pub(crate) m: usize,
    pub(crate) frame: u64,
    pub(crate) trajectories: Vec<ImmTrajectory>,
}

impl ImmEstimator {
    /// Checked: ≥ 2 models of one state and measurement length, a K × K row-stochastic
    /// `transition` (row-major), initial mode probabilities `mu`.
    pub fn new(models: Vec<BankModel>, transition: &[f64], mu: &[f64]) -> Result<Self> {
        let m = bank_measurement_dim(&models)?;
        let (k, n) = (models.len(), models[0].state_dim());
        if let Some((i, b)) = models.iter().enumerate().find(|(_, b)| b.state_dim() != n) {
            return Err(FieldError::Shape(format!(
                "the IMM mixes states: all models need the state length {n} of model 0, \
                 model {i} has {}",
                b.state_dim()
            )));
        }
        if transition.len() != k * k {
            return Err(FieldError::Shape(format!(
                "transition must be {k}×{k}, got {} values",
                transition.len()
            )));
        }
        for row in transition.chunks_exact(k) {
            check_probabilities(row, k, "every row of transition")?;
        }
        check_probabilities(mu, k, "mu")?;
        Ok(Self {
            transition: DMatrix::from_row_slice(k, k, transition),
            initial_mu: mu.to_vec(),
            models,
            n,
            m,
            frame: 0,
            trajectories: Vec::new(),
        })
    }

    /// K.
    pub fn n_models(&self) -> usize {
        self.models.len()
    }

    /// n, the state length.
    pub fn state_dim(&self) -> usize {
        self.n
    }

    /// m, the measurement length.
    pub fn measurement_dim(&self) -> usize {
        self.m
    }

    /// Trajectories of the stream (0 before the first run).
    pub fn n_trajectories(&self) -> usize {
        self.trajectories.len()
    }

    /// Frames processed.
    pub fn frame(&self) -> u64 {
        self.frame
    }

    pub(crate) fn fresh_trajectory(&self) -> ImmTrajectory {
        ImmTrajectory {
            estimates: self.models.iter().map(|b| b.prior.clone()).collect(),
            mu: self.initial_mu.clone(),
        }
    }

    /// Processes `n_frames` frames of `n_traj` trajectories (`z`: n_traj × n_frames × m, a
    /// NaN row a missed frame). The first run fixes the number of trajectories; on error
    /// nothing changes.
    pub fn run(&mut self, z: &[f64], n_traj: usize, n_frames: usize) -> Result<ImmOutput> {
        let (n, m, k) = (self.n, self.m, self.models.len());
        let observed = checked_batch(z, n_traj, n_frames, m, self.trajectories.len())?;
        let mut states = if self.trajectories.is_empty() {
            vec![self.fresh_trajectory(); n_traj]
        } else {
            self.trajectories.clone()
        };
        let mut out = ImmOutput {
            state: vec![0.0; n_traj * n_frames * n],
            mode_probabilities: vec![0.0; n_traj * n_frames * k],
            log_likelihood: vec![0.0; n_traj * n_frames],
        };
        let f = n_frames.max(1);
        states
            .par_iter_mut()
            .zip(out.state.par_chunks_mut(f * n))
            .zip(out.mode_probabilities.par_chunks_mut(f * k))
            .zip(out.log_likelihood.par_chunks_mut(f))
            .zip(z.par_chunks(f * m))
            .zip(observed.par_chunks(f))
            .try_for_each(|(((((traj, x_out), mu_out), ll_out), z), seen)| {
                for t in 0..n_frames {
                    let row = seen[t].then(|| DVector::from_column_slice(&z[t * m..(t + 1) * m]));
                    ll_out[t] = self.step(traj, row.as_ref())?;
                    x_out[t * n..(t + 1) * n].copy_from_slice(combined(traj).mean.as_slice());
                    mu_out[t * k..(t + 1) * k].copy_from_slice(&traj.mu);
                }
                Ok::<(), FieldError>(())
            })?;
        self.trajectories = states;
        self.frame += n_frames as u64;
        Ok(out)
    }

    /// One frame of one trajectory; returns ln p(z | past) (0 when missed).
    fn step(&self, traj: &mut ImmTrajectory, z: Option<&DVector<f64>>) -> Result<f64> {
        let k = self.models.len();
        let cbar: Vec<f64> = (0..k)
            .map(|j| (0..k).map(|i| self.transition[(i, j)] * traj.mu[i]).sum())
            .collect();
        let mut next = Vec::with_capacity(k);
        for (j, model) in self.models.iter().enumerate() {
            let weights: Vec<f64> = (0..k)
                .map(|i| {
                    if cbar[j] > 0.0 {
                        self.transition[(i, j)] * traj.mu[i] / cbar[j]
                    } else {
                        traj.mu[i]
                    }
                })
                .collect();
            let mixed = mixture(&traj.estimates, &weights);
            next.push(predict(&model.dynamics, &mixed));
        }
        let Some(z) = z else {
            traj.estimates = next;
            traj.mu = cbar;
            return Ok(0.0);
        };
        let mut log_weights = Vec::with_capacity(k);
        for (j, model) in self.models.iter().enumerate() {
            let up = update(&model.dynamics, &next[j], z)?;
            log_weights.push(cbar[j].ln() + up.log_likelihood);
            next[j] = up.posterior;
        }
        let top = log_weights
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        let total = top
            + log_weights
                .iter()
                .map(|w| (w - top).exp())
                .sum::<f64>()
                .ln();
        traj.estimates = next;
        traj.mu = normalised(&log_weights);
        Ok(total)
    }

    /// Combined estimates per trajectory: means (n_traj × n) and covariances
    /// (n_traj × n × n).
    pub fn combined(&self) -> (Vec<f64>, Vec<f64>) {
        let mut means = Vec::new();
        let mut covs = Vec::new();
        for traj in &self.trajectories {
            let c = combined(traj);
            means.extend(c.mean.iter());
            covs.extend(c.cov.transpose().iter());
        }
        (means, covs)
    }

    /// Mode probabilities per trajectory (n_traj × K).
    pub fn mode_probabilities(&self) -> Vec<f64> {
        self.trajectories
            .iter()
            .flat_map(|t| t.mu.iter().copied())
            .collect()
    }
}

/// The moment-matched Gaussian of a mixture Σ w_i N(x_i, P_i).
fn mixture(estimates: &[Gaussian], weights: &[f64]) -> Gaussian {
    let n = estimates[0].dim();
    let mut mean = DVector::zeros(n);
    for (e, w) in estimates.iter().zip(weights) {
        mean += &e.mean * *w;
    }
    let mut cov = DMatrix::zeros(n, n);
    for (e, w) in estimates.iter().zip(weights) {
        let d = &e.mean - &mean;
        cov += (&e.cov + &d * d.transpose()) * *w;
    }
    Gaussian { mean, cov }
}

fn combined(traj: &ImmTrajectory) -> Gaussian {
    mixture(&traj.estimates, &traj.mu)
}
