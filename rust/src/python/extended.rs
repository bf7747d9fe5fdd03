//! Binding of stage 2 of the detector (SPEC §3.4): `kalmanfield._core.GroupTracker` and
//! `kalmanfield._core.extended_assign`.

use super::convert::{contiguous, contiguous_mut};
use crate::extended::{
    assign, background_level, box_smooth, box_smooth_into, GroupConfig, GroupTracker, Measurement,
    Variant,
};
use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

/// Adds the stage-2 items to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyGroupTracker>()?;
    m.add_function(wrap_pyfunction!(extended_smooth, m)?)?;
    m.add_function(wrap_pyfunction!(extended_level, m)?)?;
    m.add_function(wrap_pyfunction!(extended_assign, m)?)
}

/// Box mean of `width` × `width` (edges repeated) of a C-contiguous float64 image; into
/// `out` (C-contiguous float64 of the image's shape, not the image) when given.
#[pyfunction]
#[pyo3(signature = (image, width, out=None))]
fn extended_smooth<'py>(
    py: Python<'py>,
    image: PyReadonlyArray2<'py, f64>,
    width: usize,
    out: Option<Bound<'py, PyArray2<f64>>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    if !(1..=1 << 16).contains(&width) {
        return Err(PyValueError::new_err(format!(
            "width must be 1..=65536, got {width}"
        )));
    }
    let (h, w) = (image.shape()[0], image.shape()[1]);
    if h == 0 || w == 0 {
        return Err(PyValueError::new_err("image must not be empty"));
    }
    let values = contiguous(&image, "image")?;
    let Some(out) = out else {
        let smoothed = py.detach(|| box_smooth(values, h, w, width));
        return PyArray1::from_vec(py, smoothed).reshape([h, w]);
    };
    if out.shape() != [h, w] {
        return Err(PyValueError::new_err(format!(
            "out must have the image's shape ({h}, {w}), got {:?}",
            out.shape()
        )));
    }
    {
        let mut written = out
            .try_readwrite()
            .map_err(|_| PyValueError::new_err("out must be writable and not the image"))?;
        let dst = contiguous_mut(&mut written, "out")?;
        py.detach(|| box_smooth_into(values, h, w, width, dst));
    }
    Ok(out)
}

/// Median of a C-contiguous float64 image without NaN (of every 4th row and column beyond
/// 65536 pixels).
#[pyfunction]
fn extended_level(py: Python<'_>, image: PyReadonlyArray2<'_, f64>) -> PyResult<f64> {
    let (h, w) = (image.shape()[0], image.shape()[1]);
    let values = contiguous(&image, "image")?;
    if values.iter().any(|v| v.is_nan()) {
        return Err(PyValueError::new_err("image must not contain NaN"));
    }
    Ok(py.detach(|| background_level(values, h, w)))
}

/// The greedy assignment of steps 5–6: positions of the chosen variants, best first.
#[pyfunction]
fn extended_assign<'py>(
    py: Python<'py>,
    sequence: PyReadonlyArray1<'py, i64>,
    segment: PyReadonlyArray1<'py, i64>,
    index: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let (sequence, segment, index) = (sequence.as_array(), segment.as_array(), index.as_array());
    if sequence.len() != segment.len() || sequence.len() != index.len() {
        return Err(PyValueError::new_err(
            "sequence, segment and index must have one length",
        ));
    }
    if sequence.iter().chain(segment.iter()).any(|&v| v < 0) {
        return Err(PyValueError::new_err(
            "sequence and segment must be non-negative",
        ));
    }
    if index.iter().any(|v| v.is_nan()) {
        return Err(PyValueError::new_err("index must not contain NaN"));
    }
    let variants: Vec<Variant> = (0..index.len())
        .map(|k| Variant {
            sequence: sequence[k] as usize,
            segment: segment[k] as usize,
            index: index[k],
        })
        .collect();
    let n_seq = variants.iter().map(|v| v.sequence + 1).max().unwrap_or(0);
    let n_seg = variants.iter().map(|v| v.segment + 1).max().unwrap_or(0);
    let chosen = py.detach(|| assign(&variants, n_seq, n_seg));
    Ok(PyArray1::from_vec(
        py,
        chosen.into_iter().map(|k| k as i64).collect(),
    ))
}

/// The Rust stage-2 tracker; the typed front is `kalmanfield.detect_moving_objects`.
#[pyclass(name = "GroupTracker", module = "kalmanfield._core")]
pub struct PyGroupTracker {
    inner: GroupTracker,
}

