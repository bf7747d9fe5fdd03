//! Binding of the branching tracker (SPEC §3.1–3.3): `kalmanfield._core.BranchingTracker`.

use crate::tracking::{BranchingTracker, Selection, TrackerConfig, MAX_MOTION_ORDER};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
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
    #[new]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (order, process_std, measurement_std, n_spatial, confidence, memory,
        max_misses, dt, p_detect, clutter_density, max_speed, n_confirm, confirm_llr,
        confirm_window, delete_llr, max_per_tree, max_hypotheses, max_seeds, max_children, merge_depth, maneuver_std,
        maneuver_prob, min_hits, final_llr, max_shared, selection, seed))]
    fn new(
        order: Vec<usize>,
        process_std: Vec<f64>,
        measurement_std: Vec<f64>,
        n_spatial: usize,
        confidence: f64,
        memory: usize,
        max_misses: usize,
        dt: f64,
        p_detect: f64,
        clutter_density: Option<f64>,
        max_speed: f64,
        n_confirm: usize,
        confirm_llr: f64,
        confirm_window: usize,
        delete_llr: Option<f64>,
        max_per_tree: usize,
        max_hypotheses: usize,
        max_seeds: usize,
        max_children: Option<usize>,
        merge_depth: usize,
        maneuver_std: Option<Vec<f64>>,
        maneuver_prob: f64,
        min_hits: usize,
        final_llr: f64,
        max_shared: usize,
        selection: &str,
        seed: u64,
    ) -> PyResult<Self> {
        let cfg = TrackerConfig {
            order,
            process_std,
            measurement_std,
            n_spatial,
            confidence,
            memory,
            max_misses,
            dt,
            p_detect,
            clutter_density,
            max_speed,
            n_confirm,
            confirm_llr,
            confirm_window,
            delete_llr,
            max_per_tree,
            max_hypotheses,
            max_seeds,
            max_children,
            merge_depth,
            maneuver_std,
            maneuver_prob,
            min_hits,
            final_llr,
            max_shared,
            selection: Selection::parse(selection)?,
            seed,
        };
        Ok(Self {
            inner: BranchingTracker::new(cfg)?,
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
            .flat_map(|s| {
                [
                    s.measurements,
                    s.live_before,
                    s.children,
                    s.live,
                    s.seeds,
                    s.bookkeeping,
                ]
            })
            .map(|v| v as i64)
            .collect();
        let rows = flat.len() / 6;
        PyArray1::from_vec(py, flat).reshape([rows, 6])
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

/// Adds the tracker class to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyBranchingTracker>()?;
    m.add("MAX_MOTION_ORDER", MAX_MOTION_ORDER)?;
    Ok(())
}
