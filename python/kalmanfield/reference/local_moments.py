"""NumPy twin of the Rust ``local_moments`` kernel (box mean and variance, box cut at the
borders) used by the adaptive ``denoise``."""

from __future__ import annotations

import numpy as np


def local_moments(z: np.ndarray, radius: int) -> tuple[np.ndarray, np.ndarray]:
    """(mean, biased variance) over the (2r+1)² box of every pixel of an (H, W) image, by
    cumulative sums of z − mean(z) and its square along both axes."""
    z = np.asarray(z, dtype=np.float64)
    shift = z.mean()
    centred = z - shift
    count = _box_sum(np.ones_like(z), radius)
    mean = _box_sum(centred, radius) / count
    var = np.maximum(_box_sum(centred**2, radius) / count - mean**2, 0.0)
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
