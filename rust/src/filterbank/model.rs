//! One candidate type: a linear-Gaussian model with its prior state.

use crate::kalman::{Gaussian, LinearGaussian};
use crate::{FieldError, Result};

/// The dynamics of a type and the prior N(x0, P0) of its state one step before the first
/// frame.
#[derive(Clone, Debug, PartialEq)]
pub struct BankModel {
    pub dynamics: LinearGaussian,
    pub prior: Gaussian,
}

impl BankModel {
    /// Checked: the prior has the model's state dimension.
    pub fn new(dynamics: LinearGaussian, prior: Gaussian) -> Result<Self> {
        if prior.dim() != dynamics.state_dim() {
            return Err(FieldError::Shape(format!(
                "x0 has {} states but F is {n}×{n}",
                prior.dim(),
                n = dynamics.state_dim()
            )));
        }
        Ok(Self { dynamics, prior })
    }

    /// n, the state length.
    pub fn state_dim(&self) -> usize {
        self.dynamics.state_dim()
    }
}

/// The common measurement length of a bank of at least two models.
pub(crate) fn bank_measurement_dim(models: &[BankModel]) -> Result<usize> {
    if models.len() < 2 {
        return Err(FieldError::InvalidParameter(format!(
            "a bank needs at least two models, got {}",
            models.len()
        )));
    }
    let m = models[0].dynamics.measurement_dim();
    if let Some((i, other)) = models
        .iter()
        .enumerate()
        .find(|(_, b)| b.dynamics.measurement_dim() != m)
    {
        return Err(FieldError::Shape(format!(
            "all models must observe measurements of the same length: model 0 has {m}, \
             model {i} has {}",
            other.dynamics.measurement_dim()
        )));
    }
    Ok(m)
}
