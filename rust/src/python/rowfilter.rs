//! Binding of the row filters (SPEC §2): `kalmanfield._core.VectorRowFilter`,
//! `ScalarRowFilter`, the Wiener bound and the row model's default orders.

use super::convert::{contiguous, output};
use super::field::PyFieldModel;
use super::threads::with_threads;
use crate::error::FieldError;
use crate::rowfilter::{
    wiener_bound as bound_kernel, wiener_error_map, ModeSet, RowModels, ScalarRowFilter,
    VectorRowFilter,
};
use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArrayDyn, PyReadwriteArrayDyn,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Adds the row filters' classes and functions to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyVectorRowFilter>()?;
    m.add_class::<PyScalarRowFilter>()?;
    m.add_function(wrap_pyfunction!(wiener_bound, m)?)?;
    m.add_function(wrap_pyfunction!(wiener_map, m)?)?;
    m.add_function(wrap_pyfunction!(default_ar_order, m)?)?;
    m.add_function(wrap_pyfunction!(model_ar_order, m)?)
}

/// `out` (same shape), GIL released.
fn filter_array(
    py: Python<'_>,
    z: PyReadonlyArrayDyn<'_, f64>,
    mut out: PyReadwriteArrayDyn<'_, f64>,
    threads: Option<usize>,
    image: impl Fn(&[f64], &mut [f64], usize) -> crate::Result<()> + Send + Sync,
    stack: impl Fn(&[f64], &mut [f64], usize, usize) -> crate::Result<()> + Send + Sync,
) -> PyResult<()> {
    let shape = z.shape().to_vec();
    let target = output(&mut out, &shape, "out")?;
    let values = contiguous(&z, "z")?;
    py.detach(|| {
        with_threads(threads, || match shape.as_slice() {
            [h, _] => image(values, target, *h),
            [f, h, _] => stack(values, target, *f, *h),
            _ => Err(FieldError::Shape("z must be 2-D or 3-D".into())),
        })
    })??;
    Ok(())
}

/// The optimal vector row filter (SPEC §2.1–2.2); wrapped by `kalmanfield.VectorRowFilter`.
#[pyclass(name = "VectorRowFilter", module = "kalmanfield._core", frozen)]
pub struct PyVectorRowFilter {
    inner: VectorRowFilter,
}

#[pymethods]
impl PyVectorRowFilter {
    #[new]
    fn new(py: Python<'_>, model: &PyFieldModel, noise_var: f64, width: usize) -> PyResult<Self> {
        let inner = py.detach(|| VectorRowFilter::new(&model.inner, noise_var, width))?;
        Ok(Self { inner })
    }

    /// Filters z (height × width, or frames × height × width) into `out` (same shape).
    #[pyo3(signature = (z, out, smooth, threads=None))]
    fn filter_into(
        &self,
        py: Python<'_>,
        z: PyReadonlyArrayDyn<'_, f64>,
        out: PyReadwriteArrayDyn<'_, f64>,
        smooth: bool,
        threads: Option<usize>,
    ) -> PyResult<()> {
        let filter = &self.inner;
        filter_array(
            py,
            z,
            out,
            threads,
            |z, out, h| filter.filter_image(z, out, h, smooth, true),
            |z, out, f, h| filter.filter_stack(z, out, f, h, smooth),
        )
    }

    /// Per-pixel error variance map (height × width) of the filter or of the smoother.
    fn error_variance<'py>(
        &self,
        py: Python<'py>,
        height: usize,
        smooth: bool,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let width = self.inner.width();
        let mut out = vec![0.0; height * width];
        py.detach(|| self.inner.error_variance(height, smooth, &mut out))?;
        PyArray1::from_vec(py, out).reshape([height, width])
    }
}

/// The quasi-optimal row filter (SPEC §2.3 generalised); wrapped by
/// `kalmanfield.ScalarRowFilter`.
#[pyclass(name = "ScalarRowFilter", module = "kalmanfield._core", frozen)]
pub struct PyScalarRowFilter {
    inner: ScalarRowFilter,
}

