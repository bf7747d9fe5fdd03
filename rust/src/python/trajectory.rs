//! Binding of the trajectory filters and change detectors (SPEC §4, [K95]):
//! `kalmanfield._core.TrajectoryModel`, `FilterBank`, `DetectorConfig`, `DetectorBank`,
//! `detect_changes`, `cusum_threshold`, `cusum_arl`, `effective_memory`.

use super::convert::contiguous;
use super::threads::with_threads;
use crate::trajectory::{
    self as kernels, Batch, Detections, DetectorConfig, GainRule, Method, MotionModel, Times,
};
use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArrayDyn,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// A motion model and the rule of its gains; wrapped by `kalmanfield.FuzzyFilter` and
/// `kalmanfield.KalmanFilterCV`.
#[pyclass(name = "TrajectoryModel", module = "kalmanfield._core", frozen)]
pub struct PyTrajectoryModel {
    inner: MotionModel,
}

type Pair<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);
type StepPair<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>);

fn matrix(py: Python<'_>, v: Vec<f64>, shape: [usize; 2]) -> PyResult<Bound<'_, PyArray2<f64>>> {
    PyArray1::from_vec(py, v).reshape(shape)
}

/// The batch of (series × samples) arrays, borrowed from the Python arrays.
fn batch<'a>(
    z: &'a PyReadonlyArray2<'_, f64>,
    times: &'a Option<PyReadonlyArrayDyn<'_, f64>>,
    z_vel: &'a Option<PyReadonlyArray2<'_, f64>>,
) -> PyResult<Batch<'a>> {
    let (n_series, n_samples) = (z.shape()[0], z.shape()[1]);
    let z_vel = match z_vel {
        Some(zv) if zv.shape() != z.shape() => {
            return Err(PyValueError::new_err(
                "the velocity samples must have the shape of z",
            ))
        }
        Some(zv) => Some(contiguous(zv, "the velocity samples")?),
        None => None,
    };
    let times = match times {
        None => Times::Regular,
        Some(t) if t.ndim() == 1 => Times::Shared(contiguous(t, "times")?),
        Some(t) if t.ndim() == 2 => Times::PerSeries(contiguous(t, "times")?),
        Some(_) => return Err(PyValueError::new_err("times must be 1-D or 2-D")),
    };
    Ok(Batch {
        z: contiguous(z, "z")?,
        z_vel,
        times,
        n_series,
        n_samples,
    })
}

/// The samples of one streaming step as slices.
fn step_samples<'a>(
    z: &'a PyReadonlyArray1<'_, f64>,
    z_vel: &'a Option<PyReadonlyArray1<'_, f64>>,
) -> PyResult<(&'a [f64], Option<&'a [f64]>)> {
    let zv = z_vel
        .as_ref()
        .map(|a| contiguous(a, "velocity"))
        .transpose()?;
    Ok((contiguous(z, "z")?, zv))
}

#[pymethods]
impl PyTrajectoryModel {
    #[new]
    #[pyo3(signature = (rule, p, q, r, p_vel, q_vel, r_vel=None))]
    fn new(
        rule: &str,
        p: f64,
        q: f64,
        r: f64,
        p_vel: f64,
        q_vel: f64,
        r_vel: Option<f64>,
    ) -> PyResult<Self> {
        let rule = GainRule::parse(rule)?;
        Ok(Self {
            inner: MotionModel::new(rule, p, q, r, p_vel, q_vel, r_vel)?,
        })
    }

