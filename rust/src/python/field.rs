//! Binding of the field model (SPEC §1): `kalmanfield._core.FieldModel` (sampling,
//! streams, the product field, correlations, anisotropy) and `axis_correlation_table`.

use super::convert::{contiguous, shaped_mut, with_dtype};
use super::threads::with_threads;
use crate::field::{
    anisotropy, correlation_table, product_field_into, sample_into, stream_frame_into,
    AxisRecursion, DrivingNoise, FieldModel, Real, MAX_ORDER,
};
use numpy::{
    Element, PyArray1, PyArray2, PyArrayDyn, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyReadonlyArrayDyn, PyReadwriteArrayDyn,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// Adds the field model's class, functions and constants to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyFieldModel>()?;
    m.add_function(wrap_pyfunction!(axis_correlation_table, m)?)?;
    m.add("MAX_ORDER", MAX_ORDER)
}

/// The separable multiple-root AR field model (SPEC §1.2); wrapped by `kalmanfield.ARFieldModel`.
#[pyclass(name = "FieldModel", module = "kalmanfield._core", frozen)]
pub(super) struct PyFieldModel {
    pub(super) inner: FieldModel,
}

/// The error for an output that is not a writable float64 or float32 array.
fn not_a_float_output() -> PyErr {
    PyTypeError::new_err("output must be a writable float64 or float32 numpy array")
}

fn noise_slice<'a>(noise: &'a Option<PyReadonlyArrayDyn<'_, f64>>) -> PyResult<Option<&'a [f64]>> {
    noise.as_ref().map(|n| contiguous(n, "noise")).transpose()
}

fn seeded_or_given(seed: u64, given: Option<&[f64]>) -> DrivingNoise<'_> {
    match given {
        Some(values) => DrivingNoise::Given {
            values,
            first_line: 0,
        },
        None => DrivingNoise::Seeded(seed),
    }
}

