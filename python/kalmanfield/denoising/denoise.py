"""One-call denoising of images by the row Kalman filters (SPEC §2), with the model and the
noise level estimated from the noisy image itself, optionally locally adapted."""

from __future__ import annotations

import warnings
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from .. import _core
from .._validation import (
    images,
    peak_magnitude,
    positive_float,
    power_of_two_exponent,
    real_array,
    real_number,
    thread_count,
)
from ..field.model import ARFieldModel
from ..identification.from_noisy import model_from_noisy
from ..rowfilter.base import row_model
from ..rowfilter.scalar import ScalarRowFilter, check_row_models
from ..rowfilter.vector import VectorRowFilter

#: Model of the normalised detail field of the adaptive denoiser (see :func:`denoise`),
#: chosen on scikit-image training images other than the benchmark's (README).
DETAIL_MODEL = ARFieldModel([0.7, 0.7], [1, 1])


def local_moments(image: npt.ArrayLike, window: int) -> tuple[np.ndarray, np.ndarray]:
    """(mean, variance) of every pixel's window × window box (odd `window`; the box is cut
    at the borders, so any window ≥ 2 max(H, W) + 1 gives the whole frame's moments), for
    an image (H, W) or a stack (F, H, W); Rust, O(1) per pixel.
    NaN pixels are missing: the moments are those of the box's other pixels, NaN where the
    box holds none. Images whose largest |pixel| lies outside [2⁻⁴⁰⁰, 2⁴⁰⁰] are scaled by a
    power of two (exact) for the sums of squares, so the moments of data of any magnitude
    are those of the scaled data, scaled back (variances below float64's normal range are
    rounded to its subnormal numbers); ValueError ("rescale") when a variance overflows
    float64 (|pixel deviations| ≳ 1e154)."""
    z = images(image, missing=True)
    radius = _box_radius(window, z)
    exponent = _moments_scale(z)
    if exponent:
        z = np.ldexp(z, -exponent)
    mean, var = np.empty_like(z), np.empty_like(z)
    _core.local_moments_into(z, radius, mean, var)
    if exponent:
        np.ldexp(mean, exponent, out=mean)
        with np.errstate(over="ignore"):
            np.ldexp(var, 2 * exponent, out=var)
        if exponent > 0 and np.isinf(var).any():
            raise ValueError(
                f"the local variances overflow float64 (pixels of magnitude ~2^{exponent}): "
                "rescale the image"
            )
    return mean, var


#: pixels up to this magnitude (and down to its reciprocal) need no scaling for the box
#: sums of squares: (2 · 2^400)² times any pixel count stays far inside float64, and the
#: squared deviations of pixels ≥ 2^-400 (at least their ulp, ~2^-452) stay normal
_UNSCALED = 2.0**400


def _moments_scale(z: np.ndarray) -> int:
    """0, or the power of two to divide `z` by for :func:`local_moments`
    (:func:`power_of_two_exponent` of its largest finite |pixel|)."""
    if z.size == 0:
        return 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN image: no scaling
        peak = max(float(np.fmax.reduce(z, axis=None)), -float(np.fmin.reduce(z, axis=None)))
    if not (peak > 0 and (peak > _UNSCALED or peak < 1.0 / _UNSCALED)):
        return 0
    return power_of_two_exponent(np.array([peak])) or 0


