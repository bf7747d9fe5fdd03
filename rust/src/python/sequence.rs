//! Binding of the sequence filters (SPEC §2.5): `kalmanfield._core.ModalSequenceFilter` and
//! `FastSequenceFilter`, wrapped by `kalmanfield.SequenceFilter`.

use super::convert::contiguous;
use super::field::PyFieldModel;
use super::threads::with_threads;
use crate::sequence::{FastSequenceFilter, ModalSequenceFilter};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;

/// Adds the sequence filters' classes to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyModalSequenceFilter>()?;
    m.add_class::<PyFastSequenceFilter>()
}

type Frame<'py> = Bound<'py, PyArray1<f64>>;

/// The exact filter over frames per spatial mode, or its fixed-lag smoother.
#[pyclass(name = "ModalSequenceFilter", module = "kalmanfield._core")]
pub struct PyModalSequenceFilter {
    inner: ModalSequenceFilter,
}

#[pymethods]
impl PyModalSequenceFilter {
    #[new]
    fn new(
        py: Python<'_>,
        model: &PyFieldModel,
        noise_var: f64,
        height: usize,
        width: usize,
        lag: usize,
    ) -> PyResult<Self> {
        let inner =
            py.detach(|| ModalSequenceFilter::new(&model.inner, noise_var, height, width, lag))?;
        Ok(Self { inner })
    }

    /// The estimate of frame t − lag (flat H·W) after frame `z` (flat, NaN = missing), None
    /// while fewer than lag + 1 frames were seen. GIL released.
    #[pyo3(signature = (z, threads=None))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        z: PyReadonlyArray1<'py, f64>,
        threads: Option<usize>,
    ) -> PyResult<Option<Frame<'py>>> {
        let values = contiguous(&z, "z")?;
        let mut out = vec![0.0; values.len()];
        let inner = &mut self.inner;
        let written = py.detach(|| with_threads(threads, || inner.step(values, &mut out)))??;
        Ok(written.then(|| PyArray1::from_vec(py, out)))
    }

    /// The estimates of the frames not yet returned, oldest first (flat).
    fn pending<'py>(&self, py: Python<'py>) -> PyResult<Frame<'py>> {
        Ok(PyArray1::from_vec(py, self.inner.pending()?))
    }

    /// The steady per-pixel error variance (flat H·W).
    #[pyo3(signature = (threads=None))]
    fn error_variance<'py>(&self, py: Python<'py>, threads: Option<usize>) -> PyResult<Frame<'py>> {
        let inner = &self.inner;
        let map = py.detach(|| with_threads(threads, || inner.error_variance()))?;
        Ok(PyArray1::from_vec(py, map))
    }

    /// (frames seen, means, covariances).
    fn state<'py>(&self, py: Python<'py>) -> (u64, Frame<'py>, Frame<'py>) {
        let (frames, means, covs) = self.inner.state();
        (
            frames,
            PyArray1::from_slice(py, means),
            PyArray1::from_slice(py, covs),
        )
    }

    /// Restores a state saved by `state`.
    fn set_state(
        &mut self,
        frames: u64,
        means: PyReadonlyArray1<'_, f64>,
        covs: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<()> {
        let (means, covs) = (contiguous(&means, "means")?, contiguous(&covs, "covs")?);
        Ok(self.inner.set_state(frames, means, covs)?)
    }
}

/// The fast filter over frames: temporal prediction + the smoothed row filter of its error.
#[pyclass(name = "FastSequenceFilter", module = "kalmanfield._core")]
pub struct PyFastSequenceFilter {
    inner: FastSequenceFilter,
}

#[pymethods]
impl PyFastSequenceFilter {
    #[new]
    fn new(
        py: Python<'_>,
        model: &PyFieldModel,
        error_model: &PyFieldModel,
        smoothing: f64,
        noise_var: f64,
        height: usize,
        width: usize,
    ) -> PyResult<Self> {
        let inner = py.detach(|| {
            let (m, e) = (&model.inner, &error_model.inner);
            FastSequenceFilter::new(m, e, smoothing, noise_var, height, width)
        })?;
        Ok(Self { inner })
    }

    /// The estimate of frame `z` (flat, NaN = missing). GIL released.
    #[pyo3(signature = (z, threads=None))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        z: PyReadonlyArray1<'py, f64>,
        threads: Option<usize>,
    ) -> PyResult<Frame<'py>> {
        let values = contiguous(&z, "z")?;
        let mut out = vec![0.0; values.len()];
        let inner = &mut self.inner;
        py.detach(|| with_threads(threads, || inner.step(values, &mut out)))??;
        Ok(PyArray1::from_vec(py, out))
    }

    /// The steady row filter's own per-pixel error variance (flat H·W).
    fn error_variance<'py>(&self, py: Python<'py>) -> PyResult<Frame<'py>> {
        let inner = &self.inner;
        Ok(PyArray1::from_vec(
            py,
            py.detach(|| inner.error_variance())?,
        ))
    }

    /// (frames seen, the last n_t estimates).
    fn state<'py>(&self, py: Python<'py>) -> (u64, Frame<'py>) {
        let (frames, history) = self.inner.state();
        (frames, PyArray1::from_slice(py, history))
    }

    /// Restores a state saved by `state`.
    fn set_state(&mut self, frames: u64, history: PyReadonlyArray1<'_, f64>) -> PyResult<()> {
        Ok(self
            .inner
            .set_state(frames, contiguous(&history, "history")?)?)
    }
}
