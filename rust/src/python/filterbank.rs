//! Binding of the filter bank: `kalmanfield._core.TypeIdentifier`, `IMMEstimator` and the
//! model check; the typed fronts are in `kalmanfield.filterbank`.

use super::kalman::{array2, gaussian, linear_gaussian};
use super::threads::with_threads;
use crate::filterbank::{BankModel, ImmEstimator, TypeIdentifier};
use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use numpy::{PyReadonlyArray3, PyUntypedArrayMethods, ToPyArray};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

/// (F, Q, H, R, x0, P0) of one model.
type ModelArrays<'py> = (
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray2<'py, f64>,
);

fn bank_model(arrays: &ModelArrays<'_>) -> PyResult<BankModel> {
    let (f, q, h, r, x0, p0) = arrays;
    Ok(BankModel::new(
        linear_gaussian(f, q, h, r)?,
        gaussian(x0, p0)?,
    )?)
}

fn bank(models: &[ModelArrays<'_>]) -> PyResult<Vec<BankModel>> {
    models.iter().map(bank_model).collect()
}

type CheckedModel<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<f64>>,
);

/// The checked model (F, Q, H, R, x0, P0), covariances symmetrised; ValueError naming what
/// is wrong.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn filterbank_check_model<'py>(
    py: Python<'py>,
    f: PyReadonlyArray2<'py, f64>,
    q: PyReadonlyArray2<'py, f64>,
    h: PyReadonlyArray2<'py, f64>,
    r: PyReadonlyArray2<'py, f64>,
    x0: PyReadonlyArray1<'py, f64>,
    p0: PyReadonlyArray2<'py, f64>,
) -> PyResult<CheckedModel<'py>> {
    let b = bank_model(&(f, q, h, r, x0, p0))?;
    let d = &b.dynamics;
    Ok((
        array2(py, &d.f),
        array2(py, &d.q),
        array2(py, &d.h),
        array2(py, &d.r),
        b.prior.mean.as_slice().to_pyarray(py),
        array2(py, &b.prior.cov),
    ))
}

/// A contiguous (n_traj, n_frames, m) batch as (values, n_traj, n_frames).
fn batch<'a>(z: &'a PyReadonlyArray3<'_, f64>) -> PyResult<(&'a [f64], usize, usize)> {
    let shape = z.shape();
    let values = z
        .as_slice()
        .map_err(|_| PyValueError::new_err("measurements must be C-contiguous"))?;
    Ok((values, shape[0], shape[1]))
}

fn check_columns(z: &PyReadonlyArray3<'_, f64>, m: usize) -> PyResult<()> {
    if z.shape()[2] != m {
        return Err(PyValueError::new_err(format!(
            "the models observe {m} values per frame, the measurements have {}",
            z.shape()[2]
        )));
    }
    Ok(())
}

fn rows<'py, T: numpy::Element>(
    py: Python<'py>,
    v: Vec<T>,
    cols: usize,
) -> PyResult<Bound<'py, PyArray2<T>>> {
    let n = v.len().checked_div(cols).unwrap_or(0);
    PyArray1::from_vec(py, v).reshape([n, cols])
}

/// The Rust bank; the typed front is `kalmanfield.TypeIdentifier`.
#[pyclass(name = "TypeIdentifier", module = "kalmanfield._core")]
pub struct PyTypeIdentifier {
    inner: TypeIdentifier,
}

type RunResult<'py> = (Bound<'py, PyArray2<i64>>, Option<Bound<'py, PyArray3<f64>>>);

#[pymethods]
impl PyTypeIdentifier {
    #[new]
    #[pyo3(signature = (models, priors, alpha=None, beta=None))]
    fn new(
        models: Vec<ModelArrays<'_>>,
        priors: Vec<f64>,
        alpha: Option<f64>,
        beta: Option<f64>,
    ) -> PyResult<Self> {
        let errors = match (alpha, beta) {
            (None, None) => None,
            (Some(a), Some(b)) => Some((a, b)),
            _ => {
                return Err(PyValueError::new_err(
                    "give both alpha and beta (the sequential test) or neither",
                ))
            }
        };
        Ok(Self {
            inner: TypeIdentifier::new(bank(&models)?, &priors, errors)?,
        })
    }