fn measurements(segments: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<Measurement>> {
    if segments.shape()[1] != 8 {
        return Err(PyValueError::new_err(format!(
            "segments must have 8 columns (x, y, amplitude, area, bbox x0, y0, x1, y1), got {}",
            segments.shape()[1]
        )));
    }
    let a = segments.as_array();
    Ok(a.rows()
        .into_iter()
        .map(|r| Measurement {
            x: r[0],
            y: r[1],
            amplitude: r[2],
            area: r[3],
            bbox: [r[4], r[5], r[6], r[7]],
        })
        .collect())
}

#[pymethods]
impl PyGroupTracker {
    /// A tracker from the configuration fields (see `GroupConfig`).
    #[new]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (*, order, dt, position_std, process_std, amplitude_std, log_area_std,
        feature_drift, confidence, memory, initial_speed_std, gate_margin, min_speed,
        velocity_tolerance, cohesion, max_misses, seed_groups))]
    fn new(
        order: usize,
        dt: f64,
        position_std: f64,
        process_std: f64,
        amplitude_std: f64,
        log_area_std: f64,
        feature_drift: f64,
        confidence: f64,
        memory: usize,
        initial_speed_std: f64,
        gate_margin: f64,
        min_speed: f64,
        velocity_tolerance: f64,
        cohesion: f64,
        max_misses: usize,
        seed_groups: bool,
    ) -> PyResult<Self> {
        let config = GroupConfig {
            order,
            dt,
            position_std,
            process_std,
            amplitude_std,
            log_area_std,
            feature_drift,
            confidence,
            memory,
            initial_speed_std,
            gate_margin,
            min_speed,
            velocity_tolerance,
            cohesion,
            max_misses,
            seed_groups,
        };
        Ok(Self {
            inner: GroupTracker::new(config)?,
        })
    }

    /// One frame's segments, an (m, 8) float64 array; returns a dict of segment_group,
    /// segment_sequence, segment_member (per segment), groups ((G, 7): id, x, y, vx, vy,
    /// members, frames_detected), merged ((k, 2): absorbed, into) and hidden (ids).
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        segments: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let z = measurements(&segments)?;
        let inner = &mut self.inner;
        let a = py.detach(|| inner.step(&z))?;
        let out = PyDict::new(py);
        out.set_item("segment_group", PyArray1::from_vec(py, a.segment_group))?;
        out.set_item(
            "segment_sequence",
            PyArray1::from_vec(py, a.segment_sequence),
        )?;
        out.set_item("segment_member", PyArray1::from_vec(py, a.segment_member))?;
        let rows: Vec<f64> = a
            .groups
            .iter()
            .flat_map(|g| {
                [
                    g.id as f64,
                    g.x,
                    g.y,
                    g.vx,
                    g.vy,
                    g.members as f64,
                    g.frames_detected as f64,
                ]
            })
            .collect();
        let n = a.groups.len();
        let groups: Bound<'py, PyArray2<f64>> = PyArray1::from_vec(py, rows).reshape([n, 7])?;
        out.set_item("groups", groups)?;
        let merged: Vec<i64> = a
            .merged
            .iter()
            .flat_map(|&(b, g)| [b as i64, g as i64])
            .collect();
        let n = a.merged.len();
        let merged: Bound<'py, PyArray2<i64>> = PyArray1::from_vec(py, merged).reshape([n, 2])?;
        out.set_item("merged", merged)?;
        let hidden: Vec<i64> = a.hidden.iter().map(|&g| g as i64).collect();
        out.set_item("hidden", PyArray1::from_vec(py, hidden))?;
        Ok(out)
    }

    /// Starts a group at the given segments ((m, 8) array) with a known velocity (vx, vy)
    /// and the number of observations stage 1 made of the object; returns the group id.
    #[pyo3(signature = (segments, vx, vy, length=1))]
    fn seed(
        &mut self,
        segments: PyReadonlyArray2<'_, f64>,
        vx: f64,
        vy: f64,
        length: usize,
    ) -> PyResult<u64> {
        let z = measurements(&segments)?;
        Ok(self.inner.seed(&z, [vx, vy], length)?)
    }

    /// Frames processed.
    #[getter]
    fn frame(&self) -> u64 {
        self.inner.frame()
    }

    /// Live groups.
    #[getter]
    fn n_groups(&self) -> usize {
        self.inner.n_groups()
    }

    /// Live sequences.
    #[getter]
    fn n_sequences(&self) -> usize {
        self.inner.n_sequences()
    }

    /// The configuration and state as bytes (for pickling).
    fn state_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.inner.to_bytes())
    }

    /// A tracker restored from `state_bytes` (every part checked).
    #[staticmethod]
    fn from_state(state: &[u8]) -> PyResult<Self> {
        Ok(Self {
            inner: GroupTracker::from_bytes(state)?,
        })
    }
}
