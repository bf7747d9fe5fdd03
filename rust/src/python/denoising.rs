//! Binding of denoising: the box moments, the Haar-MAD noise variance and the adaptive
//! denoiser.

use super::convert::{contiguous, output, stack_dims};
use super::field::PyFieldModel;
use super::rowfilter::row_models_of;
use super::threads::with_threads;
use crate::denoising::{
    adaptive_denoise, haar_mad_noise_var, local_moments, AdaptiveSettings, NOMINAL_SAMPLE,
    SIGNAL_FLOOR,
};
use numpy::{PyReadonlyArrayDyn, PyReadwriteArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// Adds the denoising functions and constants to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(local_moments_into, m)?)?;
    m.add_function(wrap_pyfunction!(haar_noise_var, m)?)?;
    m.add_function(wrap_pyfunction!(adaptive_denoise_into, m)?)?;
    m.add("SIGNAL_FLOOR", SIGNAL_FLOOR)?;
    m.add("NOMINAL_SAMPLE", NOMINAL_SAMPLE)
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
    py.detach(|| local_moments(values, frames, height, width, radius, mean, var))?;
    Ok(())
}

/// σ̂_θ² of white noise in an image (H, W) or a stack (F, H, W), pooled over the frames:
/// the Haar-MAD estimate of `noise_level.rs`.
#[pyfunction]
fn haar_noise_var(py: Python<'_>, z: PyReadonlyArrayDyn<'_, f64>) -> PyResult<f64> {
    let (frames, height, width) = stack_dims(z.shape())?;
    let values = contiguous(&z, "z")?;
    Ok(py.detach(|| haar_mad_noise_var(values, frames, height, width))?)
}

/// The adaptive denoiser (`kalmanfield.denoise`) of an image (H, W) or a stack (F, H, W) into
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