fn history_slices<'py, T: Real + Element>(
    history: &'py [Bound<'py, PyAny>],
) -> PyResult<Vec<PyReadonlyArrayDyn<'py, T>>> {
    history
        .iter()
        .map(|h| {
            h.extract::<PyReadonlyArrayDyn<T>>().map_err(|_| {
                PyTypeError::new_err("history frames must have the dtype of the output")
            })
        })
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn stream_step<T: Real + Element>(
    py: Python<'_>,
    model: &FieldModel,
    frame: &mut [T],
    shape: &[usize],
    history: &[Bound<'_, PyAny>],
    t: u64,
    noise: DrivingNoise,
    threads: Option<usize>,
) -> PyResult<()> {
    let arrays = history_slices::<T>(history)?;
    let slices = arrays
        .iter()
        .map(|a| contiguous(a, "history frames"))
        .collect::<PyResult<Vec<&[T]>>>()?;
    py.detach(|| {
        with_threads(threads, || {
            stream_frame_into(model, frame, shape, &slices, t, noise)
        })
    })??;
    Ok(())
}

#[pymethods]
impl PyFieldModel {
    #[new]
    fn new(rho: Vec<f64>, order: Vec<usize>, sigma: f64) -> PyResult<Self> {
        Ok(Self {
            inner: FieldModel::new(&rho, &order, sigma)?,
        })
    }

    /// β = σ Π_k β̃_k  [P 2.16].
    fn beta(&self) -> f64 {
        self.inner.beta()
    }

    /// The template c_j̄ of shape (n_1+1, …, n_N+1)  [P 2.14].
    fn template<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let (values, shape) = self.inner.template();
        PyArray1::from_vec(py, values).reshape(shape)
    }

    /// σ² Π R_k(r_k) for an (M, N) array of lags.
    fn correlation<'py>(
        &self,
        py: Python<'py>,
        lags: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let lags = contiguous(&lags, "lags")?;
        Ok(PyArray1::from_vec(py, self.inner.correlation(lags)?))
    }

    /// A_τ of SPEC §1.5.
    fn anisotropy(&self, py: Python<'_>) -> f64 {
        py.detach(|| anisotropy(&self.inner))
    }

    /// (coefficients per position, gains) of the stationary-start recursion of `axis` (§1.3).
    fn boundary(&self, axis: usize) -> PyResult<(Vec<Vec<f64>>, Vec<f64>)> {
        let model = self
            .inner
            .axes()
            .get(axis)
            .ok_or_else(|| PyValueError::new_err(format!("axis {axis} out of range")))?;
        let rec = AxisRecursion::<f64>::new(model, 1.0)?;
        let n = rec.order();
        Ok((0..=n).map(|l| (rec.at(l).0.to_vec(), rec.at(l).1)).unzip())
    }

    /// Fills `out` (float64/float32, C order) with one realisation (SPEC §1.2–1.3).
    #[pyo3(signature = (out, seed, noise=None, threads=None))]
    fn sample_into(
        &self,
        py: Python<'_>,
        out: &Bound<'_, PyAny>,
        seed: u64,
        noise: Option<PyReadonlyArrayDyn<'_, f64>>,
        threads: Option<usize>,
    ) -> PyResult<()> {
        let given = noise_slice(&noise)?;
        let model = &self.inner;
        with_dtype!(out, PyReadwriteArrayDyn<f64, f32>, |array| {
            let (shape, slice) = shaped_mut(&mut array, "output")?;
            py.detach(|| {
                with_threads(threads, || {
                    sample_into(model, slice, &shape, seeded_or_given(seed, given))
                })
            })??;
            Ok(())
        }, else Err(not_a_float_output()))
    }

    /// Frame `t` of a stream (axis 0 = time); `history` = previous frames, most recent first.
    #[pyo3(signature = (out, history, t, seed, noise=None, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn stream_into(
        &self,
        py: Python<'_>,
        out: &Bound<'_, PyAny>,
        history: Vec<Bound<'_, PyAny>>,
        t: u64,
        seed: u64,
        noise: Option<PyReadonlyArrayDyn<'_, f64>>,
        threads: Option<usize>,
    ) -> PyResult<()> {
        let given = noise_slice(&noise)?;
        let model = &self.inner;
        with_dtype!(out, PyReadwriteArrayDyn<f64, f32>, |array| {
            let (shape, slice) = shaped_mut(&mut array, "output")?;
            let noise = seeded_or_given(seed, given);
            stream_step(py, model, slice, &shape, &history, t, noise, threads)
        }, else Err(not_a_float_output()))
    }

    /// Fills `out` with the product field of SPEC §1.4; `noise` = one 1-D array per axis.
    #[pyo3(signature = (out, seed, noise=None, threads=None))]
    fn product_into(
        &self,
        py: Python<'_>,
        out: &Bound<'_, PyAny>,
        seed: u64,
        noise: Option<Vec<PyReadonlyArray1<'_, f64>>>,
        threads: Option<usize>,
    ) -> PyResult<()> {
        let slices = noise
            .as_ref()
            .map(|v| {
                v.iter()
                    .map(|a| contiguous(a, "noise"))
                    .collect::<PyResult<Vec<&[f64]>>>()
            })
            .transpose()?;
        let model = &self.inner;
        with_dtype!(out, PyReadwriteArrayDyn<f64, f32>, |array| {
            let (shape, slice) = shaped_mut(&mut array, "output")?;
            py.detach(|| {
                with_threads(threads, || {
                    product_field_into(model, slice, &shape, seed, slices.as_deref())
                })
            })??;
            Ok(())
        }, else Err(not_a_float_output()))
    }
}

/// R_{n,ρ}(lag) of one axis for every ρ of `rhos` (rows) and lag of `lags` (columns).
#[pyfunction]
fn axis_correlation_table<'py>(
    py: Python<'py>,
    rhos: PyReadonlyArray1<'py, f64>,
    order: usize,
    lags: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (r, l) = (contiguous(&rhos, "rhos")?, contiguous(&lags, "lags")?);
    let table = correlation_table(r, order, l)?;
    PyArray1::from_vec(py, table).reshape([r.len(), l.len()])
}
