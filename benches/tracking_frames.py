"""Images for the tracker benchmark: point detections rendered as Gaussian spots in noise.

Turns the (m, 2) x, y detections of one frame of ``tracking_scenario.py`` (targets and clutter
alike) into a float32 image that ``kalmanfield.segment`` can take apart again::

    from tracking_frames import render
    from tracking_scenario import make_scenario
    sc = make_scenario(seed=1, size=512.0, n_targets=50, n_clutter=200)
    rng = np.random.default_rng(0)
    images = [render(xy, (512, 512), rng=rng) for xy in sc.frames()]

Pixel (row r, column c) has centre x = c, y = r (the convention of ``kalmanfield.segment``).
"""

from __future__ import annotations

import math

import numpy as np


def render(
    positions: np.ndarray,
    shape: tuple[int, int],
    psf_sigma: float = 1.0,
    amplitude: float = 100.0,
    noise_std: float = 5.0,
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    """A float32 frame of `shape` (H, W): Σ_k amplitude · exp(−|p − p_k|² / (2 psf_sigma²))
    over the points p_k = `positions`[k] = (x, y), plus white Gaussian noise of std
    `noise_std` (none if 0).

    Each spot is drawn only in the window |x − x_k|, |y − y_k| ≤ ⌈4 psf_sigma⌉ (the tail
    beyond is < 3.4e-4 of the peak) and clipped to the frame; points outside the frame add
    only the part of their window inside it.
    """
    height, width = shape
    image = np.zeros(shape, dtype=np.float64)
    radius = math.ceil(4.0 * psf_sigma)
    offsets = np.arange(-radius, radius + 1)
    for x, y in np.asarray(positions, dtype=np.float64).reshape(-1, 2):
        cols = np.round(x).astype(int) + offsets
        rows = np.round(y).astype(int) + offsets
        cols = cols[(cols >= 0) & (cols < width)]
        rows = rows[(rows >= 0) & (rows < height)]
        if cols.size == 0 or rows.size == 0:
            continue
        gx = np.exp(-((cols - x) ** 2) / (2.0 * psf_sigma**2))
        gy = np.exp(-((rows - y) ** 2) / (2.0 * psf_sigma**2))
        image[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1] += amplitude * np.outer(gy, gx)
    if noise_std > 0:
        image += (rng or np.random.default_rng()).normal(0.0, noise_std, size=shape)
    return image.astype(np.float32)
