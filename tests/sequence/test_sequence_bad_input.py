"""Bad input of the sequence filter: clear errors, and a stream that goes on unharmed."""

from __future__ import annotations

import numpy as np
import pytest

import kalmanfield as kf

MODEL = kf.ARFieldModel((0.9, 0.8, 0.8), (1, 1, 1))


@pytest.mark.parametrize(
    ("args", "kwargs", "error"),
    [
        ((kf.ARFieldModel((0.8, 0.8), (1, 1)), 1.0, (4, 4)), {}, ValueError),
        (("model", 1.0, (4, 4)), {}, TypeError),
        ((MODEL, 0.0, (4, 4)), {}, ValueError),
        ((MODEL, -1.0, (4, 4)), {}, ValueError),
        ((MODEL, float("nan"), (4, 4)), {}, ValueError),
        ((MODEL, 1.0, (0, 4)), {}, ValueError),
        ((MODEL, 1.0, (4,)), {}, ValueError),
        ((MODEL, 1.0, (4, 4)), {"lag": -1}, ValueError),
        ((MODEL, 1.0, (4, 4)), {"lag": 1.5}, TypeError),
        ((MODEL, 1.0, (4, 4)), {"method": "exact"}, ValueError),
        ((MODEL, 1.0, (4, 4)), {"method": "fast", "lag": 2}, ValueError),
        ((kf.ARFieldModel(0.8, [3, 1, 1]), 1.0, (4, 4)), {"method": "fast"}, ValueError),
    ],
)
def test_bad_arguments(args, kwargs, error):
    with pytest.raises(error):
        kf.SequenceFilter(*args, **kwargs)


@pytest.mark.parametrize("method", ["optimal", "fast"])
def test_bad_frames_mid_stream_leave_the_stream_unharmed(method):
    rng = np.random.default_rng(30)
    frames = rng.normal(size=(4, 6, 5))
    f = kf.SequenceFilter(MODEL, 1.0, (6, 5), method=method)
    clean = kf.SequenceFilter(MODEL, 1.0, (6, 5), method=method)
    f.step(frames[0])
    clean.step(frames[0])
    one_infinite = frames[1].copy()
    one_infinite[2, 3], one_infinite[0, 0] = -np.inf, np.nan  # (the NaN alone is fine)
    bad_frames = [
        (one_infinite, ValueError),
        (np.zeros((5, 6)), ValueError),
        (np.zeros((4, 6, 5)), ValueError),
        (np.full((6, 5), 1j), TypeError),
        (np.full((6, 5), "a"), TypeError),
        (np.full((6, 5), np.inf), ValueError),
        (None, TypeError),
    ]
    for frame, error in bad_frames:
        with pytest.raises(error):
            f.step(frame)
    for frame in frames[1:]:
        np.testing.assert_array_equal(f.step(frame), clean.step(frame))


def test_filter_refuses_a_two_dimensional_array_and_accepts_iterables():
    f = kf.SequenceFilter(MODEL, 1.0, (6, 5))
    with pytest.raises(ValueError):
        f.filter(np.zeros((6, 5)))
    with pytest.raises(TypeError):
        f.filter(5)
    frames = np.random.default_rng(31).normal(size=(3, 6, 5))
    np.testing.assert_array_equal(f.filter(iter(list(frames))), f.filter(frames))
    uint8 = (np.arange(90).reshape(3, 6, 5) % 7).astype(np.uint8)
    np.testing.assert_array_equal(f.filter(uint8), f.filter(uint8.astype(float)))
