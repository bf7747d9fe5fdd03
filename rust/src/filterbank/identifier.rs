//! The streaming type identifier: a batch of trajectories, K models, per-frame decisions.

use super::decision::{normalised, DecisionRule};
use super::lanes::{advance, Dynamics, Lane, Trajectory, LANES};
use super::model::{bank_measurement_dim, BankModel};
use super::schedule::{schedule, Schedule};
use super::validation::checked_batch;
use crate::Result;
use nalgebra::DMatrix;
use rayon::prelude::*;

/// Trajectories per parallel task (a multiple of the lane width).
const CHUNK: usize = 64;

/// What a run returns.
#[derive(Clone, Debug, PartialEq)]
pub struct RunOutput {
    /// Decision per trajectory and frame (n_trajectories × n_frames): the type index, or
    /// −1 while Wald's test is undecided.
    pub decisions: Vec<i64>,
    /// Accumulated log-likelihood per trajectory, frame and model (n_trajectories ×
    /// n_frames × K), when asked for.
    pub log_likelihoods: Option<Vec<f64>>,
}

/// A bank of K models identifying the type of a batch of trajectories, frame by frame.
#[derive(Clone, Debug)]
pub struct TypeIdentifier {
    pub(crate) models: Vec<BankModel>,
    dynamics: Vec<Dynamics>,
    pub(crate) rule: DecisionRule,
    log_priors: Vec<f64>,
    pub(crate) m: usize,
    /// Frames processed.
    pub(crate) frame: u64,
    /// The current covariance of every trajectory that never missed a frame, per model.
    pub(crate) shared_cov: Vec<DMatrix<f64>>,
    /// Per trajectory (empty before the first run).
    pub(crate) trajectories: Vec<Trajectory>,
}

impl TypeIdentifier {
    /// A bank of `models` (≥ 2, one measurement length) with prior probabilities `priors`;
    /// `errors` = (α, β) selects Wald's test (two models).
    pub fn new(models: Vec<BankModel>, priors: &[f64], errors: Option<(f64, f64)>) -> Result<Self> {
        let m = bank_measurement_dim(&models)?;
        let rule = DecisionRule::new(models.len(), priors, errors)?;
        Ok(Self {
            dynamics: models.iter().map(|b| Dynamics::new(&b.dynamics)).collect(),
            shared_cov: models.iter().map(|b| b.prior.cov.clone()).collect(),
            log_priors: priors.iter().map(|p| p.ln()).collect(),
            models,
            rule,
            m,
            frame: 0,
            trajectories: Vec::new(),
        })
    }

