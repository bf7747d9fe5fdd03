//! The whitening operator of a separable multiple-root model: e = Π_k (1 - ρ_k z_k⁻¹)^{n_k} x,
//! white for a field of that model (SPEC §1.2); used for the residual test of SPEC §1.6.

use crate::error::{FieldError, Result};
use rayon::prelude::*;

/// Applies (1 - ρ z⁻¹)ⁿ along `axis` of `data` (C order, `shape`) in place. The first n
/// elements of every line have no residual and become NaN; NaN inputs spread to the n
/// following elements.
pub fn whiten_axis(
    data: &mut [f64],
    shape: &[usize],
    axis: usize,
    rho: f64,
    n: usize,
) -> Result<()> {
    if axis >= shape.len() || shape.iter().product::<usize>() != data.len() {
        return Err(FieldError::Shape(format!(
            "axis {axis} of shape {shape:?} does not fit {} values",
            data.len()
        )));
    }
    if !(rho.is_finite() && rho.abs() < 1.0) {
        return Err(FieldError::InvalidParameter(format!(
            "rho must lie in (-1, 1), got {rho}"
        )));
    }
    let (len, inner) = (shape[axis], shape[axis + 1..].iter().product::<usize>());
    if len == 0 || inner == 0 {
        return Ok(());
    }
    data.par_chunks_mut(len * inner)
        .for_each(|slab| (0..n).for_each(|_| whiten_slab_once(slab, inner, rho)));
    Ok(())
}

/// One factor (1 - ρ z⁻¹) on a (len, inner) slab, rows from the last to the first.
fn whiten_slab_once(slab: &mut [f64], inner: usize, rho: f64) {
    let len = slab.len() / inner;
    for i in (1..len).rev() {
        let (before, current) = slab.split_at_mut(i * inner);
        let previous = &before[(i - 1) * inner..];
        current[..inner]
            .iter_mut()
            .zip(previous)
            .for_each(|(x, p)| *x -= rho * p);
    }
    slab[..inner].fill(f64::NAN);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_difference_of_an_ar1_line() {
        let mut x = vec![1.0, 2.0, 4.0, 8.0];
        whiten_axis(&mut x, &[4], 0, 0.5, 1).unwrap();
        assert!(x[0].is_nan());
        assert_eq!(&x[1..], &[1.5, 3.0, 6.0]);
    }

    #[test]
    fn axis_zero_of_a_grid_and_order_two() {
        let mut x: Vec<f64> = (0..12).map(|i| i as f64).collect();
        whiten_axis(&mut x, &[4, 3], 0, 0.5, 2).unwrap();
        // (1 - 0.5 z⁻¹)² x_i = x_i - x_{i-1} + 0.25 x_{i-2} along rows of 3
        for c in 0..3 {
            for r in 2..4 {
                let v = |rr: usize| (rr * 3 + c) as f64;
                let want = v(r) - v(r - 1) + 0.25 * v(r - 2);
                assert!((x[r * 3 + c] - want).abs() < 1e-12);
            }
            assert!(x[c].is_nan() && x[3 + c].is_nan());
        }
    }

    #[test]
    fn bad_rho_is_an_error() {
        assert!(whiten_axis(&mut [1.0, 2.0], &[2], 0, 1.0, 1).is_err());
        assert!(whiten_axis(&mut [1.0, 2.0], &[2], 1, 0.5, 1).is_err());
    }
}
