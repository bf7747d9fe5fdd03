//! The error of the best linear (non-causal) estimator of a separable 2-D field from
//! z = x + θ on a finite grid (SPEC §2.4): the floor no row filter can beat.
//!
//! Cov(x) = σ² R_y ⊗ R_x = (U_y ⊗ U_x) diag(σ² λ_a μ_b) (U_y ⊗ U_x)ᵀ, so the posterior
//! covariance is (U_y ⊗ U_x) diag(f_ab) (U_y ⊗ U_x)ᵀ with f_ab = σ²λ_aμ_b s / (σ²λ_aμ_b + s),
//! its trace / (H W) = mean f_ab and its diagonal (U_y∘U_y) F (U_x∘U_x)ᵀ.

use crate::error::{FieldError, Result};
use crate::field::{AxisModes, FieldModel};
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatMut, Par};

fn check(model: &FieldModel, noise_var: f64, height: usize, width: usize) -> Result<()> {
    if model.ndim() != 2 {
        return Err(FieldError::InvalidParameter(format!(
            "the Wiener bound needs a 2-axis model, got {} axes",
            model.ndim()
        )));
    }
    crate::error::check_noise_var(noise_var)?;
    if height == 0 || width == 0 {
        return Err(FieldError::Shape("the grid must not be empty".into()));
    }
    Ok(())
}

fn posterior_variances(
    model: &FieldModel,
    noise_var: f64,
    y: &AxisModes,
    x: &AxisModes,
) -> Mat<f64> {
    let signal = model.sigma() * model.sigma();
    Mat::from_fn(y.size(), x.size(), |a, b| {
        let v = signal * y.values[a] * x.values[b];
        v * noise_var / (v + noise_var)
    })
}

/// Mean error variance of the best linear estimator on a height × width grid.
pub fn wiener_bound(
    model: &FieldModel,
    noise_var: f64,
    height: usize,
    width: usize,
) -> Result<f64> {
    check(model, noise_var, height, width)?;
    let y = AxisModes::new(&model.axes()[0], height)?;
    let x = AxisModes::new(&model.axes()[1], width)?;
    let f = posterior_variances(model, noise_var, &y, &x);
    let total: f64 = (0..width).map(|b| f.col(b).iter().sum::<f64>()).sum();
    Ok(total / (height * width) as f64)
}

/// Per-pixel error variance of the best linear estimator, written row-major into `out`
/// (height × width).
pub fn wiener_error_map(
    model: &FieldModel,
    noise_var: f64,
    height: usize,
    width: usize,
    out: &mut [f64],
) -> Result<()> {
    check(model, noise_var, height, width)?;
    if out.len() != height * width {
        return Err(FieldError::Shape(format!(
            "the output holds {} values, not {height}×{width}",
            out.len()
        )));
    }
    let y = AxisModes::new(&model.axes()[0], height)?;
    let x = AxisModes::new(&model.axes()[1], width)?;
    let f = posterior_variances(model, noise_var, &y, &x);
    let mut left = Mat::<f64>::zeros(height, width);
    matmul(
        &mut left,
        Accum::Replace,
        y.squared_vectors(),
        &f,
        1.0,
        Par::rayon(0),
    );
    let dst = MatMut::from_row_major_slice_mut(out, height, width);
    matmul(
        dst,
        Accum::Replace,
        &left,
        x.squared_vectors().transpose(),
        1.0,
        Par::rayon(0),
    );
    crate::simd::clear_upper_state();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_field_bound_is_the_scalar_wiener_error() {
        // ρ → 0 is not allowed; a (1,1) model with tiny ρ is nearly white: f = σ²s/(σ²+s).
        let model = FieldModel::new(&[1e-9, 1e-9], &[1, 1], 2.0).unwrap();
        let b = wiener_bound(&model, 1.0, 5, 7).unwrap();
        assert!((b - 4.0 / 5.0).abs() < 1e-8);
        let mut map = vec![0.0; 35];
        wiener_error_map(&model, 1.0, 5, 7, &mut map).unwrap();
        assert!(map.iter().all(|v| (v - 0.8).abs() < 1e-8));
    }

    #[test]
    fn map_averages_to_the_bound() {
        let model = FieldModel::new(&[0.9, 0.7], &[2, 1], 1.0).unwrap();
        let b = wiener_bound(&model, 0.5, 9, 11).unwrap();
        let mut map = vec![0.0; 99];
        wiener_error_map(&model, 0.5, 9, 11, &mut map).unwrap();
        let mean = map.iter().sum::<f64>() / 99.0;
        assert!((mean - b).abs() < 1e-12);
        // corners see fewer neighbours than the centre
        assert!(map[0] > map[4 * 11 + 5]);
    }

    #[test]
    fn bad_arguments() {
        let model = FieldModel::new(&[0.9], &[1], 1.0).unwrap();
        assert!(wiener_bound(&model, 1.0, 4, 4).is_err());
        let model = FieldModel::new(&[0.9, 0.9], &[1, 1], 1.0).unwrap();
        assert!(wiener_bound(&model, 0.0, 4, 4).is_err());
        assert!(wiener_bound(&model, 1.0, 0, 4).is_err());
    }
}
