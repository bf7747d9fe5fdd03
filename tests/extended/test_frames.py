"""The detector's frame kernels (method page *Extended objects*, §3.4): the Rust box mean
and background level against their NumPy twins, the local-background box mean, and the
`background_width` option on a frame whose background the white-noise threshold cannot
handle."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import kalmanfield as kf
from kalmanfield import _core
from kalmanfield.extended.frames import box_mean
from kalmanfield.reference.extended import background_level, box_smooth


@settings(max_examples=40, deadline=None)
@given(
    h=st.integers(1, 40),
    w=st.integers(1, 40),
    width=st.integers(1, 9),
    seed=st.integers(0, 2**32 - 1),
)
def test_rust_equals_twin(h, w, width, seed):
    image = np.random.default_rng(seed).normal(0, 3, (h, w))
    np.testing.assert_allclose(
        _core.extended_smooth(image, width), box_smooth(image, width), rtol=0, atol=1e-12
    )
    np.testing.assert_allclose(box_mean(image, width), box_smooth(image, width), atol=1e-12)
    assert _core.extended_level(image) == background_level(image)
    out = np.full((h, w), np.nan)  # into a buffer: every value written, the same values
    assert _core.extended_smooth(image, width, out) is out
    np.testing.assert_array_equal(out, _core.extended_smooth(image, width))


@pytest.mark.parametrize("shape", [(300, 300), (257, 256), (5, 4)])
def test_level_subsamples_large_frames_like_the_twin(shape):
    image = np.random.default_rng(1).exponential(size=shape)
    assert _core.extended_level(image) == background_level(image)


def test_bad_kernel_input():
    with pytest.raises(ValueError, match="width"):
        _core.extended_smooth(np.zeros((4, 4)), 0)
    image = np.zeros((4, 4))
    with pytest.raises(ValueError, match="shape"):
        _core.extended_smooth(image, 3, np.zeros((4, 5)))
    with pytest.raises(ValueError, match="not the image"):
        _core.extended_smooth(image, 3, image)
    with pytest.raises(ValueError, match="C-contiguous"):
        _core.extended_smooth(image, 3, np.zeros((4, 8))[:, ::2])
    with pytest.raises(TypeError):
        _core.extended_smooth(image, 3, np.zeros((4, 4), np.float32))
    with pytest.raises(ValueError, match="NaN"):
        _core.extended_level(np.full((3, 3), np.nan))


def ramp_scene(n=10):
    """A disc of amplitude 6 moving at (2, 1) px/frame on a ramp rising 0 → 30 across the
    frame (a background the median + kσ threshold cannot handle), σ = 1."""
    rng = np.random.default_rng(0)
    yy, xx = np.mgrid[0:64, 0:64]
    frames = rng.normal(0, 1, (n, 64, 64)) + 30.0 * xx / 63
    for t in range(n):
        frames[t][(xx - 12 - 2 * t) ** 2 + (yy - 20 - t) ** 2 <= 16] += 6.0
    return frames


def test_background_width_finds_target_on_a_ramp():
    frames = ramp_scene()
    plain = kf.detect_moving_objects(frames, noise_std=1.0)
    local = kf.detect_moving_objects(frames, noise_std=1.0, background_width=15)

    def hit(objects):
        if not objects:
            return False
        row = objects[0].track[objects[0].track["frame"] == 9]
        return not row.empty and abs(row.iloc[0].x - 30) < 2 and abs(row.iloc[0].y - 29) < 2

    assert hit(local)
    assert not hit(plain)  # half the frame is above the plain threshold
    with pytest.raises(ValueError, match="background_width"):
        kf.detect_moving_objects(frames, noise_std=1.0, background_width=-1)