#[pymethods]
impl PyScalarRowFilter {
    #[new]
    #[pyo3(signature = (model, noise_var, width, ar_order=None, modes="ends", row_models="propagated"))]
    fn new(
        py: Python<'_>,
        model: &PyFieldModel,
        noise_var: f64,
        width: usize,
        ar_order: Option<usize>,
        modes: &str,
        row_models: &str,
    ) -> PyResult<Self> {
        let row_models = row_models_of(row_models)?;
        let set = match modes {
            "exact" => ModeSet::Exact,
            "ends" => ModeSet::Ends,
            "toeplitz" => ModeSet::Toeplitz,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "modes must be 'ends', 'exact' or 'toeplitz', got {modes:?}"
                )))
            }
        };
        let inner =
            py.detach(|| ScalarRowFilter::new(&model.inner, noise_var, width, ar_order, set))?;
        Ok(Self {
            inner: inner.with_row_models(row_models),
        })
    }

    /// W' of the exact ends of the "ends" modes (None: no splice).
    fn ends_span(&self) -> Option<usize> {
        self.inner.ends_span()
    }

    /// Half-bandwidth of the row systems.
    fn bandwidth(&self) -> usize {
        self.inner.bandwidth()
    }

    /// The causal filter's per-pixel error variance map (height × width); `weights`:
    /// per-pixel 1/σ_θ² of that shape (0 = missing pixel), None = nominal.
    #[pyo3(signature = (height, weights=None))]
    fn error_variance<'py>(
        &self,
        py: Python<'py>,
        height: usize,
        weights: Option<PyReadonlyArrayDyn<'_, f64>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let width = self.inner.width();
        let weights = weights
            .as_ref()
            .map(|w| contiguous(w, "weights"))
            .transpose()?;
        let out = py.detach(|| self.inner.error_variance(height, weights))?;
        PyArray1::from_vec(py, out).reshape([height, width])
    }

    /// Filters z (height × width, or frames × height × width) into `out` (same shape);
    /// `weights`: per-pixel 1/σ_θ² of z's shape (0 = missing pixel).
    #[pyo3(signature = (z, out, smooth, threads=None, weights=None))]
    fn filter_into(
        &self,
        py: Python<'_>,
        z: PyReadonlyArrayDyn<'_, f64>,
        out: PyReadwriteArrayDyn<'_, f64>,
        smooth: bool,
        threads: Option<usize>,
        weights: Option<PyReadonlyArrayDyn<'_, f64>>,
    ) -> PyResult<()> {
        if let Some(w) = &weights {
            if w.shape() != z.shape() {
                return Err(PyValueError::new_err("weights must have the shape of z"));
            }
        }
        let weights = weights
            .as_ref()
            .map(|w| contiguous(w, "weights"))
            .transpose()?;
        let filter = &self.inner;
        filter_array(
            py,
            z,
            out,
            threads,
            |z, out, h| filter.filter_image(z, weights, out, h, smooth),
            |z, out, f, h| filter.filter_stack(z, weights, out, f, h, smooth),
        )
    }
}

/// The default order m of the quasi-optimal filter's row model for multiplicities (n_y, n_x)
/// (`rowfilter::default_ar_order`).
#[pyfunction]
fn default_ar_order(n_y: usize, n_x: usize) -> usize {
    crate::rowfilter::default_ar_order(n_y, n_x)
}

/// The row model of order n_x, 2 ≤ m ≤ 8, that `denoise` uses
/// (`rowfilter::model_ar_order`).
#[pyfunction]
fn model_ar_order(n_x: usize) -> usize {
    crate::rowfilter::model_ar_order(n_x)
}

/// `RowModels` by name.
pub(super) fn row_models_of(name: &str) -> PyResult<RowModels> {
    match name {
        "propagated" => Ok(RowModels::Propagated),
        "nominal" => Ok(RowModels::Nominal),
        "implied" => Ok(RowModels::Implied),
        _ => Err(PyValueError::new_err(format!(
            "row_models must be 'propagated', 'nominal' or 'implied', got {name:?}"
        ))),
    }
}

/// Mean error variance of the best linear estimator on a height × width grid (SPEC §2.4).
#[pyfunction]
fn wiener_bound(
    py: Python<'_>,
    model: &PyFieldModel,
    noise_var: f64,
    height: usize,
    width: usize,
) -> PyResult<f64> {
    Ok(py.detach(|| bound_kernel(&model.inner, noise_var, height, width))?)
}

/// Per-pixel error variance of the best linear estimator (SPEC §2.4).
#[pyfunction]
fn wiener_map<'py>(
    py: Python<'py>,
    model: &PyFieldModel,
    noise_var: f64,
    height: usize,
    width: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let mut out = vec![0.0; height * width];
    py.detach(|| wiener_error_map(&model.inner, noise_var, height, width, &mut out))?;
    PyArray1::from_vec(py, out).reshape([height, width])
}
