//! Binding of the search-recurrent fragment tracker's kernels (SPEC §5):
//! `kalmanfield._core.match_template` and `kalmanfield._core.TemplateTracker`.

use super::convert::{contiguous, pixel_dtype_error, untyped_array, with_dtype};
use crate::image::Pixel;
use crate::kalman::Gaussian;
use crate::template::{
    match_template as match_kernel, Frame, Method, Motion, Step, Template, TemplateTracker,
    TrackerConfig, Window,
};
use nalgebra::DMatrix;
use numpy::{
    Element, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Adds the domain's items to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(match_template, m)?)?;
    m.add_class::<PyTemplateTracker>()
}

/// (x, y, score, surface if asked for) of a search.
type Found<'py> = (f64, f64, f64, Option<Bound<'py, PyArray2<f64>>>);

/// A `Frame` of a C-contiguous 2-D array's pixels.
fn frame_of<'a, T: Pixel + Element>(a: &'a PyReadonlyArray2<'_, T>) -> PyResult<Frame<'a, T>> {
    let (h, w) = (a.shape()[0], a.shape()[1]);
    Ok(Frame::new(contiguous(a, "frame")?, h, w)?)
}

/// A template from a 2-D float64 array.
pub(super) fn template_of(template: &PyReadonlyArray2<'_, f64>) -> PyResult<Template> {
    let (h, w) = (template.shape()[0], template.shape()[1]);
    Ok(Template::new(
        template.as_array().iter().copied().collect(),
        h,
        w,
    )?)
}

/// The search of SPEC §5's correlation-extreme link over `window` = (x0, y0, x1, y1),
/// half-open, default the whole frame: (x, y, score, surface or None), (x, y) the
/// template's top-left.
#[pyfunction]
#[pyo3(signature = (frame, template, window, method, subpixel, return_surface))]
fn match_template<'py>(
    py: Python<'py>,
    frame: &Bound<'py, PyAny>,
    template: PyReadonlyArray2<'py, f64>,
    window: Option<(usize, usize, usize, usize)>,
    method: &str,
    subpixel: bool,
    return_surface: bool,
) -> PyResult<Found<'py>> {
    let template = template_of(&template)?;
    let method = Method::parse(method)?;
    let window = window.map(|(x0, y0, x1, y1)| Window { x0, y0, x1, y1 });
    let options = (method, subpixel, return_surface);
    let untyped = untyped_array(frame, "frame", 2)?;
    with_dtype!(frame, PyReadonlyArray2<u8, u16, f32, f64>, |a| {
        search(py, &frame_of(&a)?, &template, window, options)
    }, else Err(pixel_dtype_error(untyped, "frame")))
}

fn search<'py, T: Pixel>(
    py: Python<'py>,
    frame: &Frame<'_, T>,
    template: &Template,
    window: Option<Window>,
    (method, subpixel, return_surface): (Method, bool, bool),
) -> PyResult<Found<'py>> {
    let (m, s) = py.detach(|| match_kernel(frame, template, window, method, subpixel))?;
    let surface = return_surface
        .then(|| PyArray1::from_slice(py, &s.values).reshape([s.rows, s.cols]))
        .transpose()?;
    Ok((m.x, m.y, m.score, surface))
}

/// The tracker of SPEC §5 over one or more templates; the typed front is
/// `kalmanfield.TemplateTracker`.
#[pyclass(name = "TemplateTracker", module = "kalmanfield._core")]
pub struct PyTemplateTracker {
    inner: TemplateTracker,
}

