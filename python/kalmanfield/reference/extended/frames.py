"""NumPy twins of the detector's frame kernels (method page *Extended objects*, §3.4):
the box mean and the background level, in the Rust kernels' summation order."""

from __future__ import annotations

import numpy as np

__all__ = ["background_level", "box_smooth"]


def box_smooth(image: np.ndarray, width: int) -> np.ndarray:
    """Mean over a width × width box centred on each pixel (edges repeated): column sums,
    then row sums, each term in order, times 1 / width² (the Rust kernel multiplies by the
    reciprocal, not divides)."""
    if width == 1:
        return image
    lo = width // 2
    padded = np.pad(image, ((lo, width - 1 - lo), (lo, width - 1 - lo)), mode="edge")
    h, w = image.shape
    rows = padded[0:h].copy()
    for k in range(1, width):
        rows += padded[k : k + h]
    out = rows[:, 0:w].copy()
    for k in range(1, width):
        out += rows[:, k : k + w]
    out *= 1.0 / (width * width)
    return out


def background_level(smoothed: np.ndarray) -> float:
    """Median of the smoothed frame: of every 4th row and column beyond 256² pixels."""
    step = 1 if smoothed.size <= 65536 else 4
    return float(np.median(smoothed[::step, ::step]))
