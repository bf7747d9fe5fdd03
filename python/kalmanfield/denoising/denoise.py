"""One-call denoising of images by the row Kalman filters, with the model and the noise level
estimated from the noisy image itself, optionally locally adapted (method page
*Denoising*)."""

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
#: chosen on scikit-image training images other than the benchmark's (method page
#: *Denoising*).
DETAIL_MODEL = ARFieldModel([0.7, 0.7], [1, 1])


def local_moments(image: npt.ArrayLike, window: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean and variance of every pixel's window × window box.

    Parameters
    ----------
    image : array_like
        An image (H, W) or a stack (F, H, W); NaN pixels are missing (the moments are those
        of the box's other pixels).
    window : int
        Odd box side. The box is cut at the borders, so a window ≥ 2 max(H, W) + 1 gives the
        whole frame's moments.

    Returns
    -------
    mean : numpy.ndarray
        Box means, of the image's shape (NaN where the box holds no observed pixel).
    variance : numpy.ndarray
        Box variances, likewise.

    Raises
    ------
    ValueError
        An even or non-positive window, images that are not 2-D or 3-D, a variance that
        overflows float64 (pixel deviations ≳ 1e154).
    TypeError
        A window that is not an integer.

    Notes
    -----
    O(1) work per pixel (running sums, Rust). Images whose largest absolute pixel lies outside
    [2⁻⁴⁰⁰, 2⁴⁰⁰] are scaled by a power of two (exact) for the sums of squares.

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> mean, var = kf.local_moments(np.arange(25.0).reshape(5, 5), window=3)
    >>> float(mean[2, 2]), round(float(var[2, 2]), 2)  # the box's population variance
    (12.0, 17.33)
    """
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
    """Variance σ_θ² of the white noise in an image, by the robust Haar-MAD estimate.

    Parameters
    ----------
    image : array_like
        An image (H, W) or a stack (…, H, W), at least 2 × 2; blocks with a NaN (missing) or
        infinite pixel are left out.

    Returns
    -------
    float
        The estimate σ̂², pooled over the frames of a stack.

    Raises
    ------
    ValueError
        An image smaller than 2 × 2, a σ̂² that overflows float64.

    Notes
    -----
    σ̂ = median|d| / Φ⁻¹(3/4) over the diagonal Haar details d = (z₀₀ − z₀₁ − z₁₀ + z₁₁)/2
    of the disjoint 2 × 2 blocks: the detail of a smooth image is ~0, of white noise
    N(0, σ²). See :doc:`/methods/denoising`.

    References
    ----------
    .. [1] D. L. Donoho and I. M. Johnstone, "Ideal spatial adaptation by wavelet
       shrinkage", Biometrika 81(3), 425–455, 1994.

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> z = np.random.default_rng(0).normal(0, 2.0, (512, 512))
    >>> round(kf.estimate_noise_var(z), 1)
    4.0
    """
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
    """Denoise an image or a stack of z = x + θ, θ white, by the row Kalman filters.

    By default the noise level is estimated, the image's local mean and variance adapt the
    filter pixel by pixel, and a smoothing pass runs over the rows.

    Parameters
    ----------
    image : array_like
        An image (H, W) or a stack (F, H, W); float64, float32, uint8 or uint16. NaN pixels
        are missing observations (``method="scalar"``), filled from their neighbours.
    noise_var : float, optional
        The noise variance σ_θ²; None estimates it (:func:`estimate_noise_var`).
    model : ARFieldModel, optional
        Adaptive mode: the model of the normalised detail field ξ (default
        :data:`DETAIL_MODEL`, (1,1) with ρ = 0.7). Stationary mode: the model of x (default
        fitted by :func:`model_from_noisy`).
    method : {"scalar", "vector"}, default "scalar"
        :class:`ScalarRowFilter` (O(W) per row) or :class:`VectorRowFilter` (optimal,
        O(W²) per row; needs every pixel, not adaptive).
    smooth : bool, default True
        Run the smoothing pass over the rows.
    adaptive : bool, optional
        Locally adapted mean and variance (default: True with ``method="scalar"``); False
        filters with one stationary model for the whole image.
    window : int, default 9
        Odd side of the box of the local moments (adaptive mode).
    mean : float, optional
        The field mean of the stationary model (None: the image mean); checked in both
        modes, used by the stationary one.
    threads : int, optional
        Threads for the frames of a stack (None: all cores); a single image runs on the
        calling thread, GIL released.
    row_models : {"nominal", "propagated", "implied"}, default "nominal"
        Row models of the adaptive filter's per-pixel weights (see
        :class:`ScalarRowFilter`): "nominal" is the fast path; "propagated" gains
        +0.1–0.3 dB on the benchmark images at 3.5–5× the time.

    Returns
    -------
    numpy.ndarray
        The estimate, float64 of the image's shape (an empty stack gives an empty one).

    Raises
    ------
    ValueError
        A bad option (``adaptive=True`` with ``method="vector"``), images that are not 2-D
        or 3-D or hold infinite values, every pixel missing (or a frame without an observed
        pixel in the adaptive mode), a noise variance estimated as 0 or out of float64's
        range, NaN pixels with ``method="vector"``.
    TypeError
        A model that is not an ARFieldModel, an image that is not numeric.

    See Also
    --------
    ScalarRowFilter : The filter, with a model and noise level of your own.
    estimate_noise_var : The noise estimate.

    Notes
    -----
    Adaptive mode: x = μ(s) + σ(s) ξ(s), with μ and σ² + σ_θ² the mean and variance of the
    `window`² box around each pixel; the normalised residual (z − μ)/σ = ξ + θ/σ is
    filtered with per-pixel noise variance σ_θ²/σ²: little smoothing on edges and texture,
    strong in flat areas. With ρ = 0 this is the adaptive (Lee) Wiener filter of
    ``scipy.signal.wiener``; the AR model of ξ adds the row-Kalman smoothing. Images of any
    magnitude float64 holds are scaled by a power of two (exact) and back. Method and
    choices: :doc:`/methods/denoising`; figures: :doc:`/benchmarks/row_filters`.

    References
    ----------
    .. [1] J.-S. Lee, "Digital image enhancement and noise filtering by use of local
       statistics", IEEE Trans. PAMI 2(2), 165–168, 1980.

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> x = kf.ARFieldModel([0.95, 0.95], [2, 2]).sample((128, 128), seed=1)
    >>> z = x + np.random.default_rng(0).normal(0, 0.5, x.shape)
    >>> x_hat = kf.denoise(z)
    >>> bool(np.mean((x_hat - x) ** 2) < 0.25 * np.mean((z - x) ** 2))
    True
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