    /// (n, 4) gains (xx, xv, vx, vv) of a segment with every sample observed at `times`.
    fn gains<'py>(
        &self,
        py: Python<'py>,
        times: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let t = contiguous(&times, "times")?;
        let g = kernels::gain_sequence(&self.inner, t)?;
        let flat = g.iter().flat_map(|g| [g.xx, g.xv, g.vx, g.vv]).collect();
        matrix(py, flat, [g.len(), 4])
    }

    /// (positions, velocities) of every series of the (series, samples) array `z`; `times`
    /// None (t_n = n), 1-D (shared) or 2-D (per series); NaN = missing sample.
    #[pyo3(signature = (z, times=None, z_vel=None, threads=None))]
    fn filter<'py>(
        &self,
        py: Python<'py>,
        z: PyReadonlyArray2<'py, f64>,
        times: Option<PyReadonlyArrayDyn<'py, f64>>,
        z_vel: Option<PyReadonlyArray2<'py, f64>>,
        threads: Option<usize>,
    ) -> PyResult<Pair<'py>> {
        let b = batch(&z, &times, &z_vel)?;
        let shape = [b.n_series, b.n_samples];
        // numpy's allocator: large arrays get huge pages (fewer page faults than a Vec)
        let (pos, vel) = (
            PyArray2::<f64>::zeros(py, shape, false),
            PyArray2::<f64>::zeros(py, shape, false),
        );
        let (mut pos_rw, mut vel_rw) = (pos.readwrite(), vel.readwrite());
        let (p, v) = (pos_rw.as_slice_mut()?, vel_rw.as_slice_mut()?);
        let model = &self.inner;
        py.detach(|| with_threads(threads, || kernels::filter_batch(model, &b, p, v)))??;
        drop((pos_rw, vel_rw));
        Ok((pos, vel))
    }

    /// Like `filter`, into the given C-contiguous float64 arrays `pos` and `vel` (shaped like
    /// `z`): a stream of batches can reuse them and skip the page faults of fresh outputs.
    #[pyo3(signature = (z, pos, vel, times=None, z_vel=None, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn filter_into<'py>(
        &self,
        py: Python<'py>,
        z: PyReadonlyArray2<'py, f64>,
        pos: &Bound<'py, PyArray2<f64>>,
        vel: &Bound<'py, PyArray2<f64>>,
        times: Option<PyReadonlyArrayDyn<'py, f64>>,
        z_vel: Option<PyReadonlyArray2<'py, f64>>,
        threads: Option<usize>,
    ) -> PyResult<()> {
        let b = batch(&z, &times, &z_vel)?;
        for out in [pos, vel] {
            if out.shape() != z.shape() {
                return Err(PyValueError::new_err(
                    "the outputs must have the shape of z",
                ));
            }
        }
        let (mut pos_rw, mut vel_rw) = (pos.try_readwrite()?, vel.try_readwrite()?);
        let (p, v) = (pos_rw.as_slice_mut()?, vel_rw.as_slice_mut()?);
        let model = &self.inner;
        py.detach(|| with_threads(threads, || kernels::filter_batch(model, &b, p, v)))??;
        Ok(())
    }

    /// The gain rule: "fuzzy" or "kalman".
    #[getter]
    fn rule(&self) -> &'static str {
        match self.inner.rule {
            GainRule::Fuzzy => "fuzzy",
            GainRule::Kalman => "kalman",
        }
    }
}

/// Filters of k series fed sample by sample.
#[pyclass(name = "FilterBank", module = "kalmanfield._core")]
pub struct PyFilterBank {
    inner: kernels::FilterBank,
}

#[pymethods]
impl PyFilterBank {
    #[new]
    fn new(model: &PyTrajectoryModel, series: usize) -> Self {
        Self {
            inner: kernels::FilterBank::new(model.inner, series),
        }
    }

    /// (positions, velocities) after one sample per series at time `t`.
    #[pyo3(signature = (t, z, z_vel=None))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        t: f64,
        z: PyReadonlyArray1<'py, f64>,
        z_vel: Option<PyReadonlyArray1<'py, f64>>,
    ) -> PyResult<StepPair<'py>> {
        let (z, zv) = step_samples(&z, &z_vel)?;
        let out = self.inner.step(t, z, zv)?;
        let (x, v): (Vec<f64>, Vec<f64>) = out.into_iter().unzip();
        Ok((PyArray1::from_vec(py, x), PyArray1::from_vec(py, v)))
    }

    #[getter]
    fn series(&self) -> usize {
        self.inner.series()
    }

    /// Time of the last step (None before the first).
    #[getter]
    fn last_time(&self) -> Option<f64> {
        self.inner.last_time()
    }

    /// The state as a float64 array (for pickling).
    fn state<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.save())
    }

    /// Restores a state saved by `state` with the same model.
    fn load_state(&mut self, state: PyReadonlyArray1<'_, f64>) -> PyResult<()> {
        Ok(self.inner.load(contiguous(&state, "state")?)?)
    }
}

/// A change detector's method, confidence, χ² window and CUSUM drift.
#[pyclass(name = "DetectorConfig", module = "kalmanfield._core", frozen)]
pub struct PyDetectorConfig {
    inner: DetectorConfig,
}

#[pymethods]
impl PyDetectorConfig {
    #[new]
    fn new(method: &str, confidence: f64, window: usize, drift: f64) -> PyResult<Self> {
        Ok(Self {
            inner: DetectorConfig::new(Method::parse(method)?, confidence, window, drift)?,
        })
    }

    /// -ln(1 - μ) (fuzzy), the χ²_W quantile (chi2) or h (cusum).
    #[getter]
    fn threshold(&self) -> f64 {
        self.inner.threshold
    }
}

/// Detectors of k series fed sample by sample.
#[pyclass(name = "DetectorBank", module = "kalmanfield._core")]
pub struct PyDetectorBank {
    inner: kernels::DetectorBank,
}

type StepArrays<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<bool>>,
    Bound<'py, PyArray1<f64>>,
);

