"""FieldStream (SPEC §1.4): stationary from frame 0, equal to one-shot sampling, resumable."""

import pickle

import numpy as np
import pytest

import kalmanfield as kf
from kalmanfield import reference as ref


def test_stream_equals_one_shot_sample_with_the_same_seed():
    model = kf.ARFieldModel([0.9, 0.8, 0.7], [2, 2, 1], 1.2)
    whole = model.sample((7, 30, 40), seed=11)
    stream = model.stream((30, 40), seed=11)
    frames = np.stack([next(stream) for _ in range(7)])
    assert np.array_equal(frames, whole)


@pytest.mark.parametrize("threads", [1, 2])
def test_large_frames_equal_one_shot_on_any_thread_count(threads):
    """Frames above the parallel threshold: the one-pass serial and the parallel paths."""
    model = kf.ARFieldModel([0.8, 0.9, 0.7], [2, 3, 2], 1.0)
    whole = model.sample((4, 260, 270), seed=3, threads=2)
    stream = model.stream((260, 270), seed=3, threads=threads)
    assert np.array_equal(stream.take(4), whole)


def test_frames_are_read_only_state():
    stream = kf.ARFieldModel([0.8, 0.9, 0.7], [1, 1, 1]).stream((4, 4), seed=0)
    frame = next(stream)
    with pytest.raises(ValueError, match="read-only"):
        frame[0, 0] = 1.0


def test_stream_with_given_noise_equals_one_shot_and_reference():
    model = kf.ARFieldModel([0.7, 0.6, 0.9], [3, 1, 2], 0.8)
    noise = np.random.default_rng(1).standard_normal((6, 5, 8))
    whole = model.sample(noise.shape, noise=noise)
    stream = model.stream((5, 8), seed=0)
    history = []
    for t in range(6):
        frame = stream.next_frame(noise=noise[t])
        np.testing.assert_allclose(frame, whole[t], rtol=1e-12, atol=1e-14)
        want = ref.stream_frame(model.rho, model.order, model.sigma, history, t, noise[t])
        np.testing.assert_allclose(frame, want, rtol=1e-9, atol=1e-12)
        history = [frame, *history][:3]


def test_pickle_resumes_bit_identically():
    model = kf.ARFieldModel([0.95, 0.9, 0.9], [2, 2, 2])
    stream = model.stream((16, 24), seed=5)
    for _ in range(3):
        next(stream)
    copy = pickle.loads(pickle.dumps(stream))
    for _ in range(4):
        assert np.array_equal(next(stream), next(copy))
    assert copy.time == stream.time == 7
    assert repr(copy) == repr(stream) == f"FieldStream({model!r}, frame_shape=(16, 24), time=7)"


def test_memory_is_bounded_by_the_time_order():
    model = kf.ARFieldModel([0.9, 0.5, 0.5], [3, 1, 1])
    stream = model.stream((8, 8), seed=0)
    for _ in range(10):
        next(stream)
    assert len(stream._history) == 3


def test_stream_is_stationary_from_the_first_frame():
    """Variance of frame 0, 1, 2 and covariance of frames (0, 1) over many streams."""
    model = kf.ARFieldModel([0.9, 0.5], [2, 1], 2.0)
    reps = 8000
    frames = np.array([model.stream((3,), seed=s).take(3) for s in range(reps)])
    var = (frames**2).mean(axis=0)  # (3 frames, 3 pixels)
    se = 4.0 * np.sqrt(2 / reps)
    assert np.abs(var - 4.0).max() < 5 * se
    cov01 = (frames[:, 0, :] * frames[:, 1, :]).mean(axis=0)
    want = model.correlation([1, 0])
    assert np.abs(cov01 - want).max() < 5 * np.sqrt((16 + want**2) / reps)


def test_stream_float32_and_bad_inputs():
    model = kf.ARFieldModel([0.9, 0.8, 0.8], [1, 1, 1])
    s32 = model.stream((10, 10), seed=3, dtype=np.float32)
    s64 = model.stream((10, 10), seed=3)
    np.testing.assert_allclose(next(s32), next(s64), atol=1e-5)
    with pytest.raises(ValueError, match="frame_shape"):
        model.stream((10,))
    with pytest.raises(ValueError, match="time axis"):
        kf.ARFieldModel(0.5, 1).stream((4,))
    with pytest.raises(ValueError, match="shape"):
        s64.next_frame(noise=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="NaN"):
        s64.next_frame(noise=np.full((10, 10), np.nan))