    /// Runs (n_traj, n_frames, m) measurements: (decisions (n_traj, n_frames), accumulated
    /// log-likelihoods (n_traj, n_frames, K) or None).
    #[pyo3(signature = (measurements, log_likelihoods=false, threads=None))]
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        measurements: PyReadonlyArray3<'py, f64>,
        log_likelihoods: bool,
        threads: Option<usize>,
    ) -> PyResult<RunResult<'py>> {
        check_columns(&measurements, self.inner.measurement_dim())?;
        let (z, n_traj, n_frames) = batch(&measurements)?;
        let inner = &mut self.inner;
        let out = py.detach(|| {
            with_threads(threads, || inner.run(z, n_traj, n_frames, log_likelihoods))
        })??;
        let k = self.inner.n_models();
        let ll = out
            .log_likelihoods
            .map(|v| PyArray1::from_vec(py, v).reshape([n_traj, n_frames, k]))
            .transpose()?;
        Ok((rows(py, out.decisions, n_frames)?, ll))
    }

    /// Accumulated log-likelihoods (n_traj, K).
    fn log_likelihoods<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        rows(py, self.inner.log_likelihoods(), self.inner.n_models())
    }

    /// Posterior type probabilities (n_traj, K).
    fn posterior<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        rows(py, self.inner.posterior(), self.inner.n_models())
    }

    /// Current decisions (n_traj,).
    fn decisions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        PyArray1::from_vec(py, self.inner.decisions())
    }

    /// Trajectories followed (0 before the first run).
    #[getter]
    fn n_trajectories(&self) -> usize {
        self.inner.n_trajectories()
    }

    /// Frames processed.
    #[getter]
    fn frame(&self) -> u64 {
        self.inner.frame()
    }

    /// The dynamic state as bytes (for pickling).
    fn state_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.inner.state_bytes())
    }

    /// Restores a state saved by `state_bytes` with the same models.
    fn load_state(&mut self, state: &[u8]) -> PyResult<()> {
        Ok(self.inner.load_state(state)?)
    }
}

/// The Rust IMM; the typed front is `kalmanfield.IMMEstimator`.
#[pyclass(name = "IMMEstimator", module = "kalmanfield._core")]
pub struct PyImmEstimator {
    inner: ImmEstimator,
}

type Combined<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray3<f64>>);

type ImmRun<'py> = (
    Bound<'py, PyArray3<f64>>,
    Bound<'py, PyArray3<f64>>,
    Bound<'py, PyArray2<f64>>,
);

#[pymethods]
impl PyImmEstimator {
    #[new]
    fn new(
        models: Vec<ModelArrays<'_>>,
        transition: PyReadonlyArray2<'_, f64>,
        mu: Vec<f64>,
    ) -> PyResult<Self> {
        let k = models.len();
        if transition.shape() != [k, k] {
            return Err(PyValueError::new_err(format!(
                "transition must be {k}×{k} for {k} models, got {:?}",
                transition.shape()
            )));
        }
        let values: Vec<f64> = transition.as_array().iter().copied().collect();
        Ok(Self {
            inner: ImmEstimator::new(bank(&models)?, &values, &mu)?,
        })
    }

    /// Runs (n_traj, n_frames, m) measurements: combined states (n_traj, n_frames, n), mode
    /// probabilities (n_traj, n_frames, K), log-likelihoods (n_traj, n_frames).
    #[pyo3(signature = (measurements, threads=None))]
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        measurements: PyReadonlyArray3<'py, f64>,
        threads: Option<usize>,
    ) -> PyResult<ImmRun<'py>> {
        check_columns(&measurements, self.inner.measurement_dim())?;
        let (z, n_traj, n_frames) = batch(&measurements)?;
        let inner = &mut self.inner;
        let out = py.detach(|| with_threads(threads, || inner.run(z, n_traj, n_frames)))??;
        let (n, k) = (self.inner.state_dim(), self.inner.n_models());
        Ok((
            PyArray1::from_vec(py, out.state).reshape([n_traj, n_frames, n])?,
            PyArray1::from_vec(py, out.mode_probabilities).reshape([n_traj, n_frames, k])?,
            rows(py, out.log_likelihood, n_frames)?,
        ))
    }

    /// Combined estimates: means (n_traj, n), covariances (n_traj, n, n).
    fn combined<'py>(&self, py: Python<'py>) -> PyResult<Combined<'py>> {
        let (means, covs) = self.inner.combined();
        let n = self.inner.state_dim();
        let n_traj = self.inner.n_trajectories();
        Ok((
            rows(py, means, n)?,
            PyArray1::from_vec(py, covs).reshape([n_traj, n, n])?,
        ))
    }

    /// Mode probabilities (n_traj, K).
    fn mode_probabilities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        rows(py, self.inner.mode_probabilities(), self.inner.n_models())
    }

    /// Trajectories followed (0 before the first run).
    #[getter]
    fn n_trajectories(&self) -> usize {
        self.inner.n_trajectories()
    }

    /// Frames processed.
    #[getter]
    fn frame(&self) -> u64 {
        self.inner.frame()
    }

    /// The dynamic state as bytes (for pickling).
    fn state_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.inner.state_bytes())
    }

    /// Restores a state saved by `state_bytes` with the same models.
    fn load_state(&mut self, state: &[u8]) -> PyResult<()> {
        Ok(self.inner.load_state(state)?)
    }
}

/// Adds the filter-bank classes to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyTypeIdentifier>()?;
    m.add_class::<PyImmEstimator>()?;
    m.add_function(wrap_pyfunction!(filterbank_check_model, m)?)?;
    m.add("MAX_MEASUREMENT", crate::filterbank::MAX_MEASUREMENT)?;
    Ok(())
}
