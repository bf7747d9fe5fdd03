//! The thin binding layer: `kalmanfield._core`. Validation of Python-side types happens here;
//! every numerical check is done by the plain-Rust kernels, whose errors become ValueError.

use crate::adaptive_denoise::{adaptive_denoise, AdaptiveSettings};
use crate::anisotropy::anisotropy;
use crate::cascade::{sample_into, stream_frame_into};
use crate::chi_squared::{chi_squared_quantile, chi_squared_sf};
use crate::difference_gram::difference_gram as gram_kernel;
use crate::error::FieldError;
use crate::field_model::FieldModel;
use crate::lag_products::lag_products as lag_kernel;
use crate::noise::{Noise, Real};
use crate::product_field::product_field_into;
use crate::row_modes::ModeSet;
use crate::scalar_row_filter::{RowModels, ScalarRowFilter};
use crate::stationary_start::AxisRecursion;
use crate::vector_row_filter::VectorRowFilter;
use crate::whitening::whiten_axis;
use crate::wiener_bound::{wiener_bound as bound_kernel, wiener_error_map};
use numpy::ndarray::Dimension;
use numpy::{
    Element, PyArray1, PyArray2, PyArrayDyn, PyArrayMethods, PyReadonlyArray, PyReadonlyArray1,
    PyReadonlyArray2, PyReadonlyArrayDyn, PyReadwriteArrayDyn, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

mod branching;
mod kalman;
mod segment;
mod template;

pyo3::create_exception!(
    _core,
    NonFiniteError,
    PyValueError,
    "A NaN or infinite value where the kernel needs a finite one (FieldError::NonFinite)."
);

impl From<FieldError> for PyErr {
    fn from(e: FieldError) -> PyErr {
        match e {
            FieldError::NonFinite(_) => NonFiniteError::new_err(e.to_string()),
            _ => PyValueError::new_err(e.to_string()),
        }
    }
}

/// Runs `f` on `threads` threads (None: rayon's global pool, all cores).
fn with_threads<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> PyResult<R> {
    match threads {
        None => Ok(f()),
        Some(0) => Err(PyValueError::new_err(
            "threads must be a positive integer or None",
        )),
        // (kalmanfield._validation.MAX_THREADS: thousands of threads only queue)
        Some(k) if k > 1024 => Err(PyValueError::new_err(format!(
            "threads must lie in 1..=1024 (or None: all cores), got {k}"
        ))),
        // a fresh pool per call: a pool thread that built a plan (faer's AVX-512 kernels) ran
        // the later filters 1.5–2× slower when pools were kept (measured)
        Some(k) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(k)
                .build()
                .map_err(|e| PyValueError::new_err(format!("cannot start {k} threads: {e}")))?;
            Ok(pool.install(f))
        }
    }
}

fn noise_slice<'a>(noise: &'a Option<PyReadonlyArrayDyn<'_, f64>>) -> PyResult<Option<&'a [f64]>> {
    noise.as_ref().map(|n| contiguous(n, "noise")).transpose()
}

fn seeded_or_given(seed: u64, given: Option<&[f64]>) -> Noise<'_> {
    match given {
        Some(values) => Noise::Given {
            values,
            first_line: 0,
        },
        None => Noise::Seeded(seed),
    }
}

/// The separable multiple-root AR field model (SPEC §1.2); wrapped by `kalmanfield.ARFieldModel`.
#[pyclass(name = "FieldModel", module = "kalmanfield._core", frozen)]
pub struct PyFieldModel {
    inner: FieldModel,
}

/// Calls `$body` with `$out` bound to the writable slice of a float64 or float32 array.
macro_rules! with_float_array {
    ($array:expr, |$out:ident, $shape:ident| $body:expr) => {{
        if let Ok(mut a) = $array.extract::<PyReadwriteArrayDyn<f64>>() {
            let $shape = a.shape().to_vec();
            let $out = a
                .as_slice_mut()
                .map_err(|_| PyValueError::new_err("output must be C-contiguous"))?;
            $body
        } else if let Ok(mut a) = $array.extract::<PyReadwriteArrayDyn<f32>>() {
            let $shape = a.shape().to_vec();
            let $out = a
                .as_slice_mut()
                .map_err(|_| PyValueError::new_err("output must be C-contiguous"))?;
            $body
        } else {
            Err(PyTypeError::new_err(
                "output must be a writable float64 or float32 numpy array",
            ))
        }
    }};
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
    noise: Noise,
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
        with_float_array!(out, |slice, shape| {
            py.detach(|| {
                with_threads(threads, || {
                    sample_into(model, slice, &shape, seeded_or_given(seed, given))
                })
            })??;
            Ok(())
        })
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
        with_float_array!(out, |slice, shape| stream_step(
            py,
            model,
            slice,
            &shape,
            &history,
            t,
            seeded_or_given(seed, given),
            threads
        ))
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
        with_float_array!(out, |slice, shape| {
            py.detach(|| {
                with_threads(threads, || {
                    product_field_into(model, slice, &shape, seed, slices.as_deref())
                })
            })??;
            Ok(())
        })
    }
}

