"""FieldStream (method page *Random fields*, §1.4): stationary from frame 0, equal to one-shot
sampling, resumable."""

import math
import pickle
import threading

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


# ------------------------------------------------------------------ issue 49: items 3, 4, 7, 9
def _stream_at(time, model=None, shape=(4, 5), seed=2, dtype=np.float64):
    stream = (model or kf.ARFieldModel([0.9, 0.8, 0.7], [2, 1, 1])).stream(shape, seed, dtype)
    for _ in range(time):
        next(stream)
    return stream


def _load(state):
    copy = kf.FieldStream.__new__(kf.FieldStream)
    copy.__setstate__(state)
    return copy


@pytest.mark.parametrize(
    "field,value,exc,match",
    [
        ("history", [np.full((4, 5), np.nan)] * 2, ValueError, "NaN or infinite"),
        ("history", [np.full((4, 5), np.inf)] * 2, ValueError, "NaN or infinite"),
        ("history", [np.full((4, 5), 1e308)] * 2, ValueError, "can carry without overflow"),
        ("history", [np.zeros((4, 6))] * 2, ValueError, r"shape \(4, 6\)"),
        ("history", [np.zeros((4, 5), np.float32)] * 2, TypeError, "dtype float32"),
        ("history", [np.zeros((4, 5))] * 3, ValueError, "keeps 2"),
        ("history", [np.zeros((4, 5))], ValueError, "keeps 2"),
        ("history", [[0.0] * 5] * 4, ValueError, "keeps 2"),
        ("history", [[[0.0] * 5] * 4] * 2, TypeError, "must be an ndarray"),
        ("history", np.zeros((2, 4, 5)), TypeError, "list of frames"),
        ("time", -1, ValueError, "time"),
        ("time", 2.0, TypeError, "time"),
        ("time", 2**64, ValueError, "time"),
        ("time", 1, ValueError, "keeps 1"),
        ("seed", -3, ValueError, "seed"),
        ("seed", 2**64, ValueError, "seed"),
        ("seed", "7", TypeError, "seed"),
        ("seed", None, TypeError, "seed"),
        ("threads", 0, ValueError, "threads"),
        ("threads", 1.5, TypeError, "threads"),
        ("dtype", "<i8", TypeError, "dtype"),
        ("dtype", "nonsense", TypeError, "dtype"),
        ("dtype", 3, TypeError, "dtype"),
        ("model", "model", TypeError, "ARFieldModel"),
        ("model", kf.ARFieldModel(0.5, 1), ValueError, "time axis"),
        ("model", kf.ARFieldModel([0.5, 0.5], [1, 1]), ValueError, "frame_shape"),
        ("frame_shape", (4, 0), ValueError, "frame_shape"),
        ("frame_shape", "45", TypeError, "frame_shape"),
    ],
)
def test_a_corrupt_state_is_refused_at_load(field, value, exc, match):
    """(a history of NaN, inf, 1e308 or the wrong shape was accepted; the next frames were
    NaN)"""
    state = _stream_at(3).__getstate__()
    state[field] = value
    with pytest.raises(exc, match=match):
        _load(state)


def test_a_state_lacking_a_field_or_not_a_dict_is_refused():
    state = _stream_at(3).__getstate__()
    del state["history"]
    with pytest.raises(ValueError, match="lacks"):
        _load(state)
    with pytest.raises(TypeError, match="dict"):
        _load([1, 2])


def test_the_history_limit_bounds_the_worst_response_of_the_time_recursion():
    """The worst history alternates in sign (stream_state.history_limit): a simulation of the
    time recursion from it peaks at the computed gain G, and G bounds every other history
    (random ones here)."""
    from kalmanfield.field.stream_state import _stationary_gain

    rng = np.random.default_rng(0)
    for rho, n in [(0.9, 1), (0.9, 3), (0.99, 4), (0.5, 16), (0.97, 2)]:
        coeffs, _ = ref.stationary_start(rho, n) if n <= 8 else (None, None)
        a = np.array([(-1) ** (j + 1) * math.comb(n, j) * rho**j for j in range(1, n + 1)])
        if coeffs is not None:
            np.testing.assert_allclose(coeffs[n], a, rtol=1e-9)
        gain = _stationary_gain(rho, n)
        steps = int(40 * n / (1 - rho)) + 50
        histories = np.vstack([(-1.0) ** np.arange(n), rng.uniform(-1, 1, (8, n))])
        peaks = []
        for h in histories:
            x, peak = list(h), 0.0
            for _ in range(steps):
                x = [float(a @ np.array(x)), *x[:-1]]
                peak = max(peak, abs(x[0]))
            peaks.append(peak)
        # (G is the peak over real t ≥ 0: at most ~1e-4 above the integer frames' at ρ = 0.97)
        assert peaks[0] == pytest.approx(gain, rel=1e-3) and max(peaks) <= gain


