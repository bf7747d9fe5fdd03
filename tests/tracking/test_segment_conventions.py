"""segment as scikit-image users expect (issue 51): Otsu's or any computed threshold, colour
channels, the RGB-read-as-a-stack trap."""

import numpy as np
import pytest

import kalmanfield as kf
from kalmanfield.tracking.segment import otsu_threshold


def spots(seed=0):
    rng = np.random.default_rng(seed)
    frame = rng.normal(0, 1, (64, 80))
    for r, c in [(10, 12), (30, 50), (50, 20)]:
        frame[r - 2 : r + 3, c - 2 : c + 3] += 8.0
    return frame


def test_otsu_threshold_is_scikit_images():
    filters = pytest.importorskip("skimage.filters")
    rng = np.random.default_rng(1)
    for _ in range(5):
        image = np.concatenate([rng.normal(0, 1, 900), rng.normal(6, 2, 300)]).reshape(30, 40)
        assert otsu_threshold(image) == filters.threshold_otsu(image)


def test_a_threshold_by_name_or_by_function():
    frame = spots()
    by_name = kf.segment(frame, "otsu")
    pd_equal = by_name.equals(kf.segment(frame, otsu_threshold(frame)))
    assert pd_equal and len(by_name) >= 3
    by_function = kf.segment(frame, lambda image: 4.0 * image.std())
    assert by_function.equals(kf.segment(frame, 4.0 * frame.std()))
    stack = np.stack([frame, frame[::-1]])
    assert kf.segment(stack, "otsu").equals(kf.segment(stack, otsu_threshold(stack)))
    with pytest.raises(ValueError, match="'otsu' or a callable"):
        kf.segment(frame, "triangle")
    with pytest.raises(ValueError, match="constant"):
        kf.segment(np.zeros((8, 8)), "otsu")
    with pytest.raises(TypeError, match="callable returned"):
        kf.segment(frame, lambda image: "high")


def test_colour_frames_are_segmented_on_their_mean():
    """kf.segment(astronaut, 100) returned 512 "frames"."""
    frame = spots()
    rgb = np.stack([frame, 2 * frame, 0 * frame], axis=-1)
    got = kf.segment(rgb, 3.0, channel_axis=-1)
    assert got.equals(kf.segment(rgb.mean(axis=-1), 3.0))
    assert "frame" not in got and len(got) >= 3
    with pytest.warns(UserWarning, match="channel_axis=-1"):
        kf.segment(rgb, 3.0)


def test_identify_takes_channels_as_replicates():
    model = kf.ARFieldModel([0.9, 0.7], [1, 2])
    channels = np.stack([model.sample((96, 96), seed=s) for s in range(3)], axis=-1)
    by_channel = kf.identify(channels, channel_axis=-1)
    by_axes = kf.identify(channels, axes=(0, 1))
    assert by_channel.model == by_axes.model
    with pytest.raises(ValueError, match="channel axis"):
        kf.identify(channels, axes=(0, 2), channel_axis=2)


def test_identify_summary_says_whether_the_model_is_rejected():
    field = kf.ARFieldModel([0.9, 0.9], [1, 1]).sample((128, 128), seed=3)
    fit = kf.identify(field)
    assert fit.summary().splitlines()[-1].startswith("The model is not rejected")
    ramp = np.add.outer(np.arange(128.0), np.arange(128.0)) ** 1.5 + field  # not stationary
    rejected = kf.identify(ramp, max_order=1).summary()
    assert "The model is rejected" in rejected.splitlines()[-1]


def test_sample_adds_the_fitted_mean():
    data = 5.0 + kf.ARFieldModel([0.8, 0.8], [1, 1]).sample((64, 64), seed=2)
    fit = kf.identify(data)
    a = fit.model.sample((64, 64), seed=4, mean=fit.mean)
    np.testing.assert_array_equal(a, fit.model.sample((64, 64), seed=4) + fit.mean)
    with pytest.raises(ValueError, match="mean"):
        fit.model.sample((8, 8), seed=4, mean=np.inf)