    /// K.
    pub fn n_models(&self) -> usize {
        self.models.len()
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

    pub(crate) fn fresh_trajectory(&self) -> Trajectory {
        Trajectory {
            means: self
                .models
                .iter()
                .flat_map(|b| b.prior.mean.iter().copied())
                .collect(),
            log_lik: vec![0.0; self.models.len()],
            decision: self.rule.initial(),
            own_cov: None,
        }
    }

    /// Processes `n_frames` frames of `n_traj` trajectories: `z` is n_traj × n_frames × m
    /// (C order), a row of NaN a missed frame. The first run fixes the number of
    /// trajectories. On error nothing changes.
    pub fn run(
        &mut self,
        z: &[f64],
        n_traj: usize,
        n_frames: usize,
        keep_log_likelihoods: bool,
    ) -> Result<RunOutput> {
        let (m, k) = (self.m, self.models.len());
        let observed = checked_batch(z, n_traj, n_frames, m, self.trajectories.len())?;
        let mut states = if self.trajectories.is_empty() {
            vec![self.fresh_trajectory(); n_traj]
        } else {
            self.trajectories.clone()
        };
        let all_observed = vec![true; n_frames];
        let shared: Vec<Schedule> = self
            .models
            .iter()
            .zip(&self.shared_cov)
            .map(|(b, cov)| schedule(&b.dynamics, cov, &all_observed))
            .collect::<Result<_>>()?;
        let mut decisions = vec![0i64; n_traj * n_frames];
        let mut log_lik = vec![
            0.0;
            if keep_log_likelihoods {
                n_traj * n_frames * k
            } else {
                0
            }
        ];
        let n_chunks = n_traj.div_ceil(CHUNK);
        let ll_chunks: Vec<Option<&mut [f64]>> = if keep_log_likelihoods {
            log_lik.chunks_mut(CHUNK * n_frames * k).map(Some).collect()
        } else {
            (0..n_chunks).map(|_| None).collect()
        };
        let span = CHUNK * n_frames;
        states
            .par_chunks_mut(CHUNK)
            .zip(decisions.par_chunks_mut(span.max(1)))
            .zip(z.par_chunks((span * m).max(1)))
            .zip(observed.par_chunks(span.max(1)))
            .zip(ll_chunks)
            .try_for_each(|((((states, decisions), z), observed), ll)| {
                self.run_chunk(&shared, states, decisions, z, observed, ll, n_frames)
            })?;
        for (cov, s) in self.shared_cov.iter_mut().zip(&shared) {
            *cov = s.final_cov.clone();
        }
        self.trajectories = states;
        self.frame += n_frames as u64;
        Ok(RunOutput {
            decisions,
            log_likelihoods: keep_log_likelihoods.then_some(log_lik),
        })
    }

    /// One parallel task: the trajectories of a chunk, the shared ones [`LANES`] at a time.
    #[allow(clippy::too_many_arguments)]
    fn run_chunk(
        &self,
        shared: &[Schedule],
        states: &mut [Trajectory],
        decisions: &mut [i64],
        z: &[f64],
        observed: &[bool],
        log_lik: Option<&mut [f64]>,
        n_frames: usize,
    ) -> Result<()> {
        let (m, k) = (self.m, self.models.len());
        let mut ll_rows: Vec<Option<&mut [f64]>> = match log_lik {
            Some(out) => out.chunks_mut((n_frames * k).max(1)).map(Some).collect(),
            None => (0..states.len()).map(|_| None).collect(),
        };
        ll_rows.resize_with(states.len(), || None);
        let (mut together, mut alone) = (Vec::new(), Vec::new());
        for ((((state, decisions), z), seen), log_lik) in states
            .iter_mut()
            .zip(decisions.chunks_mut(n_frames.max(1)))
            .zip(z.chunks((n_frames * m).max(1)))
            .zip(observed.chunks(n_frames.max(1)))
            .zip(ll_rows)
        {
            let lane = Lane {
                state,
                z,
                decisions,
                log_lik,
            };
            if lane.state.own_cov.is_none() && seen.iter().all(|&s| s) {
                together.push(lane);
            } else {
                alone.push((lane, seen));
            }
        }
        let shared_refs: Vec<&Schedule> = shared.iter().collect();
        let mut groups = together.chunks_exact_mut(LANES);
        for group in &mut groups {
            advance::<LANES>(&self.dynamics, &shared_refs, &self.rule, group);
        }
        for lane in groups.into_remainder().chunks_mut(1) {
            advance::<1>(&self.dynamics, &shared_refs, &self.rule, lane);
        }
        for (lane, seen) in alone {
            let own: Vec<Schedule> = self
                .models
                .iter()
                .enumerate()
                .map(|(i, b)| {
                    let start = match &lane.state.own_cov {
                        Some(covs) => &covs[i],
                        None => &self.shared_cov[i],
                    };
                    schedule(&b.dynamics, start, seen)
                })
                .collect::<Result<_>>()?;
            let refs: Vec<&Schedule> = own.iter().collect();
            let mut one = [lane];
            advance::<1>(&self.dynamics, &refs, &self.rule, &mut one);
            one[0].state.own_cov = Some(own.into_iter().map(|s| s.final_cov).collect());
        }
        Ok(())
    }

    /// Accumulated log-likelihood per trajectory and model (n_trajectories × K).
    pub fn log_likelihoods(&self) -> Vec<f64> {
        self.trajectories
            .iter()
            .flat_map(|t| t.log_lik.iter().copied())
            .collect()
    }

    /// Posterior type probabilities per trajectory (n_trajectories × K).
    pub fn posterior(&self) -> Vec<f64> {
        self.trajectories
            .iter()
            .flat_map(|t| {
                let w: Vec<f64> = t
                    .log_lik
                    .iter()
                    .zip(&self.log_priors)
                    .map(|(l, p)| l + p)
                    .collect();
                normalised(&w)
            })
            .collect()
    }

    /// The current decision per trajectory.
    pub fn decisions(&self) -> Vec<i64> {
        self.trajectories.iter().map(|t| t.decision).collect()
    }
}
