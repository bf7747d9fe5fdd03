//! The product model of SPEC §1.4 [P 2.18]: x_ī = σ Π_k s^{(k)}_{i_k} with N independent
//! unit-variance stationary 1-D sequences s^{(k)} of the axis models. Same correlation
//! function as the Gaussian field, non-Gaussian marginal, O(1) work per element.

use super::cascade::lines_into;
use super::driving_noise::DrivingNoise;
use super::field_model::FieldModel;
use super::real::Real;
use super::stationary_start::AxisRecursion;
use crate::error::{FieldError, Result};
use rayon::prelude::*;

/// Fills `out` (C order, `shape`) with a product field. With `given`, sequence k is driven by
/// `given[k]` (length shape[k]); otherwise by line k of the seeded noise streams.
pub fn product_field_into<T: Real>(
    model: &FieldModel,
    out: &mut [T],
    shape: &[usize],
    seed: u64,
    given: Option<&[&[f64]]>,
) -> Result<()> {
    let total = shape.iter().try_fold(1usize, |acc, &s| acc.checked_mul(s));
    if shape.len() != model.ndim() || shape.contains(&0) || total != Some(out.len()) {
        return Err(FieldError::Shape(format!(
            "shape {shape:?} does not fit a {}-axis model and an output of {} elements",
            model.ndim(),
            out.len()
        )));
    }
    if let Some(g) = given {
        if g.len() != shape.len() || g.iter().zip(shape).any(|(s, &n)| s.len() != n) {
            return Err(FieldError::Shape(format!(
                "noise must be {} sequences of lengths {shape:?}",
                shape.len()
            )));
        }
        if g.iter().any(|s| s.iter().any(|v| !v.is_finite())) {
            return Err(FieldError::NonFinite(
                "noise contains NaN or infinite values".into(),
            ));
        }
    }
    let sequences: Vec<Vec<f64>> = model
        .axes()
        .iter()
        .zip(shape)
        .enumerate()
        .map(|(k, (axis, &len))| {
            let mut s = vec![0.0; len];
            let recursion = AxisRecursion::new(axis, 1.0)?;
            let noise = match given {
                Some(g) => DrivingNoise::Given {
                    values: g[k],
                    first_line: k as u64,
                },
                None => DrivingNoise::Seeded(seed),
            };
            lines_into(&mut s, len, &recursion, &noise, k as u64);
            Ok(s)
        })
        .collect::<Result<_>>()?;
    // outer product of axes 1.. (the slab), then one scaled copy per index of axis 0
    let mut slab = vec![1.0f64];
    for s in &sequences[1..] {
        slab = slab
            .iter()
            .flat_map(|v| s.iter().map(move |x| v * x))
            .collect();
    }
    let sigma = model.sigma();
    out.par_chunks_mut(slab.len())
        .zip(&sequences[0])
        .for_each(|(chunk, &s0)| {
            let scale = sigma * s0;
            chunk
                .iter_mut()
                .zip(&slab)
                .for_each(|(v, &p)| *v = T::from_f64(scale * p));
        });
    Ok(())
}
