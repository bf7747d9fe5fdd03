//! The data-independent half of a run: the gains of every frame for one model, from a
//! starting covariance and the pattern of missed frames. Packed for the lane kernel: only the
//! entries of K and S⁻¹ that are non-zero on some frame are kept (block-diagonal models have
//! block-diagonal gains), S⁻¹ as its upper triangle with doubled off-diagonal entries.

use crate::kalman::{gain, predict_cov, LinearGaussian};
use crate::Result;
use nalgebra::DMatrix;

/// ln 2π.
const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// The gains of a run of frames.
#[derive(Clone, Debug)]
pub(crate) struct Schedule {
    /// Whether each frame has a measurement (else: predict only).
    pub observed: Vec<bool>,
    /// (state i, measurement a) of the kept entries of K.
    pub gain_pattern: Vec<(usize, usize)>,
    /// Per frame, the kept entries of K in `gain_pattern` order (0 on missed frames).
    pub gain: Vec<f64>,
    /// (a, b), a ≤ b, of the kept entries of S⁻¹.
    pub precision_pattern: Vec<(usize, usize)>,
    /// Per frame, S⁻¹_ab (a = b) or 2 S⁻¹_ab (a < b) in `precision_pattern` order.
    pub precision: Vec<f64>,
    /// Per frame, ln det S + m ln 2π.
    pub offset: Vec<f64>,
    /// The covariance after the last frame.
    pub final_cov: DMatrix<f64>,
}

/// The schedule of `model` from covariance `start` over frames observed as in `observed`
/// (every frame predicts first); an error when a covariance overflows.
pub(crate) fn schedule(
    model: &LinearGaussian,
    start: &DMatrix<f64>,
    observed: &[bool],
) -> Result<Schedule> {
    let (n, m) = (model.state_dim(), model.measurement_dim());
    let mut cov = start.clone();
    let mut gains = Vec::with_capacity(observed.len());
    for &seen in observed {
        let predicted = predict_cov(model, &cov);
        if seen {
            let g = gain(model, &predicted)?;
            cov = g.posterior_cov.clone();
            gains.push(Some(g));
        } else {
            if predicted.iter().any(|v| !v.is_finite()) {
                return Err(crate::FieldError::NonFinite(
                    "the predicted covariance overflowed float64 (too many missed frames)".into(),
                ));
            }
            cov = predicted;
            gains.push(None);
        }
    }
    let kept = |test: &dyn Fn(&crate::kalman::Gain) -> bool| gains.iter().flatten().any(test);
    let gain_pattern: Vec<(usize, usize)> = (0..n)
        .flat_map(|i| (0..m).map(move |a| (i, a)))
        .filter(|&(i, a)| kept(&|g| g.gain[(i, a)] != 0.0))
        .collect();
    let precision_pattern: Vec<(usize, usize)> = (0..m)
        .flat_map(|a| (a..m).map(move |b| (a, b)))
        .filter(|&(a, b)| kept(&|g| g.innovation_precision[(a, b)] != 0.0))
        .collect();
    let mut packed = Schedule {
        observed: observed.to_vec(),
        gain: Vec::with_capacity(observed.len() * gain_pattern.len()),
        precision: Vec::with_capacity(observed.len() * precision_pattern.len()),
        offset: Vec::with_capacity(observed.len()),
        gain_pattern,
        precision_pattern,
        final_cov: cov,
    };
    for g in &gains {
        match g {
            Some(g) => {
                let k = packed.gain_pattern.iter().map(|&(i, a)| g.gain[(i, a)]);
                packed.gain.extend(k);
                let p = packed.precision_pattern.iter().map(|&(a, b)| {
                    let v = g.innovation_precision[(a, b)];
                    if a == b {
                        v
                    } else {
                        2.0 * v
                    }
                });
                packed.precision.extend(p);
                packed.offset.push(g.log_det + m as f64 * LN_2PI);
            }
            None => {
                let (gk, pk) = (packed.gain_pattern.len(), packed.precision_pattern.len());
                packed.gain.extend(std::iter::repeat_n(0.0, gk));
                packed.precision.extend(std::iter::repeat_n(0.0, pk));
                packed.offset.push(0.0);
            }
        }
    }
    Ok(packed)
}
