"""Synthetic scenes for the template tests: a template moving over a background."""

import numpy as np
import pytest


def moving_scene(n=40, seed=0, shape=(60, 80), size=(9, 11), snr=1.5, path=None, background=0.3):
    """(frames, template, true top-left positions): the template added at the rounded
    position of `path(k)` (skipped while it does not fit), over a fixed background of std
    `background` plus white noise of std 1/snr per frame."""
    rng = np.random.default_rng(seed)
    height, width = shape
    h, w = size
    if path is None:

        def path(k):
            return 10 + 1.3 * k + 0.02 * k * k, 20 + 8 * np.sin(k / 7)

    backdrop = rng.standard_normal(shape) * background
    template = rng.standard_normal(size)
    frames, truth = [], []
    for k in range(n):
        x, y = path(k)
        frame = backdrop + rng.standard_normal(shape) / snr
        xi, yi = int(round(x)), int(round(y))
        if 0 <= xi <= width - w and 0 <= yi <= height - h:
            frame[yi : yi + h, xi : xi + w] += template
        frames.append(frame)
        truth.append((x, y))
    return frames, template, truth


@pytest.fixture
def scene():
    return moving_scene
