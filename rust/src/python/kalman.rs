//! Binding of the generic Kalman domain: the motion models as (F, Q, H, R) arrays and a
//! predict-then-update run of one model over a measurement sequence.

use crate::kalman::{self, Gaussian, LinearGaussian};
use nalgebra::{DMatrix, DVector};
use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use numpy::{PyUntypedArrayMethods, ToPyArray};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

type Matrices<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
);

/// A NumPy (row-major) 2-D array as a matrix.
pub(super) fn matrix(a: &PyReadonlyArray2<'_, f64>) -> DMatrix<f64> {
    let view = a.as_array();
    DMatrix::from_fn(view.nrows(), view.ncols(), |i, j| view[[i, j]])
}

/// A matrix as a NumPy 2-D array.
pub(super) fn array2<'py>(py: Python<'py>, a: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    a.transpose()
        .as_slice()
        .to_pyarray(py)
        .reshape([a.nrows(), a.ncols()])
        .unwrap()
}

/// The checked model from its four arrays.
pub(super) fn linear_gaussian(
    f: &PyReadonlyArray2<'_, f64>,
    q: &PyReadonlyArray2<'_, f64>,
    h: &PyReadonlyArray2<'_, f64>,
    r: &PyReadonlyArray2<'_, f64>,
) -> PyResult<LinearGaussian> {
    Ok(LinearGaussian::new(
        matrix(f),
        matrix(q),
        matrix(h),
        matrix(r),
    )?)
}

/// The checked Gaussian from a mean vector and a covariance array.
pub(super) fn gaussian(
    mean: &PyReadonlyArray1<'_, f64>,
    cov: &PyReadonlyArray2<'_, f64>,
) -> PyResult<Gaussian> {
    let mean = DVector::from_iterator(mean.len(), mean.as_array().iter().copied());
    Ok(Gaussian::new(mean, matrix(cov))?)
}

fn matrices<'py>(py: Python<'py>, model: PyResult<LinearGaussian>) -> PyResult<Matrices<'py>> {
    let m = model?;
    Ok((
        array2(py, &m.f),
        array2(py, &m.q),
        array2(py, &m.h),
        array2(py, &m.r),
    ))
}

/// (F, Q, H, R) of the constant-velocity model (continuous white acceleration of PSD q).
#[pyfunction]
fn kalman_constant_velocity(
    py: Python<'_>,
    dt: f64,
    q: f64,
    ndim: usize,
    measurement_std: f64,
) -> PyResult<Matrices<'_>> {
    let model = kalman::constant_velocity(dt, q, ndim, measurement_std);
    matrices(py, model.map_err(PyErr::from))
}

/// (F, Q, H, R) of the constant-acceleration model (continuous white jerk of PSD q).
#[pyfunction]
fn kalman_constant_acceleration(
    py: Python<'_>,
    dt: f64,
    q: f64,
    ndim: usize,
    measurement_std: f64,
) -> PyResult<Matrices<'_>> {
    let model = kalman::constant_acceleration(dt, q, ndim, measurement_std);
    matrices(py, model.map_err(PyErr::from))
}

/// (F, Q, H, R) of the Singer-type model (Markov acceleration, correlation rho, std sigma_a).
#[pyfunction]
fn kalman_singer(
    py: Python<'_>,
    dt: f64,
    rho: f64,
    sigma_a: f64,
    ndim: usize,
    measurement_std: f64,
) -> PyResult<Matrices<'_>> {
    let model = kalman::singer(dt, rho, sigma_a, ndim, measurement_std);
    matrices(py, model.map_err(PyErr::from))
}

/// (F, Q, H, R) of the Markov-velocity model (correlation rho, stationary std sigma).
#[pyfunction]
fn kalman_markov_velocity(
    py: Python<'_>,
    dt: f64,
    rho: f64,
    sigma: f64,
    ndim: usize,
    measurement_std: f64,
) -> PyResult<Matrices<'_>> {
    let model = kalman::markov_velocity(dt, rho, sigma, ndim, measurement_std);
    matrices(py, model.map_err(PyErr::from))
}

type FilterOutput<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray3<f64>>,
    Bound<'py, PyArray1<f64>>,
);

/// Predict-then-update over the rows of `measurements` (an all-NaN row: predict only):
/// posterior means (N, n), covariances (N, n, n), per-frame log-likelihoods (N,).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn kalman_filter<'py>(
    py: Python<'py>,
    f: PyReadonlyArray2<'py, f64>,
    q: PyReadonlyArray2<'py, f64>,
    h: PyReadonlyArray2<'py, f64>,
    r: PyReadonlyArray2<'py, f64>,
    mean: PyReadonlyArray1<'py, f64>,
    cov: PyReadonlyArray2<'py, f64>,
    measurements: PyReadonlyArray2<'py, f64>,
) -> PyResult<FilterOutput<'py>> {
    let model = linear_gaussian(&f, &q, &h, &r)?;
    let mut state = gaussian(&mean, &cov)?;
    if state.dim() != model.state_dim() {
        return Err(PyValueError::new_err(format!(
            "the prior has {} states, the model {}",
            state.dim(),
            model.state_dim()
        )));
    }
    let rows = measurements.as_array();
    let (frames, n) = (rows.nrows(), model.state_dim());
    let (mut means, mut covs, mut logliks) = (Vec::new(), Vec::new(), Vec::new());
    for row in rows.rows() {
        let predicted = kalman::predict(&model, &state);
        let z = DVector::from_iterator(row.len(), row.iter().copied());
        let missed = z.iter().all(|v| v.is_nan());
        let (next, loglik) = if missed {
            (predicted, 0.0)
        } else {
            let up = kalman::update(&model, &predicted, &z)?;
            (up.posterior, up.log_likelihood)
        };
        means.extend(next.mean.iter());
        covs.extend(next.cov.transpose().iter());
        logliks.push(loglik);
        state = next;
    }
    Ok((
        PyArray1::from_vec(py, means).reshape([frames, n])?,
        PyArray1::from_vec(py, covs).reshape([frames, n, n])?,
        PyArray1::from_vec(py, logliks),
    ))
}

/// Adds the Kalman functions to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(kalman_constant_velocity, m)?)?;
    m.add_function(wrap_pyfunction!(kalman_constant_acceleration, m)?)?;
    m.add_function(wrap_pyfunction!(kalman_singer, m)?)?;
    m.add_function(wrap_pyfunction!(kalman_markov_velocity, m)?)?;
    m.add_function(wrap_pyfunction!(kalman_filter, m)?)?;
    Ok(())
}