def _box_radius(window: object, z: np.ndarray) -> int:
    """The half-width of an odd `window`, at most max(H, W) (a box that wide covers the
    frame from every pixel: a wider one has the same moments)."""
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)):
        raise TypeError(f"window must be an odd integer, got {window!r}")
    if window < 1 or window % 2 == 0:
        raise ValueError(f"window must be a positive odd integer, got {window}")
    return min(int(window) // 2, max(z.shape[-2:]))


def estimate_noise_var(image: npt.ArrayLike) -> float:
    """σ_θ² of white noise in an image (or a stack, axes (…, H, W)): Donoho's robust estimate
    from the finest diagonal Haar detail d = (z₀₀ − z₀₁ − z₁₀ + z₁₁)/2 of disjoint 2×2 blocks,
    σ̂ = median|d| / Φ⁻¹(3/4) (≈ 0.67449, the normal's quartile; the detail of a smooth image
    is ~0, of white noise N(0, σ²)), pooled over the frames of a stack. Blocks with a NaN
    (missing) or infinite pixel are left out. ValueError when σ̂² overflows float64
    (σ̂ ≳ 1e154).
    Rust kernel (``rust/src/noise_level.rs``; NumPy twin ``reference.noise_level``)."""
    z = real_array(image, "image")
    if z.ndim < 2 or z.shape[-1] < 2 or z.shape[-2] < 2 or z.size == 0:
        raise ValueError(f"need an image of at least 2×2 pixels, got shape {z.shape}")
    stack = np.ascontiguousarray(z.reshape(-1, *z.shape[-2:]))
    variance = _core.haar_noise_var(stack)
    if not np.isfinite(variance):
        raise ValueError("the estimated noise variance overflows float64: rescale the image")
    return variance


def denoise(
    image: npt.ArrayLike,
    noise_var: float | None = None,
    model: ARFieldModel | None = None,
    method: Literal["scalar", "vector"] = "scalar",
    smooth: bool = True,
    *,
    adaptive: bool | None = None,
    window: int = 9,
    mean: float | None = None,
    threads: int | None = None,
    row_models: Literal["nominal", "propagated", "implied"] = "nominal",
) -> np.ndarray:
    """Denoise an image (H, W) or a stack (F, H, W) of z = x + θ (SPEC §2).

    noise_var : σ_θ²; None → :func:`estimate_noise_var` (robust Haar-MAD estimate).
    adaptive : locally adapted mean and variance (default with method="scalar"). The image is
        modelled as x = μ(s) + σ(s) ξ(s), with μ and σ² + σ_θ² the mean and variance of the
        `window`² box around each pixel (:func:`local_moments`) and ξ a unit-variance AR
        field (`model`, default :data:`DETAIL_MODEL`). The normalised residual
        (z − μ)/σ = ξ + θ/σ is filtered by :class:`ScalarRowFilter` (Toeplitz modes,
        ar_order = max(n_x, 2) (at most 8): every row is weighted, so refitted at O(W m³), and
        the detail model's short reach gains nothing from the longer default of n_y = 1) with the
        per-pixel noise variance σ_θ²/σ(s)²: little smoothing on edges and texture, strong in
        flat areas; x̂ = μ + σ ξ̂. With ρ = 0 this is the adaptive (Lee) Wiener filter of
        ``scipy.signal.wiener``; the AR model of ξ adds the row-Kalman smoothing.
        σ² is floored at 0.01 σ_θ². The filter's nominal noise variance (which only sets its
        prediction-error model) is 1/median(σ²/σ_θ²) over a regular sample of ≤ 2¹⁴ pixels.
        One Rust kernel (``rust/src/adaptive_denoise.rs``; NumPy twin
        ``reference.adaptive_denoise``); the frames of a stack run in parallel.
    row_models : the adaptive filter's row models for its per-pixel weights (see
        :class:`ScalarRowFilter`). "nominal" (default): the plan's, fitted for the nominal
        noise ratio, the fast path. "propagated": refitted row by row to the weighted
        systems, +0.1–0.3 dB on camera, astronaut, coins and moon (σ = 0.1) at 3.5–5× the
        time (README); "implied": propagated from the first predicted row on, not from the
        first row whose weights depart from the nominal ones. The stationary path
        (adaptive=False) always uses :class:`ScalarRowFilter`'s default, "auto"
        ("propagated", or "implied" near a unit root at high SNR).
    adaptive=False : one stationary model for the whole image. `model`: the field model of x;
        None → :func:`model_from_noisy` (noise-robust fit of the autocovariance at lags ≥ 1),
        filtered with the Toeplitz mode set (its plan is cheap, and a model refitted per
        image has no plan to reuse; on camera, coins and moon, σ = 0.1, the PSNR moves by
        at most 0.02 dB against the default spliced ends and the filter is built 4–10×
        faster); a given model gets the default mode set. The scalar filter takes
        ar_order = max(n_x, 2) (at most 8), not its longer default for n_y = 1: the identified
        models are (1, 1) at ρ ≈ 0.93–0.99 on natural images, and a row model that follows them
        more faithfully lands nearer the vector filter's lower PSNR (σ = 0.1, m = 2 / 4 /
        8: camera 25.50 / 25.09 / 24.96 dB, moon 34.42 / 34.31 / 34.23; the model, not the
        filter, limits it) at 1.6–3× the time.
    method : "scalar" (:class:`ScalarRowFilter`, O(W) per row) or "vector"
        (:class:`VectorRowFilter`, optimal, O(W²) per row; not adaptive).
    smooth : run the backward pass over the rows (default).
    mean : the field mean of the stationary model (None: the image mean); checked in both
        modes, used by the stationary one (the adaptive mode follows the local means).
    threads : threads for the frames of a stack (None: all cores). In the adaptive mode a
        single image runs on the calling thread (GIL released) whatever `threads` says: its
        kernel has no parallel part, and the thread keeps its scratch buffers between calls.
    Returns float64 of the image's shape (an empty stack, (0, H, W), gives an empty one).
    uint8/uint16/float inputs are accepted. Images whose largest |pixel| lies outside
    [2⁻⁴⁰⁰, 2⁴⁰⁰] are denoised scaled by a power of two (exact; noise_var, mean and a
    stationary model's σ alike) and scaled back, so any magnitude float64 holds works.
    NaN pixels are missing observations (method="scalar"): left out of the noise estimate,
    the model fit and the box moments, given weight 0 by the filter and filled by its
    estimate from the neighbouring pixels (a box without an observed pixel is widened,
    radius 2r + 1, …, until it holds one). method="vector" needs every pixel.
    A frame of a stack with no observed pixel: the adaptive mode raises ValueError (it has
    no local moments to adapt to); the stationary mode (adaptive=False) returns that frame as
    the field mean, the filter's answer when nothing is observed (the frames of a stack are
    filtered independently).
    """
    if method not in ("scalar", "vector"):
        raise ValueError(f"method must be 'scalar' or 'vector', got {method!r}")
    check_row_models(row_models)
    threads, smooth = thread_count(threads), bool(smooth)
    adaptive = method == "scalar" if adaptive is None else bool(adaptive)
    if adaptive and method == "vector":
        raise ValueError("adaptive denoising needs method='scalar' (per-pixel noise variances)")
    z = images(image, missing=method == "scalar")
    nv = None if noise_var is None else positive_float(noise_var, "noise_var")
    mean = None if mean is None else real_number(mean, "mean")
    if model is not None:
        row_model(model)
    if z.size == 0:  # a stack of no frames
        return z.copy()
    if np.isnan(z.flat[0]) and np.isnan(z).all():  # (a pass only if the first pixel is NaN)
        raise ValueError("every pixel is NaN (missing): there is nothing to denoise")
    exponent = _moments_scale(z)
    if exponent:
        settings: dict[str, Any] = dict(method=method, smooth=smooth, adaptive=adaptive)
        settings.update(window=window, threads=threads, row_models=row_models)
        return _rescaled(z, exponent, nv, model, mean, settings)
    if nv is None:
        nv = estimate_noise_var(z)
        if not nv > 0:
            raise ValueError(
                "the estimated noise variance is 0: the image looks noise-free (or its values"
                " are so small that their squares underflow float64: rescale it)"
            )
    if adaptive:
        detail = DETAIL_MODEL if model is None else model
        return _adaptive(z, nv, detail, window, (smooth, row_models), threads)
    modes: Literal["ends", "toeplitz"] = "ends"
    if model is None:
        model, fitted_mean, _ = model_from_noisy(z)
        mean = fitted_mean if mean is None else mean
        modes = "toeplitz"
    mean = float(np.nanmean(z)) if mean is None else float(mean)
    if method == "scalar":
        m = _core.model_ar_order(model.order[1])  # (docstring: adaptive=False)
        filt: ScalarRowFilter | VectorRowFilter = ScalarRowFilter(
            model, nv, z.shape[-1], m, smooth=smooth, mean=mean, modes=modes, threads=threads
        )
    else:
        filt = VectorRowFilter(model, nv, z.shape[-1], smooth=smooth, mean=mean, threads=threads)
    return filt.filter(z)


def _rescaled(
    z: np.ndarray,
    exponent: int,
    nv: float | None,
    model: ARFieldModel | None,
    mean: float | None,
    settings: dict[str, Any],
) -> np.ndarray:
    """:func:`denoise` of z · 2^−exponent (with noise_var, mean and a stationary model's σ
    scaled alike), times 2^exponent: the same bits as the unscaled computation wherever that
    neither overflows nor underflows (both modes are scale-equivariant)."""
    if nv is not None:
        nv = float(np.ldexp(nv, -2 * exponent))
        if not np.finfo(np.float64).tiny <= nv < np.inf:
            raise ValueError(
                f"noise_var relative to the images' scale (pixels ~2^{exponent}) would "
                "underflow or overflow float64: rescale the images or noise_var"
            )
    if model is not None and not settings["adaptive"]:  # (the detail model has unit σ)
        model = ARFieldModel(model.rho, model.order, float(np.ldexp(model.sigma, -exponent)))
    scaled_mean = None if mean is None else float(np.ldexp(mean, -exponent))
    out = denoise(np.ldexp(z, -exponent), nv, model, mean=scaled_mean, **settings)
    with np.errstate(over="ignore"):
        np.ldexp(out, exponent, out=out)
    if not np.isfinite(peak_magnitude(out)):
        raise ValueError("the denoised images overflow float64: rescale them")
    return out


def _adaptive(
    z: np.ndarray,
    nv: float,
    model: ARFieldModel,
    window: int,
    passes: tuple[bool, str],
    threads: int | None,
) -> np.ndarray:
    """x̂ = μ + σ ξ̂ of :func:`denoise`'s adaptive mode: one Rust kernel (local moments,
    normalisation, weighted :class:`ScalarRowFilter` with Toeplitz modes), frames in
    parallel, each with its own nominal noise ratio. `passes`: (smooth, row_models)."""
    radius = _box_radius(window, z)
    out = np.empty_like(z)
    smooth, row_models = passes
    _core.adaptive_denoise_into(z, nv, model._core, radius, smooth, out, threads, row_models)
    return out
