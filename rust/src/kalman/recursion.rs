//! One Kalman step: prediction, and the Joseph-form update with its innovation
//! log-likelihood (method page *Kalman filter bank*, "The recursion").

use super::gaussian::Gaussian;
use super::linear_gaussian::LinearGaussian;
use crate::{FieldError, Result};
use nalgebra::{DMatrix, DVector};

/// ln 2π.
const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// The data-independent part of an update: everything that depends on the predicted
/// covariance only (shared by all trajectories with the same history of missed frames).
#[derive(Clone, Debug, PartialEq)]
pub struct Gain {
    /// K = P⁻ Hᵀ S⁻¹ (n × m).
    pub gain: DMatrix<f64>,
    /// S = H P⁻ Hᵀ + R (m × m, symmetrised).
    pub innovation_cov: DMatrix<f64>,
    /// S⁻¹ (from the Cholesky factor of S, symmetrised).
    pub innovation_precision: DMatrix<f64>,
    /// ln det S.
    pub log_det: f64,
    /// P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ (Joseph form, symmetrised).
    pub posterior_cov: DMatrix<f64>,
}

impl Gain {
    /// The log-likelihood −½(νᵀS⁻¹ν + ln det S + m ln 2π) of an innovation ν.
    pub fn log_likelihood(&self, innovation: &DVector<f64>) -> f64 {
        let quad = innovation.dot(&(&self.innovation_precision * innovation));
        -0.5 * (quad + self.log_det + innovation.len() as f64 * LN_2PI)
    }
}

/// The result of an update.
#[derive(Clone, Debug, PartialEq)]
pub struct Update {
    /// N(x⁻ + K ν, Joseph-form P).
    pub posterior: Gaussian,
    /// ν = z − H x⁻.
    pub innovation: DVector<f64>,
    /// S = H P⁻ Hᵀ + R.
    pub innovation_cov: DMatrix<f64>,
    /// ln N(ν; 0, S) = −½(νᵀS⁻¹ν + ln det S + m ln 2π).
    pub log_likelihood: f64,
}

fn symmetrised(a: DMatrix<f64>) -> DMatrix<f64> {
    (&a + a.transpose()) * 0.5
}

/// P⁻ = F P Fᵀ + Q (symmetrised).
pub fn predict_cov(model: &LinearGaussian, cov: &DMatrix<f64>) -> DMatrix<f64> {
    symmetrised(&model.f * cov * model.f.transpose() + &model.q)
}

/// x⁻ = F x, P⁻ = F P Fᵀ + Q.
pub fn predict(model: &LinearGaussian, prior: &Gaussian) -> Gaussian {
    Gaussian {
        mean: &model.f * &prior.mean,
        cov: predict_cov(model, &prior.cov),
    }
}

/// The gain, innovation covariance and posterior covariance for a predicted covariance P⁻;
/// an error when S is not numerically positive definite (P⁻ overflowed or lost definiteness).
pub fn gain(model: &LinearGaussian, predicted_cov: &DMatrix<f64>) -> Result<Gain> {
    let ph = predicted_cov * model.h.transpose();
    let s = symmetrised(&model.h * &ph + &model.r);
    let chol = s.clone().cholesky().ok_or_else(|| {
        FieldError::InvalidParameter(
            "the innovation covariance H P Hᵀ + R is not positive definite (the predicted \
             covariance overflowed or is not a covariance)"
                .into(),
        )
    })?;
    let log_det = 2.0
        * chol
            .l_dirty()
            .diagonal()
            .iter()
            .map(|d| d.ln())
            .sum::<f64>();
    let precision = symmetrised(chol.inverse());
    let k = &ph * &precision;
    let n = model.state_dim();
    let i_kh = DMatrix::<f64>::identity(n, n) - &k * &model.h;
    let posterior_cov =
        symmetrised(&i_kh * predicted_cov * i_kh.transpose() + &k * &model.r * k.transpose());
    if !log_det.is_finite() || posterior_cov.iter().any(|v| !v.is_finite()) {
        return Err(FieldError::NonFinite(
            "the Kalman update overflowed float64 (covariances too large)".into(),
        ));
    }
    Ok(Gain {
        gain: k,
        innovation_cov: s,
        innovation_precision: precision,
        log_det,
        posterior_cov,
    })
}

/// The Joseph-form update of the predicted state with measurement z.
pub fn update(model: &LinearGaussian, predicted: &Gaussian, z: &DVector<f64>) -> Result<Update> {
    let m = model.measurement_dim();
    if z.len() != m {
        return Err(FieldError::Shape(format!(
            "a measurement must have {m} values, got {}",
            z.len()
        )));
    }
    if z.iter().any(|v| !v.is_finite()) {
        return Err(FieldError::NonFinite(
            "a measurement must hold finite numbers".into(),
        ));
    }
    let g = gain(model, &predicted.cov)?;
    let innovation = z - &model.h * &predicted.mean;
    let log_likelihood = g.log_likelihood(&innovation);
    Ok(Update {
        posterior: Gaussian {
            mean: &predicted.mean + &g.gain * &innovation,
            cov: g.posterior_cov,
        },
        innovation,
        innovation_cov: g.innovation_cov,
        log_likelihood,
    })
}
