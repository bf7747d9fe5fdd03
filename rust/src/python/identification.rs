//! Binding of the identification statistics (SPEC §1.6): difference Gram, lagged products,
//! whitening and the χ² tail and quantile.

use super::convert::{contiguous, contiguous_mut};
use super::threads::with_threads;
use crate::identification::{
    chi_squared_quantile, chi_squared_sf, difference_gram as gram_kernel,
    lag_products as lag_kernel, whiten_axis, MAX_DIFFERENCE_ORDER,
};
use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArrayDyn, PyReadwriteArrayDyn,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;

/// Adds the identification functions and constants to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(difference_gram, m)?)?;
    m.add_function(wrap_pyfunction!(lag_products, m)?)?;
    m.add_function(wrap_pyfunction!(whiten_axis_into, m)?)?;
    m.add_function(wrap_pyfunction!(chi2_sf, m)?)?;
    m.add_function(wrap_pyfunction!(chi2_quantile, m)?)?;
    m.add("MAX_DIFFERENCE_ORDER", MAX_DIFFERENCE_ORDER)
}

/// Difference Gram G_ab = Σ DᵃxDᵇx along `axis` (SPEC §1.6); NaN marks missing values.
#[pyfunction]
#[pyo3(signature = (data, axis, max_order, threads=None))]
fn difference_gram<'py>(
    py: Python<'py>,
    data: PyReadonlyArrayDyn<'py, f64>,
    axis: usize,
    max_order: usize,
    threads: Option<usize>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, u64)> {
    let shape = data.shape().to_vec();
    let values = contiguous(&data, "data")?;
    let gram =
        py.detach(|| with_threads(threads, || gram_kernel(values, &shape, axis, max_order)))??;
    let width = max_order + 1;
    let matrix = PyArray1::from_vec(py, gram.symmetric()).reshape([width, width])?;
    Ok((matrix, gram.count))
}

/// (S_h, N_h) as numpy arrays.
type LagArrays<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<u64>>);

/// Lagged products S_h = Σ x_i x_{i+h} and pair counts along `axis`, h = 0..=max_lag.
#[pyfunction]
#[pyo3(signature = (data, axis, max_lag, threads=None))]
fn lag_products<'py>(
    py: Python<'py>,
    data: PyReadonlyArrayDyn<'py, f64>,
    axis: usize,
    max_lag: usize,
    threads: Option<usize>,
) -> PyResult<LagArrays<'py>> {
    let shape = data.shape().to_vec();
    let values = contiguous(&data, "data")?;
    let lags =
        py.detach(|| with_threads(threads, || lag_kernel(values, &shape, axis, max_lag)))??;
    Ok((
        PyArray1::from_vec(py, lags.sums),
        PyArray1::from_vec(py, lags.counts),
    ))
}

/// Applies (1 - ρ z⁻¹)ⁿ along `axis` in place (SPEC §1.6 residuals).
#[pyfunction]
fn whiten_axis_into(
    py: Python<'_>,
    mut data: PyReadwriteArrayDyn<'_, f64>,
    axis: usize,
    rho: f64,
    order: usize,
) -> PyResult<()> {
    let shape = data.shape().to_vec();
    let values = contiguous_mut(&mut data, "data")?;
    py.detach(|| whiten_axis(values, &shape, axis, rho, order))?;
    Ok(())
}

/// P(χ²_dof > x).
#[pyfunction]
fn chi2_sf(x: f64, dof: f64) -> PyResult<f64> {
    Ok(chi_squared_sf(x, dof)?)
}

/// The χ² quantile of probability p.
#[pyfunction]
fn chi2_quantile(p: f64, dof: f64) -> PyResult<f64> {
    Ok(chi_squared_quantile(p, dof)?)
}