fn contiguous<'a, T: Element, D: Dimension>(
    a: &'a PyReadonlyArray<'_, T, D>,
    name: &str,
) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name} must be C-contiguous")))
}

/// Difference Gram G_ab = Σ DᵃxDᵇx along `axis` (SPEC §1.6); NaN marks missing values.
#[pyfunction]
#[pyo3(signature = (data, axis, max_order, threads=None))]
fn difference_gram<'py>(
    py: Python<'py>,
    data: PyReadonlyArrayDyn<'py, f64>,
    axis: usize,
    max_order: usize,
    threads: Option<usize>,
) -> PyResult<(Bound<'py, PyArray2<f64>>, u64)> {
    let shape = data.shape().to_vec();
    let values = contiguous(&data, "data")?;
    let gram =
        py.detach(|| with_threads(threads, || gram_kernel(values, &shape, axis, max_order)))??;
    let width = max_order + 1;
    let matrix = PyArray1::from_vec(py, gram.symmetric()).reshape([width, width])?;
    Ok((matrix, gram.count))
}

/// (S_h, N_h) as numpy arrays.
type LagArrays<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<u64>>);

/// Lagged products S_h = Σ x_i x_{i+h} and pair counts along `axis`, h = 0..=max_lag.
#[pyfunction]
#[pyo3(signature = (data, axis, max_lag, threads=None))]
fn lag_products<'py>(
    py: Python<'py>,
    data: PyReadonlyArrayDyn<'py, f64>,
    axis: usize,
    max_lag: usize,
    threads: Option<usize>,
) -> PyResult<LagArrays<'py>> {
    let shape = data.shape().to_vec();
    let values = contiguous(&data, "data")?;
    let lags =
        py.detach(|| with_threads(threads, || lag_kernel(values, &shape, axis, max_lag)))??;
    Ok((
        PyArray1::from_vec(py, lags.sums),
        PyArray1::from_vec(py, lags.counts),
    ))
}

/// Applies (1 - ρ z⁻¹)ⁿ along `axis` in place (SPEC §1.6 residuals).
#[pyfunction]
fn whiten_axis_into(
    py: Python<'_>,
    mut data: PyReadwriteArrayDyn<'_, f64>,
    axis: usize,
    rho: f64,
    order: usize,
) -> PyResult<()> {
    let shape = data.shape().to_vec();
    let values = data
        .as_slice_mut()
        .map_err(|_| PyValueError::new_err("data must be C-contiguous"))?;
    py.detach(|| whiten_axis(values, &shape, axis, rho, order))?;
    Ok(())
}

/// P(χ²_dof > x).
#[pyfunction]
fn chi2_sf(x: f64, dof: f64) -> PyResult<f64> {
    Ok(chi_squared_sf(x, dof)?)
}

/// The χ² quantile of probability p.
#[pyfunction]
fn chi2_quantile(p: f64, dof: f64) -> PyResult<f64> {
    Ok(chi_squared_quantile(p, dof)?)
}

/// Runs a row filter on an image (height × width) or a stack (frames × height × width) into
/// (frames, height, width) of an image (H, W) or a stack (F, H, W).
fn stack_dims(shape: &[usize]) -> PyResult<(usize, usize, usize)> {
    match shape {
        [h, w] => Ok((1, *h, *w)),
        [f, h, w] => Ok((*f, *h, *w)),
        _ => Err(PyValueError::new_err("z must be 2-D or 3-D")),
    }
}

/// The values of an output array `name` of `shape`, checked shape and C-contiguous.
fn output<'a>(
    out: &'a mut PyReadwriteArrayDyn<'_, f64>,
    shape: &[usize],
    name: &str,
) -> PyResult<&'a mut [f64]> {
    if out.shape() != shape {
        return Err(PyValueError::new_err(format!(
            "{name} must have the shape of z"
        )));
    }
    out.as_slice_mut()
        .map_err(|_| PyValueError::new_err(format!("{name} must be C-contiguous")))
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

/// Box mean and variance (window 2·radius + 1, cut at the borders) of an image (H, W) or a
/// stack (F, H, W), into `mean` and `var` (same shape).
#[pyfunction]
fn local_moments_into(
    py: Python<'_>,
    z: PyReadonlyArrayDyn<'_, f64>,
    radius: usize,
    mut mean: PyReadwriteArrayDyn<'_, f64>,
    mut var: PyReadwriteArrayDyn<'_, f64>,
) -> PyResult<()> {
    let shape = z.shape().to_vec();
    let (frames, height, width) = stack_dims(&shape)?;
    let mean = output(&mut mean, &shape, "mean")?;
    let var = output(&mut var, &shape, "var")?;
    let values = contiguous(&z, "z")?;
    py.detach(|| {
        crate::local_moments::local_moments(values, frames, height, width, radius, mean, var)
    })?;
    Ok(())
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
    let table = crate::axis_model::correlation_table(r, order, l)?;
    PyArray1::from_vec(py, table).reshape([r.len(), l.len()])
}

