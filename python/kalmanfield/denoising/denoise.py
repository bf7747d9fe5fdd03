"""One-call denoising of images by the row Kalman filters, with the model and the noise level
estimated from the noisy image itself, optionally locally adapted (method page
*Denoising*)."""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from .. import _core
from .._channels import check_channel_axis, per_channel, warn_if_colour
from .._compat import keyword_only
from .._validation import (
    boolean_mask,
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


def estimate_sigma(image: npt.ArrayLike) -> float:
    """Standard deviation σ_θ of the white noise in an image (:func:`estimate_noise_var`).

    Parameters
    ----------
    image : array_like
        An image (H, W) or a stack (…, H, W), at least 2 × 2.

    Returns
    -------
    float
        √σ̂², scikit-image's ``estimate_sigma`` convention.

    Raises
    ------
    ValueError
        As :func:`estimate_noise_var`.

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> z = np.random.default_rng(0).normal(0, 2.0, (512, 512))
    >>> round(kf.estimate_sigma(z), 1)
    2.0
    """
    return float(np.sqrt(estimate_noise_var(image)))


#: seed of the fixed SURE probe ("SUREPROB")
_PROBE_SEED = 0x5355_5245_5052_4F42

Method = Literal["auto", "adaptive", "stationary", "vector", "scalar"]
_METHODS = ("auto", "adaptive", "stationary", "vector")


@dataclass(frozen=True)
class _Options:
    """The resolved settings of one :func:`denoise` call."""

    method: str
    smooth: bool
    detail_model: ARFieldModel
    window: int
    row_models: str
    threads: int | None


@keyword_only("noise_var", "model", "method", "smooth")
def denoise(
    image: npt.ArrayLike,
    *,
    noise_var: float | None = None,
    sigma: float | None = None,
    model: ARFieldModel | None = None,
    method: Method = "auto",
    smooth: bool = True,
    channel_axis: int | None = None,
    mask: npt.ArrayLike | None = None,
    clip: bool = False,
    detail_model: ARFieldModel | None = None,
    window: int = 9,
    mean: float | None = None,
    threads: int | None = None,
    row_models: Literal["nominal", "propagated", "implied"] = "nominal",
    adaptive: bool | None = None,
) -> np.ndarray:
    """Denoise an image or a stack of z = x + θ, θ white, by the row Kalman filters.

    By default the noise level is estimated, and the better of two filters is chosen for the
    image by Stein's unbiased risk estimate: the adaptive filter (local mean and variance
    adapt it pixel by pixel: edges, text, faces) or the stationary one (one field model for
    the whole image: smooth scenes such as the moon or cells).

    Parameters
    ----------
    image : array_like
        An image (H, W) or a stack (F, H, W), with a channel axis if `channel_axis` is given;
        float64, float32, uint8 or uint16. NaN pixels are missing observations, filled from
        their neighbours (not with ``method="vector"``).
    noise_var : float, optional
        The noise variance σ_θ² (keyword only). Give it or `sigma`, not both; neither
        estimates it (:func:`estimate_noise_var`, per channel).
    sigma : float, optional
        The noise standard deviation σ_θ, scikit-image's convention.
    model : ARFieldModel, optional
        The field model of x (e.g. ``identify(clean).model``); given, the stationary filter
        runs with it. Default: fitted by :func:`model_from_noisy`.
    method : {"auto", "adaptive", "stationary", "vector"}, default "auto"
        "auto" picks "adaptive" or "stationary" by the smaller risk estimate (about four
        filter runs; "stationary" when `model` is given); "vector" is the optimal
        :class:`VectorRowFilter` (O(W²) per row, every pixel needed). "scalar" (0.1.0) is
        deprecated: "adaptive", or "stationary" with ``adaptive=False``.
    smooth : bool, default True
        Run the smoothing pass over the rows.
    channel_axis : int, optional
        The axis of colour channels (scikit-image's convention): each channel is denoised
        as an image of its own, with its own noise level. None: no channel axis (a 3-D
        array ending in 3 or 4 values then warns: it is read as a stack of narrow frames).
    mask : array_like of bool, optional
        True = a pixel to leave out (missing), as in ``numpy.ma``; of the image's shape.
    clip : bool, default False
        Clip the estimate to the input's range: its dtype's for uint8/uint16 input (e.g.
        0…255), its [min, max] for floats.
    detail_model : ARFieldModel, optional
        The adaptive filter's model of the normalised detail field ξ (default
        :data:`DETAIL_MODEL`, (1,1) with ρ = 0.7).
    window : int, default 9
        Odd side of the box of the local moments (adaptive filter).
    mean : float, optional
        The field mean of the stationary filter (None: the fitted or the image mean).
    threads : int, optional
        Threads for the frames of a stack (None: all cores); a single image runs on the
        calling thread, GIL released.
    row_models : {"nominal", "propagated", "implied"}, default "nominal"
        Row models of the adaptive filter's per-pixel weights (see
        :class:`ScalarRowFilter`).
    adaptive : bool, optional
        Deprecated: use ``method="adaptive"`` or ``method="stationary"``.

    Returns
    -------
    numpy.ndarray
        The estimate, of the image's shape, on its scale: float32 for float32 input, float64
        otherwise (uint8/uint16 on their own scale, like scikit-image's
        ``preserve_range=True``).

    Raises
    ------
    ValueError
        Both `noise_var` and `sigma`, a bad option (``model`` with ``method="adaptive"``),
        images that are not 2-D or 3-D (plus a channel axis) or hold infinite values, every
        pixel missing (or a frame without an observed pixel with the adaptive filter), a
        noise variance estimated as 0 or out of float64's range, NaN pixels with
        ``method="vector"``.
    TypeError
        A model that is not an ARFieldModel, an image that is not numeric, a non-boolean
        mask.

    See Also
    --------
    ScalarRowFilter : The filter, with a model and noise level of your own.
    estimate_sigma : The noise estimate.

    Notes
    -----
    Adaptive filter: x = μ(s) + σ(s) ξ(s), with μ and σ² + σ_θ² the mean and variance of the
    `window`² box around each pixel; the normalised residual (z − μ)/σ = ξ + θ/σ is
    filtered with per-pixel noise variance σ_θ²/σ². With ρ = 0 it is the adaptive (Lee)
    Wiener filter of ``scipy.signal.wiener``. The choice of "auto" is by Monte Carlo SURE
    [2]_ over the observed pixels (one seeded probe), the same choice whatever ran before.
    Method and choices: :doc:`/methods/denoising`; figures: :doc:`/benchmarks/row_filters`.

    References
    ----------
    .. [1] J.-S. Lee, "Digital image enhancement and noise filtering by use of local
       statistics", IEEE Trans. PAMI 2(2), 165–168, 1980.
    .. [2] S. Ramani, T. Blu and M. Unser, "Monte-Carlo SURE: a black-box optimization of
       regularization parameters for general denoising algorithms", IEEE Trans. Image
       Processing 17(9), 1540–1554, 2008.

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> x = kf.ARFieldModel([0.95, 0.95], [2, 2]).sample((128, 128), seed=1)
    >>> z = x + np.random.default_rng(0).normal(0, 0.5, x.shape)
    >>> x_hat = kf.denoise(z, sigma=0.5)
    >>> bool(np.mean((x_hat - x) ** 2) < 0.25 * np.mean((z - x) ** 2))
    True
    """
    options, model = _options(
        method, adaptive, model, detail_model, smooth, window, threads, row_models
    )
    nv = _noise_level(noise_var, sigma)
    mean = None if mean is None else real_number(mean, "mean")
    if model is not None:
        row_model(model)
    raw = image if isinstance(image, np.ndarray) else np.asarray(image)
    z = real_array(image, "image")
    if mask is not None:
        z = np.where(boolean_mask(mask, z.shape, "image"), np.nan, z)
    axis = check_channel_axis(channel_axis, z.ndim)
    grey = functools.partial(_denoise_grey, nv=nv, model=model, mean=mean, options=options)
    if axis is None:
        warn_if_colour(z, "denoise")
        out = grey(images(z, missing=True))
    else:
        out = per_channel(z, axis, lambda c: grey(images(c, missing=True)))
    return _as_input(out, raw, clip)


def _options(
    method: str,
    adaptive: bool | None,
    model: ARFieldModel | None,
    detail_model: ARFieldModel | None,
    smooth: bool,
    window: int,
    threads: int | None,
    row_models: str,
) -> tuple[_Options, ARFieldModel | None]:
    """The settings checked (and `model`, which the 0.1.0 spelling ``adaptive=True`` read as
    the detail model): the 0.1.0 spellings map to today's with a warning."""
    if method == "scalar" or adaptive is not None:
        new = "vector" if method == "vector" else "stationary" if adaptive is False else "adaptive"
        spelling = f"method={new!r}"
        if new == "adaptive" and model is not None:  # 0.1.0: the model of the detail field
            detail_model, model = model, None
            spelling = "method='adaptive', detail_model=…"
        warnings.warn(
            f"denoise(method={method!r}, adaptive={adaptive!r}) is deprecated: use {spelling}",
            DeprecationWarning,
            stacklevel=4,  # (the caller of denoise, past keyword_only's wrapper)
        )
        if method == "vector" and adaptive:
            raise ValueError("adaptive denoising needs method='adaptive' (per-pixel noise)")
        method = new
    if method not in _METHODS:
        raise ValueError(f"method must be one of {list(_METHODS)}, got {method!r}")
    if method == "adaptive" and model is not None:
        raise ValueError(
            "model= is the field model of x, used by the stationary filters; the adaptive "
            "filter's model of the normalised detail is detail_model="
        )
    check_row_models(row_models)
    if detail_model is not None:
        row_model(detail_model)
    options = _Options(
        method="stationary" if method == "auto" and model is not None else method,
        smooth=bool(smooth),
        detail_model=DETAIL_MODEL if detail_model is None else detail_model,
        window=window,
        row_models=row_models,
        threads=thread_count(threads),
    )
    return options, model


def _noise_level(noise_var: float | None, sigma: float | None) -> float | None:
    """σ_θ² from `noise_var` or `sigma` (at most one), None to estimate it."""
    if noise_var is not None and sigma is not None:
        raise ValueError("give noise_var (a variance) or sigma (a standard deviation), not both")
    if sigma is not None:
        sigma = positive_float(sigma, "sigma")
        variance = sigma * sigma
        if not 0 < variance < np.inf:
            raise ValueError(f"sigma² must be a positive float64, got sigma = {sigma!r}")
        return variance
    return None if noise_var is None else positive_float(noise_var, "noise_var")


def _as_input(out: np.ndarray, raw: np.ndarray, clip: bool) -> np.ndarray:
    """The estimate on the input's terms: clipped to its range if asked, float32 for float32
    input."""
    if clip:
        if raw.dtype.kind in "ui":
            info = np.iinfo(raw.dtype)
            low, high = float(info.min), float(info.max)
        else:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN input
                low, high = float(np.nanmin(raw)), float(np.nanmax(raw))
        np.clip(out, low, high, out=out)
    return out.astype(np.float32) if raw.dtype == np.float32 else out


def _denoise_grey(
    z: np.ndarray,
    nv: float | None,
    model: ARFieldModel | None,
    mean: float | None,
    options: _Options,
) -> np.ndarray:
    """:func:`denoise` of grey images or a stack (float64, NaN = missing)."""
    if options.method == "vector" and np.isnan(z).any():
        raise ValueError("method='vector' needs every pixel: the images hold NaN pixels")
    if z.size == 0:  # a stack of no frames
        return z.copy()
    if np.isnan(z.flat[0]) and np.isnan(z).all():  # (a pass only if the first pixel is NaN)
        raise ValueError("every pixel is NaN (missing): there is nothing to denoise")
    exponent = _moments_scale(z)
    if not exponent:
        return _denoise_scaled(z, nv, model, mean, options)
    # the same bits as the unscaled computation wherever that neither overflows nor
    # underflows (every filter is scale-equivariant)
    if nv is not None:
        nv = float(np.ldexp(nv, -2 * exponent))
        if not np.finfo(np.float64).tiny <= nv < np.inf:
            raise ValueError(
                f"noise_var relative to the images' scale (pixels ~2^{exponent}) would "
                "underflow or overflow float64: rescale the images or noise_var"
            )
    if model is not None:
        model = ARFieldModel(model.rho, model.order, float(np.ldexp(model.sigma, -exponent)))
    mean = None if mean is None else float(np.ldexp(mean, -exponent))
    out = _denoise_scaled(np.ldexp(z, -exponent), nv, model, mean, options)
    with np.errstate(over="ignore"):
        np.ldexp(out, exponent, out=out)
    if not np.isfinite(peak_magnitude(out)):
        raise ValueError("the denoised images overflow float64: rescale them")
    return out


def _denoise_scaled(
    z: np.ndarray,
    nv: float | None,
    model: ARFieldModel | None,
    mean: float | None,
    options: _Options,
) -> np.ndarray:
    """:func:`denoise` of images whose moments float64 holds."""
    if nv is None:
        nv = estimate_noise_var(z)
        if not nv > 0:
            raise ValueError(
                "the estimated noise variance is 0: the image looks noise-free (or its values"
                " are so small that their squares underflow float64: rescale it)"
            )
    if options.method == "adaptive":
        return _adaptive(z, nv, options)
    modes: Literal["ends", "toeplitz"] = "ends"
    if model is None:
        try:
            model, fitted_mean, _ = model_from_noisy(z)
        except ValueError:
            if options.method == "auto":  # no stationary model fits: the adaptive filter
                return _adaptive(z, nv, options)
            raise
        mean = fitted_mean if mean is None else mean
        modes = "toeplitz"
    mean = float(np.nanmean(z)) if mean is None else float(mean)
    if options.method == "vector":
        vector = VectorRowFilter(
            model, nv, z.shape[-1], smooth=options.smooth, mean=mean, threads=options.threads
        )
        return vector.filter(z)
    m = _core.model_ar_order(model.order[1])
    scalar = ScalarRowFilter(
        model,
        nv,
        z.shape[-1],
        m,
        smooth=options.smooth,
        mean=mean,
        modes=modes,
        threads=options.threads,
    )
    if options.method == "stationary":
        return scalar.filter(z)
    return _least_risk(z, nv, [lambda u: _adaptive(u, nv, options), scalar.filter])


def _least_risk(
    z: np.ndarray, nv: float, filters: list[Callable[[np.ndarray], np.ndarray]]
) -> np.ndarray:
    """The output of the filter with the smallest Monte Carlo SURE over the observed pixels:
    mean((z − f(z))²) − σ² + 2σ² div f / n, the divergence from one probe b of random signs,
    bᵀ(f(z + εb) − f(z))/ε (Ramani, Blu and Unser 2008). The probe is fixed (its own seed,
    and ±1 values no Gaussian noise of a user's can equal: a probe equal to the noise
    realisation biases the divergence)."""
    observed_pixels = ~np.isnan(z)
    n = int(observed_pixels.sum())
    signs = np.random.default_rng(_PROBE_SEED).integers(0, 2, z.shape)
    probe = np.where(observed_pixels, 2.0 * signs - 1.0, 0.0)
    eps = 1e-3 * np.sqrt(nv)
    best, best_risk = None, np.inf
    for f in filters:
        out = f(z)
        shifted = f(z + eps * probe)
        residual = np.where(observed_pixels, z - out, 0.0)
        divergence = float(np.sum(probe * (shifted - out), where=observed_pixels)) / eps
        risk = float(np.sum(residual**2)) / n - nv + 2.0 * nv * divergence / n
        if risk < best_risk:
            best, best_risk = out, risk
    assert best is not None
    return best


def _adaptive(z: np.ndarray, nv: float, options: _Options) -> np.ndarray:
    """x̂ = μ + σ ξ̂ of :func:`denoise`'s adaptive filter: one Rust kernel (local moments,
    normalisation, weighted :class:`ScalarRowFilter` with Toeplitz modes), frames in
    parallel, each with its own nominal noise ratio."""
    radius = _box_radius(options.window, z)
    out = np.empty_like(z)
    core = options.detail_model._core
    smooth, rows = options.smooth, options.row_models
    _core.adaptive_denoise_into(z, nv, core, radius, smooth, out, options.threads, rows)
    return out
