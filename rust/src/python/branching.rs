//! Binding of the branching tracker (SPEC §3.1–3.3): `kalmanfield._core.BranchingTracker`.

use crate::tracking::{BranchingTracker, FrameStats, Selection, TrackerConfig, MAX_MOTION_ORDER};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

/// The Rust tracker; the typed front is `kalmanfield.BranchingTracker`.
#[pyclass(name = "BranchingTracker", module = "kalmanfield._core")]
pub struct PyBranchingTracker {
    inner: BranchingTracker,
}

fn array2<'py>(py: Python<'py>, v: Vec<f64>, cols: usize) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let rows = v.len().checked_div(cols).unwrap_or(0);
    PyArray1::from_vec(py, v).reshape([rows, cols])
}

#[pymethods]
impl PyBranchingTracker {
    /// A tracker from a checked `kalmanfield.TrackerConfig` (`TrackerConfig.for_params`).
    #[new]
    fn new(config: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(Self {
            inner: BranchingTracker::new(tracker_config(config)?)?,
        })
    }

    /// Processes one frame of m measurement vectors, an (m, k) float64 array.
    #[pyo3(signature = (measurements, time=None))]
    fn update(
        &mut self,
        py: Python<'_>,
        measurements: PyReadonlyArray2<'_, f64>,
        time: Option<f64>,
    ) -> PyResult<()> {
        let k = self.inner.k();
        if measurements.shape()[1] != k {
            return Err(PyValueError::new_err(format!(
                "measurements must have {k} columns, got {}",
                measurements.shape()[1]
            )));
        }
        let z = measurements.as_slice().map_err(|_| {
            PyValueError::new_err("measurements must be a C-contiguous float64 array")
        })?;
        let inner = &mut self.inner;
        py.detach(|| inner.update(z, time))?;
        Ok(())
    }

    /// The final answer: dict of frame, particle, state (rows × Σ d_q), detection, index, score.
    fn tracks<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let t = py.detach(|| self.inner.track_table());
        let out = PyDict::new(py);
        out.set_item("frame", PyArray1::from_vec(py, t.frame))?;
        out.set_item("particle", PyArray1::from_vec(py, t.particle))?;
        out.set_item("state", array2(py, t.state, self.inner.nodes.n_state)?)?;
        out.set_item("detection", PyArray1::from_vec(py, t.detection))?;
        out.set_item("index", PyArray1::from_vec(py, t.index))?;
        out.set_item("score", PyArray1::from_vec(py, t.score))?;
        Ok(out)
    }

    /// The per-frame online answer: dict of frame, tree, position (rows × k), coasted, score.
    fn online<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let o = &self.inner.online;
        let out = PyDict::new(py);
        out.set_item("frame", PyArray1::from_slice(py, &o.frame))?;
        out.set_item("tree", PyArray1::from_slice(py, &o.tree))?;
        out.set_item("position", array2(py, o.position.clone(), self.inner.k())?)?;
        out.set_item("coasted", PyArray1::from_slice(py, &o.coasted))?;
        out.set_item("score", PyArray1::from_slice(py, &o.llr))?;
        Ok(out)
    }

    /// Per frame: measurements, live sequences before, children, live after, new sequences,
    /// bookkeeping records visited.
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let flat: Vec<i64> = self
            .inner
            .stats
            .iter()
            .flat_map(FrameStats::counters)
            .collect();
        let rows = flat.len() / FrameStats::COUNTERS;
        PyArray1::from_vec(py, flat).reshape([rows, FrameStats::COUNTERS])
    }

    /// Global id of the first measurement of every frame.
    fn frame_offsets<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        PyArray1::from_slice(py, &self.inner.frame_offsets)
    }

    /// Frames processed so far.
    #[getter]
    fn frame(&self) -> i64 {
        self.inner.frame
    }

    /// Time of the last frame (None before the first).
    #[getter]
    fn time(&self) -> Option<f64> {
        self.inner.t
    }

    /// Live sequences.
    #[getter]
    fn n_hypotheses(&self) -> usize {
        self.inner.h.len()
    }

    /// Stored nodes of the track trees.
    #[getter]
    fn n_nodes(&self) -> usize {
        self.inner.nodes.len()
    }

    /// The dynamic state as bytes (for pickling).
    fn state_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.inner.state_bytes())
    }

    /// Restores a state saved by `state_bytes` with the same configuration.
    fn load_state(&mut self, state: &[u8]) -> PyResult<()> {
        Ok(self.inner.load_state(state)?)
    }
}