#[pymethods]
impl PyDetectorBank {
    #[new]
    fn new(model: &PyTrajectoryModel, config: &PyDetectorConfig, series: usize) -> Self {
        Self {
            inner: kernels::DetectorBank::new(
                kernels::DetectorSettings {
                    model: model.inner,
                    config: config.inner,
                },
                series,
            ),
        }
    }

    /// (positions, velocities, alarms, statistic/threshold) after one sample per series.
    #[pyo3(signature = (t, z, z_vel=None))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        t: f64,
        z: PyReadonlyArray1<'py, f64>,
        z_vel: Option<PyReadonlyArray1<'py, f64>>,
    ) -> PyResult<StepArrays<'py>> {
        let (z, zv) = step_samples(&z, &z_vel)?;
        let out = self.inner.step(t, z, zv)?;
        Ok((
            PyArray1::from_iter(py, out.iter().map(|o| o.x)),
            PyArray1::from_iter(py, out.iter().map(|o| o.v)),
            PyArray1::from_iter(py, out.iter().map(|o| o.alarm)),
            PyArray1::from_iter(py, out.iter().map(|o| o.ratio)),
        ))
    }

    #[getter]
    fn series(&self) -> usize {
        self.inner.series()
    }

    /// Time of the last step (None before the first).
    #[getter]
    fn last_time(&self) -> Option<f64> {
        self.inner.last_time()
    }

    /// The state as a float64 array (for pickling).
    fn state<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.save())
    }

    /// Restores a state saved by `state` with the same model and configuration.
    fn load_state(&mut self, state: PyReadonlyArray1<'_, f64>) -> PyResult<()> {
        Ok(self.inner.load(contiguous(&state, "state")?)?)
    }
}

type DetectArrays<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<bool>>,
    Bound<'py, PyArray2<f64>>,
);

/// Runs a detector over every series of `z` → (positions, velocities, alarms, ratio).
#[pyfunction]
#[pyo3(signature = (model, config, z, times=None, z_vel=None, threads=None))]
fn detect_changes<'py>(
    py: Python<'py>,
    model: &PyTrajectoryModel,
    config: &PyDetectorConfig,
    z: PyReadonlyArray2<'py, f64>,
    times: Option<PyReadonlyArrayDyn<'py, f64>>,
    z_vel: Option<PyReadonlyArray2<'py, f64>>,
    threads: Option<usize>,
) -> PyResult<DetectArrays<'py>> {
    let b = batch(&z, &times, &z_vel)?;
    let shape = [b.n_series, b.n_samples];
    let size = b.z.len();
    let (mut pos, mut vel) = (vec![0.0; size], vec![0.0; size]);
    let (mut alarm, mut ratio) = (vec![false; size], vec![0.0; size]);
    let (m, c) = (&model.inner, &config.inner);
    py.detach(|| {
        with_threads(threads, || {
            let out = Detections {
                pos: &mut pos,
                vel: &mut vel,
                alarm: &mut alarm,
                ratio: &mut ratio,
            };
            kernels::detect_batch(m, c, &b, out)
        })
    })??;
    Ok((
        matrix(py, pos, shape)?,
        matrix(py, vel, shape)?,
        PyArray1::from_vec(py, alarm).reshape(shape)?,
        matrix(py, ratio, shape)?,
    ))
}

/// h of the two-sided CUSUM alarming once per 1/(1 - confidence) samples of N(0, 1) noise.
#[pyfunction]
fn cusum_threshold(confidence: f64, drift: f64) -> PyResult<f64> {
    Ok(kernels::cusum_threshold(confidence, drift)?)
}

/// Mean run length of the one-sided CUSUM (threshold h, drift k) on N(0, 1) increments.
#[pyfunction]
fn cusum_arl(h: f64, drift: f64) -> PyResult<f64> {
    Ok(kernels::cusum_arl(h, drift)?)
}

/// Lags whose weight in the steady estimate of gains (α, β) exceeds `level`.
#[pyfunction]
fn effective_memory(alpha: f64, beta: f64, tau: f64, level: f64) -> PyResult<usize> {
    Ok(kernels::effective_memory(alpha, beta, tau, level)?)
}

/// Adds the trajectory classes and functions to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyTrajectoryModel>()?;
    m.add_class::<PyFilterBank>()?;
    m.add_class::<PyDetectorConfig>()?;
    m.add_class::<PyDetectorBank>()?;
    m.add_function(wrap_pyfunction!(detect_changes, m)?)?;
    m.add_function(wrap_pyfunction!(cusum_threshold, m)?)?;
    m.add_function(wrap_pyfunction!(cusum_arl, m)?)?;
    m.add_function(wrap_pyfunction!(effective_memory, m)?)?;
    m.add("MAX_SPREAD", kernels::model::MAX_SPREAD)?;
    m.add("MAX_SAMPLE", kernels::series::MAX_SAMPLE)?;
    m.add("MAX_WINDOW", kernels::detector::MAX_WINDOW)?;
    Ok(())
}
