//! The decision after each frame: maximum posterior type, or Wald's sequential
//! probability-ratio test for two types (method page *Kalman filter bank*, "Decisions").

use super::probabilities::check_probabilities;
use crate::{FieldError, Result};

/// The decision of a trajectory before the sequential test crosses a threshold.
pub const UNDECIDED: i64 = -1;

/// How the type is decided from the accumulated log-likelihoods L_i.
#[derive(Clone, Debug, PartialEq)]
pub enum DecisionRule {
    /// argmax_i ln π_i + L_i (the first on ties), recomputed every frame.
    MaxPosterior { log_priors: Vec<f64> },
    /// Two types: type 1 once L_1 − L_0 ≥ ln((1 − β)/α), type 0 once L_1 − L_0 ≤
    /// ln(β/(1 − α)); undecided before; the test stops at its first crossing.
    Sprt { lower: f64, upper: f64 },
}

fn check_error_probability(p: f64, name: &str) -> Result<()> {
    if p > 0.0 && p < 1.0 {
        return Ok(());
    }
    Err(FieldError::InvalidParameter(format!(
        "{name} must lie strictly between 0 and 1, got {p}"
    )))
}

impl DecisionRule {
    /// The rule for `k` types: Wald's test when `errors` = (α, β) is given (k must be 2),
    /// the maximum posterior with `priors` otherwise.
    pub fn new(k: usize, priors: &[f64], errors: Option<(f64, f64)>) -> Result<Self> {
        check_probabilities(priors, k, "priors")?;
        match errors {
            None => Ok(Self::MaxPosterior {
                log_priors: priors.iter().map(|p| p.ln()).collect(),
            }),
            Some((alpha, beta)) => {
                check_error_probability(alpha, "alpha")?;
                check_error_probability(beta, "beta")?;
                if alpha + beta >= 1.0 {
                    return Err(FieldError::InvalidParameter(format!(
                        "alpha + beta must be below 1 (else the thresholds cross), got {}",
                        alpha + beta
                    )));
                }
                if k != 2 {
                    return Err(FieldError::InvalidParameter(format!(
                        "the sequential test (alpha, beta) needs exactly two models, got {k}"
                    )));
                }
                Ok(Self::Sprt {
                    lower: (beta / (1.0 - alpha)).ln(),
                    upper: ((1.0 - beta) / alpha).ln(),
                })
            }
        }
    }

    /// The decision before any frame.
    pub fn initial(&self) -> i64 {
        match self {
            Self::MaxPosterior { log_priors } => argmax(log_priors.iter().copied()),
            Self::Sprt { .. } => UNDECIDED,
        }
    }

    /// The decision after a frame, from the previous one and the log-likelihoods `ll(i)`.
    #[inline(always)]
    pub(crate) fn decide(&self, previous: i64, ll: impl Fn(usize) -> f64) -> i64 {
        match self {
            Self::MaxPosterior { log_priors } => {
                argmax(log_priors.iter().enumerate().map(|(i, p)| p + ll(i)))
            }
            Self::Sprt { lower, upper } => {
                if previous != UNDECIDED {
                    return previous;
                }
                let ratio = ll(1) - ll(0);
                if ratio >= *upper {
                    1
                } else if ratio <= *lower {
                    0
                } else {
                    UNDECIDED
                }
            }
        }
    }
}

impl DecisionRule {
    /// [`DecisionRule::decide`] for L trajectories at once; `ll[i][l]` is lane l's L_i.
    #[inline(always)]
    pub(crate) fn decide_lanes<const L: usize>(&self, decisions: &mut [i64; L], ll: &[[f64; L]]) {
        match self {
            Self::MaxPosterior { log_priors } => {
                let mut best = [f64::NEG_INFINITY; L];
                let mut index = [0i64; L];
                for (i, (p, row)) in log_priors.iter().zip(ll).enumerate() {
                    for l in 0..L {
                        let v = p + row[l];
                        if v > best[l] {
                            best[l] = v;
                            index[l] = i as i64;
                        }
                    }
                }
                *decisions = index;
            }
            Self::Sprt { .. } => {
                for (l, d) in decisions.iter_mut().enumerate() {
                    *d = self.decide(*d, |i| ll[i][l]);
                }
            }
        }
    }
}

/// The index of the first largest value (NaN never wins).
#[inline(always)]
fn argmax(values: impl Iterator<Item = f64>) -> i64 {
    let mut best = (0, f64::NEG_INFINITY);
    for (i, v) in values.enumerate() {
        if v > best.1 {
            best = (i, v);
        }
    }
    best.0 as i64
}

/// exp(a_i − logsumexp a): the normalised probabilities of log-weights.
pub(crate) fn normalised(log_weights: &[f64]) -> Vec<f64> {
    let top = log_weights
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    let w: Vec<f64> = log_weights.iter().map(|a| (a - top).exp()).collect();
    let sum: f64 = w.iter().sum();
    w.into_iter().map(|v| v / sum).collect()
}