def test_a_history_at_the_limit_runs_finite_and_one_beyond_it_is_refused():
    from kalmanfield.field.stream_state import history_limit

    model = kf.ARFieldModel([0.95, 0.8], [3, 1])
    stream = _stream_at(5, model, (6,))
    limit = history_limit(model, np.dtype(np.float64), 5)
    state = stream.__getstate__()
    # the worst pattern (alternating in sign from the most recent frame) at the limit
    state["history"] = [np.full(6, (-1.0) ** j * limit) for j in range(3)]
    at_limit = _load(state)
    frames = at_limit.take(400)
    assert np.isfinite(frames).all() and np.abs(frames).max() <= np.finfo(float).max / 4 * 1.01
    state["history"][0] = np.full(6, 1.001 * limit)
    with pytest.raises(ValueError, match="can carry"):
        _load(state)
    # a float32 stream's limit is float32's
    s32 = _stream_at(2, kf.ARFieldModel([0.9, 0.8], [1, 1]), (3,), dtype=np.float32)
    state = s32.__getstate__()
    state["history"] = [np.full(3, 1e38, np.float32)]
    with pytest.raises(ValueError, match="can carry"):
        _load(state)


def test_a_loaded_history_is_read_only_and_continues_as_the_reference():
    stream = _stream_at(1)
    state = stream.__getstate__()
    state["history"] = [np.arange(20.0).reshape(4, 5)]
    loaded = _load(state)
    assert not loaded._history[0].flags.writeable
    noise = np.random.default_rng(3).standard_normal((4, 5))
    model = stream.model
    want = ref.stream_frame(model.rho, model.order, model.sigma, state["history"], 1, noise)
    np.testing.assert_allclose(loaded.next_frame(noise=noise), want, rtol=1e-9, atol=1e-12)


def test_take_refuses_a_stack_beyond_memory_at_once_and_leaves_the_stream_unchanged():
    """(take(2**62) on 4×4 frames ran for ever; take(10**6) on 512² frames made 3.9 GB of
    frames before failing, the stream advanced)"""
    stream = _stream_at(3, shape=(4, 4))
    state = stream.__getstate__()
    with pytest.raises(MemoryError, match="GiB"):
        stream.take(2**62)
    with pytest.raises(MemoryError, match="GiB"):
        _stream_at(0, shape=(512, 512)).take(10**8)
    assert stream.time == 3
    assert all(a is b for a, b in zip(stream._history, state["history"]))
    np.testing.assert_array_equal(stream.take(2), _load(state).take(2))


def test_take_that_fails_midway_leaves_the_stream_where_it_was(monkeypatch):
    stream = _stream_at(2, shape=(4, 4))
    want = _load(stream.__getstate__()).take(3)
    calls = []
    real_step = stream._step

    def failing_step(given):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real_step(given)

    monkeypatch.setattr(stream, "_step", failing_step)
    with pytest.raises(KeyboardInterrupt):
        stream.take(5)
    monkeypatch.undo()
    assert stream.time == 2
    np.testing.assert_array_equal(stream.take(3), want)


def test_a_frame_shape_beyond_memory_is_refused_at_construction():
    with pytest.raises(MemoryError, match="GiB"):
        kf.ARFieldModel([0.9, 0.8, 0.7], [2, 1, 1]).stream((10**6, 10**6), seed=0)


def test_a_stream_in_use_by_another_thread_is_refused():
    """(two threads calling next() on one stream got 3 of 40 frames right)"""
    stream = _stream_at(1)
    errors = []
    stream._lock.acquire()  # as a call in progress in another thread would
    try:
        worker = threading.Thread(target=lambda: _record(errors, lambda: next(stream)))
        worker.start()
        worker.join()
        for call in (lambda: stream.take(2), stream.__getstate__, lambda: pickle.dumps(stream)):
            with pytest.raises(RuntimeError, match="FieldStream is already in use"):
                call()
    finally:
        stream._lock.release()
    assert len(errors) == 1 and isinstance(errors[0], RuntimeError)
    assert "FieldStream is already in use by another thread" in str(errors[0])
    assert stream.time == 1
    next(stream)  # free again
    assert stream.time == 2


def _record(errors, call):
    try:
        call()
    except Exception as err:  # noqa: BLE001 - the test inspects it
        errors.append(err)


def test_two_threads_drawing_from_one_stream_never_corrupt_it():
    """Whatever the interleaving, the frames drawn are a prefix of the one-thread sequence,
    each exactly once, and every other call was refused with RuntimeError."""
    model = kf.ARFieldModel([0.9, 0.8, 0.7], [2, 1, 1])
    want = model.stream((300, 300), seed=4).take(12)  # above the parallel threshold
    stream = model.stream((300, 300), seed=4)
    barrier = threading.Barrier(2)
    got, refused = [], []

    def draw():
        barrier.wait()
        for _ in range(6):
            try:
                got.append(next(stream))
            except RuntimeError as err:
                refused.append(err)

    workers = [threading.Thread(target=draw) for _ in range(2)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    assert len(got) + len(refused) == 12 and stream.time == len(got)
    matched = sorted(next(t for t in range(12) if np.array_equal(f, want[t])) for f in got)
    assert matched == list(range(len(got)))
    assert all("already in use" in str(e) for e in refused)
    np.testing.assert_array_equal(stream.take(12 - len(got)), want[len(got) :])


def test_given_noise_whose_frame_overflows_is_refused_and_the_stream_unchanged():
    """(sample(shape, noise=np.full(shape, 1e308)) returned NaN and inf, float32 too)"""
    for dtype, big in ((np.float64, 1e308), (np.float32, 1e38)):
        stream = _stream_at(3, dtype=dtype)
        frame_before = stream._history[0]
        with pytest.raises(ValueError, match="given noise"):
            stream.next_frame(noise=np.full((4, 5), big))
        assert stream.time == 3 and stream._history[0] is frame_before
        assert np.isfinite(stream.next_frame(noise=np.ones((4, 5)))).all()
