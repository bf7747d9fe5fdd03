"""Sample correlation function of 1-D/2-D/3-D data with missing pixels (method page
*Identification*, §1.6)."""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Sequence
from typing import Any, Literal, Union

import numpy as np
import numpy.typing as npt

from .._validation import observed

LagLike = Union[int, Sequence[int]]


def sample_correlation(
    data: npt.ArrayLike,
    max_lag: LagLike,
    mask: npt.ArrayLike | None = None,
    *,
    estimator: Literal["unbiased", "biased"] = "unbiased",
) -> np.ndarray:
    """Normalised sample correlation R̂(h̄) = Ĉ(h̄)/Ĉ(0̄) for every lag with ``|h_k| ≤ L_k``.

    Parameters
    ----------
    data : array_like
        1-D, 2-D or 3-D data (uint8, uint16, int or float); NaN and ``numpy.ma``-masked
        pixels are missing.
    max_lag : int or sequence of int
        L_k per axis (one int for all), 0 ≤ L_k < ``data.shape[k]``.
    mask : array_like of bool, optional
        True = leave the pixel out.
    estimator : {"unbiased", "biased"}, default "unbiased"
        "unbiased" divides each lag by its own number of valid pairs N(h̄); "biased" by the
        number of valid pixels (positive semi-definite, shrinks long lags toward 0).

    Returns
    -------
    numpy.ndarray
        Shape (2L_1 + 1, …, 2L_d + 1); entry [L_1 + h_1, …, L_d + h_d] is lag h̄, so the
        centre is 1. Lags without a valid pair are NaN.

    Raises
    ------
    ValueError
        Data that are not 1-D to 3-D, constant or without a valid pixel; lags out of range.
    TypeError
        Lags that are not integers.

    Notes
    -----
    The mean of the valid pixels is removed, then Ĉ(h̄) = Σ_ī x_ī x_{ī+h̄} / N(h̄) over the
    pairs of valid pixels, by zero-padded FFTs of the data and of the validity mask, so
    missing pixels are excluded exactly (§1.6 of :doc:`/methods/identification`).

    Examples
    --------
    >>> import kalmanfield as kf
    >>> x = kf.ARFieldModel(0.7, [1, 1]).sample((256, 256), seed=1)
    >>> r = kf.sample_correlation(x, max_lag=2)
    >>> r.shape, float(r[2, 2])
    ((5, 5), 1.0)
    """
    values, valid = observed(data, mask)
    if not 1 <= values.ndim <= 3:
        raise ValueError(f"data must be 1-D, 2-D or 3-D, got {values.ndim}-D")
    lags = _max_lags(max_lag, values.shape)
    if estimator not in ("unbiased", "biased"):
        raise ValueError(f"estimator must be 'unbiased' or 'biased', got {estimator!r}")
    n_valid = int(valid.sum())
    if n_valid == 0:
        raise ValueError("data have no valid (finite, unmasked) pixel")
    centred = np.where(valid, values - values[valid].mean(), 0.0)
    peak = np.max(np.abs(centred))
    if peak > 0:  # the ratio does not depend on the scale; products of 1e160s overflow
        centred /= peak
    sums = _lagged_sums(centred, centred, lags)
    if valid.all():
        pairs = _full_grid_pairs(values.shape, lags)
    else:
        weights = valid.astype(np.float64)
        pairs = np.rint(_lagged_sums(weights, weights, lags))
    # a lag without a valid pair is NaN under both estimators
    norm = np.full(sums.shape, float(n_valid)) if estimator == "biased" else pairs
    with np.errstate(invalid="ignore", divide="ignore"):
        covariance = np.where(pairs > 0, sums / np.maximum(norm, 1.0), np.nan)
    variance = covariance[lags]
    if not variance > 0:
        raise ValueError("data are constant over their valid pixels: no correlation to estimate")
    return covariance / variance


def _max_lags(max_lag: LagLike, shape: tuple[int, ...]) -> tuple[int, ...]:
    items: tuple[Any, ...]
    if isinstance(max_lag, numbers.Integral):
        items = (max_lag,) * len(shape)
    elif isinstance(max_lag, Iterable) and not isinstance(max_lag, str):
        items = tuple(max_lag)
    else:
        raise TypeError(f"max_lag must be an integer or one integer per axis, got {max_lag!r}")
    if len(items) != len(shape):
        raise ValueError(f"max_lag needs one entry per axis ({len(shape)}), got {len(items)}")
    lags = []
    for k, (lag, n) in enumerate(zip(items, shape)):
        if isinstance(lag, (bool, np.bool_)) or not isinstance(lag, numbers.Integral):
            raise TypeError(f"max_lag must hold integers, got {lag!r}")
        if n == 0:
            raise ValueError(f"the data have no pixels along axis {k}")
        if not 0 <= int(lag) < n:
            raise ValueError(f"max_lag {int(lag)} of axis {k} must lie in [0, {n - 1}]")
        lags.append(int(lag))
    return tuple(lags)


def _fast_length(n: int) -> int:
    """Smallest 2^a 3^b 5^c ≥ n (an efficient FFT length)."""
    best = 1 << (n - 1).bit_length()
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            m = p35
            while m < n:
                m *= 2
            best = min(best, m)
            p35 *= 3
        p5 *= 5
    return best


def _lagged_sums(a: np.ndarray, b: np.ndarray, lags: tuple[int, ...]) -> np.ndarray:
    """Σ_ī a_ī b_{ī+h̄} for |h_k| ≤ lags_k, via zero-padded real FFTs (no wrap-around)."""
    sizes = [_fast_length(n + lag) for n, lag in zip(a.shape, lags)]
    axes = tuple(range(a.ndim))
    fa = np.fft.rfftn(a, sizes, axes=axes)
    fb = fa if b is a else np.fft.rfftn(b, sizes, axes=axes)
    full = np.fft.irfftn(np.conj(fa) * fb, sizes, axes=axes)
    index = np.ix_(*[np.arange(-lag, lag + 1) % size for lag, size in zip(lags, sizes)])
    return full[index]


def _full_grid_pairs(shape: tuple[int, ...], lags: tuple[int, ...]) -> np.ndarray:
    """N(h̄) = Π_k (n_k - |h_k|) for a grid without missing pixels."""
    out = np.ones(())
    for n, lag in zip(shape, lags):
        out = np.multiply.outer(out, n - np.abs(np.arange(-lag, lag + 1)).astype(np.float64))
    return out