/// The Rust configuration from the fields of a checked Python `TrackerConfig`.
fn tracker_config(c: &Bound<'_, PyAny>) -> PyResult<TrackerConfig> {
    fn field<'py, T: FromPyObjectOwned<'py>>(c: &Bound<'py, PyAny>, name: &str) -> PyResult<T> {
        c.getattr(name)?.extract::<T>().map_err(|e| {
            let e: PyErr = e.into();
            PyTypeError::new_err(format!("TrackerConfig.{name} is not checked: {e}"))
        })
    }
    let selection: String = field(c, "selection")?;
    Ok(TrackerConfig {
        order: field(c, "order")?,
        process_std: field(c, "process_std")?,
        diffusion_std: field(c, "diffusion_std")?,
        measurement_std: field(c, "measurement_std")?,
        n_spatial: field(c, "n_spatial")?,
        confidence: field(c, "confidence")?,
        memory: field(c, "memory")?,
        max_misses: field(c, "max_misses")?,
        dt: field(c, "dt")?,
        p_detect: field(c, "p_detect")?,
        clutter_density: field(c, "clutter_density")?,
        max_speed: field(c, "max_speed")?,
        n_confirm: field(c, "n_confirm")?,
        confirm_llr: field(c, "confirm_llr")?,
        confirm_window: field(c, "confirm_window")?,
        delete_llr: field(c, "delete_llr")?,
        max_per_tree: field(c, "max_per_tree")?,
        max_hypotheses: field(c, "max_hypotheses")?,
        max_seeds: field(c, "max_seeds")?,
        max_children: field(c, "max_children")?,
        merge_depth: field(c, "merge_depth")?,
        commit_lag: field(c, "commit_lag")?,
        maneuver_std: field(c, "maneuver_std")?,
        maneuver_prob: field(c, "maneuver_prob")?,
        min_hits: field(c, "min_hits")?,
        final_llr: field(c, "final_llr")?,
        max_shared: field(c, "max_shared")?,
        selection: Selection::parse(&selection)?,
        seed: field(c, "seed")?,
    })
}

/// The Rust defaults for `k` parameters (a test checks them against `TrackerConfig`).
#[pyfunction]
fn tracker_defaults(py: Python<'_>, k: usize) -> PyResult<Bound<'_, PyDict>> {
    let c = TrackerConfig::with_defaults(k);
    let out = PyDict::new(py);
    out.set_item("order", c.order)?;
    out.set_item("process_std", c.process_std)?;
    out.set_item("diffusion_std", c.diffusion_std)?;
    out.set_item("measurement_std", c.measurement_std)?;
    out.set_item("n_spatial", c.n_spatial)?;
    out.set_item("confidence", c.confidence)?;
    out.set_item("memory", c.memory)?;
    out.set_item("max_misses", c.max_misses)?;
    out.set_item("dt", c.dt)?;
    out.set_item("p_detect", c.p_detect)?;
    out.set_item("clutter_density", c.clutter_density)?;
    out.set_item("max_speed", c.max_speed)?;
    out.set_item("n_confirm", c.n_confirm)?;
    out.set_item("confirm_llr", c.confirm_llr)?;
    out.set_item("confirm_window", c.confirm_window)?;
    out.set_item("delete_llr", c.delete_llr)?;
    out.set_item("max_per_tree", c.max_per_tree)?;
    out.set_item("max_hypotheses", c.max_hypotheses)?;
    out.set_item("max_seeds", c.max_seeds)?;
    out.set_item("max_children", c.max_children)?;
    out.set_item("merge_depth", c.merge_depth)?;
    out.set_item("commit_lag", c.commit_lag)?;
    out.set_item("maneuver_std", c.maneuver_std)?;
    out.set_item("maneuver_prob", c.maneuver_prob)?;
    out.set_item("min_hits", c.min_hits)?;
    out.set_item("final_llr", c.final_llr)?;
    out.set_item("max_shared", c.max_shared)?;
    out.set_item("selection", c.selection.name())?;
    out.set_item("seed", c.seed)?;
    Ok(out)
}

/// Adds the tracker class to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyBranchingTracker>()?;
    m.add_function(wrap_pyfunction!(tracker_defaults, m)?)?;
    m.add("MAX_MOTION_ORDER", MAX_MOTION_ORDER)?;
    Ok(())
}
