"""NumPy twin of the Rust ``local_moments`` kernel (box mean and variance, box cut at the
borders, NaN pixels missing) used by the adaptive ``denoise``."""

from __future__ import annotations

import numpy as np


def local_moments(z: np.ndarray, radius: int) -> tuple[np.ndarray, np.ndarray]:
    """(mean, biased variance) over the (2r+1)² box of every pixel of an (H, W) image, by
    cumulative sums of z − mean(z) and its square along both axes. NaN pixels are left out;
    a box without an observed pixel gets NaN."""
    z = np.asarray(z, dtype=np.float64)
    observed = ~np.isnan(z)
    shift = z[observed].mean() if observed.any() else 0.0
    centred = np.where(observed, z - shift, 0.0)
    count = _box_sum(observed.astype(np.float64), radius)
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = _box_sum(centred, radius) / count
        var = np.maximum(_box_sum(centred**2, radius) / count - mean**2, 0.0)
    empty = count == 0
    mean[empty] = var[empty] = np.nan
    return mean + shift, var


def _box_sum(a: np.ndarray, r: int) -> np.ndarray:
    for axis in (0, 1):
        n = a.shape[axis]
        prefix = np.concatenate(
            [np.zeros_like(np.take(a, [0], axis=axis)), np.cumsum(a, axis=axis)], axis=axis
        )
        hi = np.minimum(np.arange(n) + r + 1, n)
        lo = np.maximum(np.arange(n) - r, 0)
        a = np.take(prefix, hi, axis=axis) - np.take(prefix, lo, axis=axis)
    return a
