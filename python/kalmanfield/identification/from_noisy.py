"""A field model and the white-noise level from a noisy image alone (method page
*Denoising*): the model behind :func:`kalmanfield.denoise` when none is given."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .. import _core
from .._validation import images, positive_int
from ..field.model import ARFieldModel
from .fit import MAX_IDENTIFIED_ORDER, minimise_over_rho

#: lags of the autocovariance fitted (1..12)
_LAGS = 12


def model_from_noisy(image: npt.ArrayLike, max_order: int = 4) -> tuple[ARFieldModel, float, float]:
    """Fit a field model and the white-noise variance to a noisy image z = x + θ.

    Parameters
    ----------
    image : array_like
        An image (H, W) or a stack (F, H, W); NaN pixels are missing (left out of the mean
        and of every lagged product).
    max_order : int, default 4
        Highest multiplicity tried per axis.

    Returns
    -------
    model : ARFieldModel
        The 2-axis model of x (rows, columns).
    mean : float
        Mean of the observed pixels.
    noise_var : float
        Estimated σ_θ² (≥ 0).

    Raises
    ------
    ValueError
        A constant image, an image without observed pixels, fewer than 3 pixels per axis,
        no positive correlation along an axis, a variance beyond float64.

    See Also
    --------
    identify : The better tool for noise-free data.

    Notes
    -----
    White noise adds to lag 0 of the autocovariance only, so per axis the model's
    σ² R_{n,ρ}(h) is fitted by least squares to the sample autocovariance at lags 1..12;
    σ² is the mean of the per-axis fits and σ_θ² the lag-0 autocovariance minus σ²,
    floored at 0. See :doc:`/methods/denoising`.

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> x = kf.ARFieldModel([0.9, 0.7], [2, 1]).sample((256, 256), seed=1)
    >>> z = x + np.random.default_rng(0).normal(0, 0.5, x.shape)
    >>> model, mean, noise_var = kf.model_from_noisy(z)
    >>> model.order, round(noise_var, 2)
    ((2, 1), 0.21)
    """
    z = images(image, missing=True)
    max_order = positive_int(max_order, "max_order")
    stack = z.reshape(-1, *z.shape[-2:])
    if stack.size == 0:
        raise ValueError("the stack has no frames: there is no model to fit")
    if np.isnan(stack).all():
        raise ValueError("every pixel is NaN (missing): there is no model to fit")
    mean, mean_of = float(np.mean(stack)), np.mean  # (the cheaper pass; NaN if any is missing)
    if np.isnan(mean):
        mean, mean_of = float(np.nanmean(stack)), np.nanmean
    centred = np.ascontiguousarray(stack - mean)
    peak = np.nanmax(np.abs(centred))  # a NumPy float: peak² of 1e300 is inf, not an error
    if not peak > 0:
        raise ValueError("the image is constant: there is no model to fit")
    centred /= peak  # the fit in units of the peak: squares of 1e160s would overflow
    fits = [_fit_axis(centred, axis, max_order) for axis in (1, 2)]
    variance = float(np.mean([f[2] for f in fits]))
    with np.errstate(over="ignore", invalid="ignore"):  # back to the image's units
        units = peak**2
        noise = float(max(float(mean_of(centred**2)) - variance, 0.0) * units)
        variance = float(variance * units)
    if not np.isfinite(variance):
        raise ValueError("the image's variance overflows float64: rescale it")
    model = ARFieldModel([f[0] for f in fits], [f[1] for f in fits], sigma=np.sqrt(variance))
    return model, mean, noise


def _fit_axis(centred: np.ndarray, axis: int, max_order: int) -> tuple[float, int, float]:
    lags = min(_LAGS, centred.shape[axis] - 1)
    if lags < 2:
        raise ValueError("the image is too small to fit a model (need ≥ 3 pixels per axis)")
    sums, counts = _core.lag_products(centred, axis, lags)
    cov = (sums / np.maximum(counts, 1))[1:]
    h = np.arange(1, lags + 1, dtype=np.float64)
    best = (np.inf, 0.0, 1, 0.0)
    for n in range(1, min(max_order, MAX_IDENTIFIED_ORDER) + 1):
        err, rho, scale = _best_rho(cov, h, n)
        if err < best[0]:
            best = (err, rho, n, scale)
    _, rho, n, scale = best
    if not scale > 0:
        raise ValueError(f"no positive correlation along axis {axis - 1}: nothing to denoise")
    return rho, n, scale


def _misfits(
    cov: np.ndarray, h: np.ndarray, n: int, rhos: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares misfits of σ² R_{n,ρ}(h) to cov for every ρ of `rhos`, and the fitted
    σ² (≥ 0) of each (one Rust call for the table of R_{n,ρ}(h))."""
    r = _core.axis_correlation_table(np.ascontiguousarray(rhos, dtype=np.float64), n, h)
    scale = np.maximum(r @ cov / np.einsum("ij,ij->i", r, r), 0.0)
    return np.sum((cov - scale[:, np.newaxis] * r) ** 2, axis=1), scale


def _best_rho(cov: np.ndarray, h: np.ndarray, n: int) -> tuple[float, float, float]:
    """argmin over ρ of the misfit (:func:`minimise_over_rho`): (misfit, ρ, σ²)."""
    rho = minimise_over_rho(lambda rhos: _misfits(cov, h, n, rhos)[0], 60, 40)
    err, scale = _misfits(cov, h, n, np.array([rho]))
    return float(err[0]), rho, float(scale[0])