#[pymethods]
impl PyTemplateTracker {
    #[new]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (templates, positions, model, process_std, measurement_std, dt, gate,
        initial_std, collapse, reacquire_z, update_template, subpixel))]
    fn new(
        templates: Vec<PyReadonlyArray2<'_, f64>>,
        positions: Vec<(f64, f64)>,
        model: &str,
        process_std: f64,
        measurement_std: f64,
        dt: f64,
        gate: f64,
        initial_std: Vec<f64>,
        collapse: f64,
        reacquire_z: Option<f64>,
        update_template: Option<f64>,
        subpixel: bool,
    ) -> PyResult<Self> {
        let config = TrackerConfig {
            motion: Motion::parse(model)?,
            process_std,
            measurement_std,
            dt,
            gate,
            initial_std,
            collapse,
            reacquire_z,
            update_template,
            subpixel,
        };
        let templates = templates
            .iter()
            .map(template_of)
            .collect::<PyResult<Vec<_>>>()?;
        let positions: Vec<[f64; 2]> = positions.iter().map(|&(x, y)| [x, y]).collect();
        Ok(Self {
            inner: TemplateTracker::new(config, templates, &positions)?,
        })
    }

    /// One frame: a dict of per-target arrays (state, cov, score, measurement, window,
    /// collapsed, reacquired, frame_score).
    fn update<'py>(
        &mut self,
        py: Python<'py>,
        frame: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let untyped = untyped_array(frame, "frame", 2)?;
        let inner = &mut self.inner;
        with_dtype!(frame, PyReadonlyArray2<u8, u16, f32, f64>, |a| {
            let f = frame_of(&a)?;
            let steps = py.detach(|| inner.update(&f))?;
            steps_dict(py, &steps)
        }, else Err(pixel_dtype_error(untyped, "frame")))
    }

    /// The dynamic state as numbers (for pickling).
    fn state_values<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.state_values())
    }

    /// Restores numbers saved by `state_values` with the same settings and templates' shapes.
    fn load_state(&mut self, values: PyReadonlyArray1<'_, f64>) -> PyResult<()> {
        let values = values
            .as_slice()
            .map_err(|_| PyValueError::new_err("the state must be a contiguous array"))?;
        Ok(self.inner.load_state(values)?)
    }

    /// The current templates (float64; changed by template updates).
    fn templates<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
        self.inner
            .targets()
            .iter()
            .map(|t| {
                PyArray1::from_slice(py, t.template.pixels())
                    .reshape([t.template.height(), t.template.width()])
            })
            .collect()
    }

    /// The state means (targets × n) and covariances (targets × n × n).
    fn states<'py>(&self, py: Python<'py>) -> PyResult<StateArrays<'py>> {
        let states: Vec<&Gaussian> = self.inner.targets().iter().map(|t| &t.state).collect();
        state_arrays(py, &states)
    }

    /// The linear link's (F, Q, H, R).
    fn model_matrices<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
        let m = self.inner.model();
        [&m.f, &m.q, &m.h, &m.r]
            .into_iter()
            .map(|a| matrix_array(py, a))
            .collect()
    }

    /// Frames processed.
    #[getter]
    fn frames(&self) -> u64 {
        self.inner.frames()
    }

    /// Number of templates tracked.
    #[getter]
    fn n_targets(&self) -> usize {
        self.inner.targets().len()
    }
}

/// (means: targets × n, covariances: targets × n × n).
type StateArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray3<f64>>);

fn state_arrays<'py>(py: Python<'py>, states: &[&Gaussian]) -> PyResult<StateArrays<'py>> {
    let n = states.first().map_or(0, |s| s.mean.len());
    let means: Vec<f64> = states.iter().flat_map(|s| s.mean.iter().copied()).collect();
    let covs: Vec<f64> = states
        .iter()
        .flat_map(|s| s.cov.transpose().iter().copied().collect::<Vec<_>>())
        .collect();
    Ok((
        PyArray1::from_vec(py, means).reshape([states.len(), n])?,
        PyArray1::from_vec(py, covs).reshape([states.len(), n, n])?,
    ))
}

fn matrix_array<'py>(py: Python<'py>, a: &DMatrix<f64>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    PyArray1::from_vec(py, a.transpose().iter().copied().collect()).reshape([a.nrows(), a.ncols()])
}

/// The steps of one frame as a dict of per-target arrays.
fn steps_dict<'py>(py: Python<'py>, steps: &[Step]) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let states: Vec<&Gaussian> = steps.iter().map(|s| &s.state).collect();
    let (means, covs) = state_arrays(py, &states)?;
    out.set_item("state", means)?;
    out.set_item("cov", covs)?;
    let floats = |f: fn(&Step) -> f64| PyArray1::from_vec(py, steps.iter().map(f).collect());
    out.set_item("score", floats(|s| s.score))?;
    out.set_item("frame_score", floats(|s| s.frame_score))?;
    out.set_item(
        "x_measured",
        floats(|s| s.measurement.map_or(f64::NAN, |m| m[0])),
    )?;
    out.set_item(
        "y_measured",
        floats(|s| s.measurement.map_or(f64::NAN, |m| m[1])),
    )?;
    let windows: Vec<i64> = steps
        .iter()
        .flat_map(|s| match s.window {
            Some(w) => [w.x0, w.y0, w.x1, w.y1].map(|v| v as i64),
            None => [-1; 4],
        })
        .collect();
    out.set_item(
        "window",
        PyArray1::from_vec(py, windows).reshape([steps.len(), 4])?,
    )?;
    let flags = |f: fn(&Step) -> bool| PyArray1::from_vec(py, steps.iter().map(f).collect());
    out.set_item("collapsed", flags(|s| s.collapsed))?;
    out.set_item("reacquired", flags(|s| s.reacquired))?;
    Ok(out)
}