/// σ̂_θ² of white noise in an image (H, W) or a stack (F, H, W), pooled over the frames:
/// the Haar-MAD estimate of `noise_level.rs`.
#[pyfunction]
fn haar_noise_var(py: Python<'_>, z: PyReadonlyArrayDyn<'_, f64>) -> PyResult<f64> {
    let (frames, height, width) = stack_dims(z.shape())?;
    let values = contiguous(&z, "z")?;
    Ok(py.detach(|| crate::noise_level::haar_mad_noise_var(values, frames, height, width))?)
}

/// The default order m of the quasi-optimal filter's row model for multiplicities (n_y, n_x)
/// (`scalar_row_filter::default_ar_order`).
#[pyfunction]
fn default_ar_order(n_y: usize, n_x: usize) -> usize {
    crate::scalar_row_filter::default_ar_order(n_y, n_x)
}

/// The row model of order n_x, 2 ≤ m ≤ 8, that `denoise` uses
/// (`scalar_row_filter::model_ar_order`).
#[pyfunction]
fn model_ar_order(n_x: usize) -> usize {
    crate::scalar_row_filter::model_ar_order(n_x)
}

/// `RowModels` by name.
fn row_models_of(name: &str) -> PyResult<RowModels> {
    match name {
        "propagated" => Ok(RowModels::Propagated),
        "nominal" => Ok(RowModels::Nominal),
        "implied" => Ok(RowModels::Implied),
        _ => Err(PyValueError::new_err(format!(
            "row_models must be 'propagated', 'nominal' or 'implied', got {name:?}"
        ))),
    }
}

/// The adaptive denoiser (README "denoise") of an image (H, W) or a stack (F, H, W) into
/// `out` (same shape), frames in parallel.
#[pyfunction]
#[pyo3(signature = (z, noise_var, model, radius, smooth, out, threads=None, row_models="nominal"))]
#[allow(clippy::too_many_arguments)] // the Python signature
fn adaptive_denoise_into(
    py: Python<'_>,
    z: PyReadonlyArrayDyn<'_, f64>,
    noise_var: f64,
    model: &PyFieldModel,
    radius: usize,
    smooth: bool,
    mut out: PyReadwriteArrayDyn<'_, f64>,
    threads: Option<usize>,
    row_models: &str,
) -> PyResult<()> {
    let row_models = row_models_of(row_models)?;
    let shape = z.shape().to_vec();
    let (frames, height, width) = stack_dims(&shape)?;
    let out = output(&mut out, &shape, "out")?;
    let values = contiguous(&z, "z")?;
    let settings = AdaptiveSettings {
        noise_var,
        model: &model.inner,
        radius,
        smooth,
        row_models,
    };
    // one frame has no parallel part: it runs on this thread, whose scratch buffers persist
    // between calls (a fresh pool's thread would fault them in anew: `scratch.rs`)
    let threads = match threads {
        Some(k) if k > 0 && frames == 1 => None,
        t => t,
    };
    py.detach(|| {
        with_threads(threads, || {
            adaptive_denoise(values, frames, height, width, &settings, out)
        })
    })??;
    Ok(())
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

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyFieldModel>()?;
    m.add("NonFiniteError", m.py().get_type::<NonFiniteError>())?;
    m.add_class::<PyVectorRowFilter>()?;
    m.add_class::<PyScalarRowFilter>()?;
    branching::register(m)?;
    kalman::register(m)?;
    segment::register(m)?;
    template::register(m)?;
    m.add_function(wrap_pyfunction!(wiener_bound, m)?)?;
    m.add_function(wrap_pyfunction!(wiener_map, m)?)?;
    m.add_function(wrap_pyfunction!(local_moments_into, m)?)?;
    m.add_function(wrap_pyfunction!(haar_noise_var, m)?)?;
    m.add_function(wrap_pyfunction!(default_ar_order, m)?)?;
    m.add_function(wrap_pyfunction!(model_ar_order, m)?)?;
    m.add_function(wrap_pyfunction!(axis_correlation_table, m)?)?;
    m.add_function(wrap_pyfunction!(adaptive_denoise_into, m)?)?;
    m.add("SIGNAL_FLOOR", crate::adaptive_denoise::SIGNAL_FLOOR)?;
    m.add("NOMINAL_SAMPLE", crate::adaptive_denoise::NOMINAL_SAMPLE)?;
    m.add_function(wrap_pyfunction!(difference_gram, m)?)?;
    m.add_function(wrap_pyfunction!(lag_products, m)?)?;
    m.add_function(wrap_pyfunction!(whiten_axis_into, m)?)?;
    m.add_function(wrap_pyfunction!(chi2_sf, m)?)?;
    m.add_function(wrap_pyfunction!(chi2_quantile, m)?)?;
    m.add("MAX_ORDER", crate::axis_model::MAX_ORDER)?;
    m.add(
        "MAX_DIFFERENCE_ORDER",
        crate::difference_gram::MAX_DIFFERENCE_ORDER,
    )?;
    Ok(())
}
